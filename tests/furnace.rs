//! White furnace tests: objects that neither absorb nor emit, inside a uniform white world,
//! must be invisible (every pixel equals the world radiance). This checks the whole transport
//! chain at once: MIS weights, light and BSDF pdfs, spectral upsampling and the film.

mod common;

use common::scenes::{diffuse_material, furnace_scene, glass_material};
use glam::Vec3;
use prism::scene::{IorDesc, SceneDesc};

fn render_mean(desc: SceneDesc, spp: u32) -> (Vec3, Vec<[f32; 4]>) {
    common::scenes::render_mean(desc, 32, spp, 64, 7)
}

/// Mean colour of a block of pixels of a 32x32 image (single pixels carry a few percent of
/// spectral noise at these sample counts; blocks average it out).
fn region_mean(rgba: &[[f32; 4]], xs: std::ops::Range<usize>, ys: std::ops::Range<usize>) -> Vec3 {
    let mut sum = Vec3::ZERO;
    let mut n = 0.0;
    for y in ys {
        for x in xs.clone() {
            let p = rgba[y * 32 + x];
            sum += Vec3::new(p[0], p[1], p[2]);
            n += 1.0;
        }
    }
    sum / n
}

fn assert_furnace(desc: SceneDesc, spp: u32, tol: f32) {
    let (mean, rgba) = render_mean(desc, spp);
    for c in mean.to_array() {
        assert!(
            (c - 1.0).abs() < tol,
            "furnace mean {mean} deviates from 1 by more than {tol}"
        );
    }
    // The central 8x8 pixels see the sphere itself: they too must be 1.
    let centre = region_mean(&rgba, 12..20, 12..20);
    for c in centre.to_array() {
        assert!(
            (c - 1.0).abs() < 2.0 * tol,
            "sphere centre {centre} is not 1"
        );
    }
}

#[test]
fn white_furnace_diffuse_albedo_one() {
    assert_furnace(
        furnace_scene(diffuse_material("white", Vec3::ONE), Vec3::ONE),
        64,
        0.01,
    );
}

#[test]
fn white_furnace_smooth_dielectric() {
    let glass = glass_material("glass", IorDesc::Constant(1.5), 0.0);
    assert_furnace(furnace_scene(glass, Vec3::ONE), 64, 0.01);
}

#[test]
fn grey_world_scales_linearly() {
    // A grey world of 0.25 with a diffuse sphere of albedo 0.5: the background is 0.25 and
    // the sphere (single bounce, convex) 0.125.
    let (_, rgba) = render_mean(
        furnace_scene(
            diffuse_material("grey", Vec3::splat(0.5)),
            Vec3::splat(0.25),
        ),
        64,
    );
    let corner = region_mean(&rgba, 0..6, 0..6);
    let centre = region_mean(&rgba, 12..20, 12..20);
    for c in 0..3 {
        assert!((corner[c] - 0.25).abs() < 0.005, "background {corner}");
        assert!((centre[c] - 0.125).abs() < 0.0025, "sphere {centre}");
    }
}

/// Strongly dispersive smooth glass: each refraction leaves the hero wavelength alone (the
/// other wavelengths refract elsewhere) and the hero-MIS weights must then make it an unbiased
/// estimate on its own; reflections keep all four. Any error in those weights shows as a
/// coloured or darker sphere.
#[test]
fn white_furnace_smooth_dispersive_dielectric() {
    let flint = IorDesc::Cauchy {
        a: 1.6,
        b: 0.04,
        c: 0.0,
    };
    let glass = glass_material("flint", flint, 0.0);
    assert_furnace(furnace_scene(glass, Vec3::ONE), 256, 0.01);
}

/// Energy-conserving rough materials (the default model): a rough white conductor, a white
/// Principled (dielectric specular over a white base) and rough glass are invisible in the
/// white furnace through the whole renderer; the glTF spec's single-scattering BRDF
/// (`"model": "gltf"`) is visibly darker for the rough metal.
#[test]
fn white_furnace_energy_conserving_rough_materials() {
    use prism::scene::GltfMaterialDesc;
    let principled = |metallic: f32, roughness: f32, gltf_brdf: bool| {
        let mut m = common::scenes::material_with(
            GltfMaterialDesc {
                name: "principled".into(),
                base_color: glam::Vec4::ONE,
                metallic,
                roughness,
                ..Default::default()
            },
            None,
        );
        m.gltf_brdf = gltf_brdf;
        m
    };
    for (metallic, roughness) in [(1.0, 0.6), (1.0, 1.0), (0.0, 0.5), (0.0, 1.0)] {
        assert_furnace(
            furnace_scene(principled(metallic, roughness, false), Vec3::ONE),
            64,
            0.015,
        );
    }
    for roughness in [0.5, 1.0] {
        let glass = glass_material("glass", IorDesc::Constant(1.5), roughness);
        assert_furnace(furnace_scene(glass, Vec3::ONE), 64, 0.015);
    }
    let (_, rgba) = render_mean(furnace_scene(principled(1.0, 1.0, true), Vec3::ONE), 64);
    let centre = region_mean(&rgba, 12..20, 12..20);
    assert!(
        centre.max_element() < 0.9,
        "single-scattering rough metal {centre}"
    );
}
