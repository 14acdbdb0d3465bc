#![allow(dead_code)]
pub mod scenes;

/// The Open Image Denoise library the denoising tests use: `$PRISM_TEST_OIDN` (a file or a
/// folder), else the one in the bpy wheel that `tests/addon/run_addon_tests.sh install` puts
/// in `.venv-bpy` (scripts/test.sh runs it first). Panics when there is none: a denoising
/// test that skipped itself would pass with the feature broken.
pub fn oidn_library() -> std::path::PathBuf {
    if let Some(p) = std::env::var_os("PRISM_TEST_OIDN") {
        return p.into();
    }
    let venv_lib = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join(".venv-bpy/lib");
    if let Ok(entries) = std::fs::read_dir(&venv_lib) {
        for e in entries.flatten() {
            let dir = e.path().join("site-packages/bpy/lib");
            if dir.join("libOpenImageDenoise.so.2").is_file() {
                return dir;
            }
        }
    }
    panic!(
        "no Open Image Denoise library for the tests: run `tests/addon/run_addon_tests.sh install` \
         (installs the bpy wheel, which ships OIDN) or set PRISM_TEST_OIDN"
    );
}

/// Does every elementary interval of area 1/n (n = points.len(), a power of 2) hold exactly
/// one point? (The stratification of a (0, k, 2)-net in base 2.)
pub fn is_net(points: &[glam::Vec2]) -> bool {
    let k = points.len().trailing_zeros();
    (0..=k).all(|a| {
        let (nx, ny) = (1u32 << a, 1u32 << (k - a));
        let mut seen = vec![false; points.len()];
        points.iter().all(|p| {
            let cell = ((p.x * nx as f32) as u32).min(nx - 1) * ny
                + ((p.y * ny as f32) as u32).min(ny - 1);
            !std::mem::replace(&mut seen[cell as usize], true)
        })
    })
}
