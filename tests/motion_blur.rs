//! Transform motion blur (issue 13): moving objects and a moving camera blur as the time
//! average over the shutter, with closed-form profiles; a moving emitter lights a floor as the
//! average of still renders over the shutter (its light samples and MIS follow the path's
//! time); `prism_motion` in glTF node extras is read, and malformed motion is refused.

mod common;
#[path = "common/gltf_builder.rs"]
mod gltf_builder;

use common::scenes::{camera, diffuse_material, emissive_material, quad_mesh};
use glam::{Mat4, Vec2, Vec3};
use gltf_builder::{test_dir, GltfBuilder};
use prism::film::PixelFilter;
use prism::render::{render_quiet, RenderSettings};
use prism::scene::{
    load_scene, DeformationDesc, InstanceDesc, InstanceVisibility, Scene, SceneDesc,
};
use serde_json::{json, Value};

const SIZE: u32 = 64;
/// The orthographic view spans [-2, 2] in x and y: 16 pixels per unit.
const HALF_VIEW: f32 = 2.0;

/// An emissive 1 x 2 quad (radiance 1, facing the camera) seen by an orthographic camera
/// looking down -z, over a black world.
fn strip_scene(quad: Mat4, quad_motion: Vec<Mat4>, camera_motion: Vec<Mat4>) -> SceneDesc {
    let mut cam = camera(5.0, 0.5);
    cam.orthographic = Some(Vec2::splat(HALF_VIEW));
    cam.motion = camera_motion;
    SceneDesc {
        meshes: vec![quad_mesh("strip", Vec3::ZERO, 0.5 * Vec3::X, Vec3::Y, 0)],
        instances: vec![InstanceDesc {
            mesh: 0,
            object_to_world: quad,
            name: "strip".into(),
        }],
        instance_motion: if quad_motion.is_empty() {
            vec![]
        } else {
            vec![quad_motion]
        },
        materials: vec![emissive_material("glow", Vec3::ONE, false)],
        camera: Some(cam),
        ..Default::default()
    }
}

fn render(desc: SceneDesc, size: u32, spp: u32) -> Vec<[f32; 4]> {
    let scene = Scene::build(desc).expect("scene builds");
    let settings = RenderSettings {
        width: size,
        height: size,
        spp,
        max_depth: 4,
        seed: 7,
        filter: PixelFilter::unit_box(),
        ..Default::default()
    };
    let (film, stats) = render_quiet(&scene, &settings);
    assert_eq!(stats.discarded, 0, "non-finite samples");
    film.to_rgba()
}

/// Mean luminance-ish (green) of each column over the rows |y| < 0.8 (inside the strip).
fn column_profile(px: &[[f32; 4]]) -> Vec<f32> {
    let rows: Vec<usize> = (0..SIZE as usize)
        .filter(|&r| {
            let y = HALF_VIEW - (r as f32 + 0.5) * 2.0 * HALF_VIEW / SIZE as f32;
            y.abs() < 0.8
        })
        .collect();
    (0..SIZE as usize)
        .map(|c| {
            rows.iter()
                .map(|&r| px[r * SIZE as usize + c][1])
                .sum::<f32>()
                / rows.len() as f32
        })
        .collect()
}

/// The strip (width 1) swept uniformly over one width, centred at x = 0: each point x is
/// covered for a fraction max(0, 1 - |x|) of the shutter; averaged over the pixel's width.
fn triangle_profile() -> Vec<f32> {
    let px = 2.0 * HALF_VIEW / SIZE as f32;
    (0..SIZE)
        .map(|c| {
            let x0 = -HALF_VIEW + c as f32 * px;
            (0..64)
                .map(|k| {
                    let x = x0 + (k as f32 + 0.5) / 64.0 * px;
                    (1.0 - x.abs()).max(0.0)
                })
                .sum::<f32>()
                / 64.0
        })
        .collect()
}

fn assert_profile(got: &[f32], want: &[f32], what: &str) {
    for (c, (g, w)) in got.iter().zip(want).enumerate() {
        assert!(
            (g - w).abs() < 0.05,
            "{what}: column {c}: got {g:.3}, want {w:.3}\ngot  {got:.2?}\nwant {want:.2?}"
        );
    }
}

#[test]
fn a_moving_object_blurs_into_the_time_average() {
    let keys = vec![
        Mat4::from_translation(Vec3::new(-0.5, 0.0, 0.0)),
        Mat4::from_translation(Vec3::new(0.5, 0.0, 0.0)),
    ];
    let px = render(strip_scene(Mat4::IDENTITY, keys, vec![]), SIZE, 64);
    assert_profile(&column_profile(&px), &triangle_profile(), "moving strip");
}

#[test]
fn three_keys_move_piecewise() {
    // Over three keys the strip goes -0.5 -> 0 -> 0.5: the same uniform sweep.
    let keys = [-0.5, 0.0, 0.5]
        .map(|x| Mat4::from_translation(Vec3::new(x, 0.0, 0.0)))
        .to_vec();
    let px = render(strip_scene(Mat4::IDENTITY, keys, vec![]), SIZE, 64);
    assert_profile(&column_profile(&px), &triangle_profile(), "three keys");
}

#[test]
fn a_moving_camera_blurs_the_still_scene() {
    // The camera moving +0.5 -> -0.5 sees the still strip sweep -0.5 -> +0.5.
    let keys = [0.5, -0.5]
        .map(|x| Mat4::from_translation(Vec3::new(x, 0.0, 5.0)))
        .to_vec();
    let px = render(strip_scene(Mat4::IDENTITY, vec![], keys), SIZE, 64);
    assert_profile(&column_profile(&px), &triangle_profile(), "moving camera");
}

#[test]
fn a_still_scene_is_sharp() {
    // The check above fails without blur: the still strip's profile is a box.
    let px = render(strip_scene(Mat4::IDENTITY, vec![], vec![]), SIZE, 16);
    let got = column_profile(&px);
    assert!(
        got[SIZE as usize / 2] > 0.97 && got[SIZE as usize / 2 + 12] < 0.01,
        "{got:?}"
    );
}

/// A 6 x 6 diffuse floor at z = 0 under a 1 x 1 emitter at height 0.6 facing down (hidden
/// from the camera), seen from above by an orthographic camera.
fn lit_floor(light: Mat4, light_motion: Vec<Mat4>) -> SceneDesc {
    let mut cam = camera(5.0, 0.5);
    cam.orthographic = Some(Vec2::splat(HALF_VIEW));
    SceneDesc {
        meshes: vec![
            quad_mesh("floor", Vec3::ZERO, 3.0 * Vec3::X, 3.0 * Vec3::Y, 0),
            quad_mesh(
                "light",
                Vec3::new(0.0, 0.0, 0.6),
                0.5 * Vec3::Y,
                0.5 * Vec3::X,
                1,
            ),
        ],
        instances: vec![
            InstanceDesc {
                mesh: 0,
                object_to_world: Mat4::IDENTITY,
                name: "floor".into(),
            },
            InstanceDesc {
                mesh: 1,
                object_to_world: light,
                name: "light".into(),
            },
        ],
        instance_visibility: vec![
            InstanceVisibility::default(),
            InstanceVisibility {
                camera_visible: false,
                ..Default::default()
            },
        ],
        instance_motion: vec![vec![], light_motion],
        materials: vec![
            diffuse_material("floor", Vec3::splat(0.8)),
            emissive_material("glow", Vec3::splat(4.0), false),
        ],
        camera: Some(cam),
        ..Default::default()
    }
}

/// Means of 8 x 8 pixel blocks (removes most of the per-pixel noise).
fn blocks(px: &[[f32; 4]], size: usize) -> Vec<f32> {
    let n = size / 8;
    let mut out = vec![0.0; n * n];
    for (i, p) in px.iter().enumerate() {
        let (x, y) = (i % size, i / size);
        out[(y / 8) * n + x / 8] += (p[0] + p[1] + p[2]) / (3.0 * 64.0);
    }
    out
}

/// The lit floor's blocks (256 spp) under the emitter moving -0.8 -> +0.8 in x.
fn moving_emitter_blocks(size: u32) -> Vec<f32> {
    let at = |x: f32| Mat4::from_translation(Vec3::new(x, 0.0, 0.0));
    blocks(
        &render(
            lit_floor(Mat4::IDENTITY, vec![at(-0.8), at(0.8)]),
            size,
            256,
        ),
        size as usize,
    )
}

#[test]
fn a_moving_emitter_lights_as_the_shutter_average() {
    let size = 32;
    let at = |x: f32| Mat4::from_translation(Vec3::new(x, 0.0, 0.0));
    let moving = moving_emitter_blocks(size);
    // The shutter average by the midpoint rule over 8 still positions.
    let stills: Vec<Vec<f32>> = (0..8)
        .map(|k| {
            let x = -0.8 + 1.6 * (k as f32 + 0.5) / 8.0;
            blocks(&render(lit_floor(at(x), vec![]), size, 64), size as usize)
        })
        .collect();
    let average: Vec<f32> = (0..moving.len())
        .map(|b| stills.iter().map(|s| s[b]).sum::<f32>() / 8.0)
        .collect();
    let centre_still = blocks(&render(lit_floor(at(0.0), vec![]), size, 64), size as usize);
    let mut worst = 0.0f32;
    for (b, (m, a)) in moving.iter().zip(&average).enumerate() {
        let rel = (m - a).abs() / a.max(0.05);
        worst = worst.max(rel);
        assert!(
            rel < 0.06,
            "block {b}: moving {m:.4}, shutter average {a:.4}"
        );
    }
    // And the blur is visible: the still light at the centre differs from the average.
    let differs = centre_still
        .iter()
        .zip(&average)
        .any(|(c, a)| (c - a).abs() / a.max(0.05) > 0.15);
    assert!(
        differs,
        "the test scene must show the blur (worst match {worst})"
    );
}

#[test]
fn gltf_node_motion_is_read_and_bad_motion_refused() {
    let dir = test_dir("motion_blur");
    let mut b = GltfBuilder::basic();
    let key = |x: f32| {
        Mat4::from_translation(Vec3::new(x, 0.0, 0.0))
            .to_cols_array()
            .to_vec()
    };
    // Under a parent moved by +1 in y: the keys are local, as the node's `matrix`.
    let m = b.emissive_material("Mover", 2.0);
    let q = b.quad_mesh("Mover", Some(m));
    let child = b.node(json!({
        "name": "Mover", "mesh": q,
        "extras": { "prism_motion": [key(-1.0), key(0.0), key(1.0)] }
    }));
    b.root(json!({ "name": "Parent", "translation": [0.0, 1.0, 0.0], "children": [child] }));
    let path = b.write_gltf(&dir.join("moving.gltf"));
    let desc = load_scene(&path, None, None).expect("loads");
    let i = desc
        .instances
        .iter()
        .position(|i| i.name == "Mover")
        .expect("the moving instance");
    let motion = &desc.instance_motion[i];
    assert_eq!(motion.len(), 3);
    assert!(motion[2]
        .w_axis
        .truncate()
        .abs_diff_eq(Vec3::new(1.0, 1.0, 0.0), 1e-6));

    let mut bad = GltfBuilder::basic();
    let q = bad.quad_mesh("Bad", None);
    bad.root(json!({ "name": "Bad", "mesh": q, "extras": { "prism_motion": [key(0.0)] } }));
    let path = bad.write_gltf(&dir.join("bad_motion.gltf"));
    let err = load_scene(&path, None, None).expect_err("one key is refused");
    assert!(err.to_string().contains("prism_motion"), "{err}");
}

// ------------------------------------------------------------------ deformation blur

/// Deformation keys of `mesh`: its vertices shifted along x by each of `shifts`.
fn shifted_keys(mesh: &prism::scene::MeshDesc, shifts: &[f32]) -> Option<DeformationDesc> {
    Some(DeformationDesc {
        positions: shifts
            .iter()
            .map(|&x| {
                mesh.positions
                    .iter()
                    .map(|p| *p + Vec3::new(x, 0.0, 0.0))
                    .collect()
            })
            .collect(),
        normals: None,
    })
}

/// `strip_scene` whose strip deforms: its vertices are shifted by `shifts` (one key each)
/// instead of the object moving.
fn deforming_strip(shifts: &[f32]) -> SceneDesc {
    let mut desc = strip_scene(Mat4::IDENTITY, vec![], vec![]);
    desc.meshes[0].deformation = shifted_keys(&desc.meshes[0], shifts);
    desc
}

#[test]
fn a_deforming_mesh_blurs_into_the_time_average() {
    // The strip's vertices go -0.5 -> +0.5 over the shutter (two keys, then three): the same
    // sweep as the moving object above, so the same closed-form profile.
    for shifts in [&[-0.5, 0.5][..], &[-0.5, 0.0, 0.5]] {
        let px = render(deforming_strip(shifts), SIZE, 64);
        assert_profile(
            &column_profile(&px),
            &triangle_profile(),
            &format!("deforming strip, {} keys", shifts.len()),
        );
    }
}

/// The lit floor with a 1.2 x 1.2 diffuse occluder at height 0.3 between the emitter and the
/// floor, moving -0.8 -> +0.8 in x: by its transform or by deforming its vertices.
fn shadowed_floor(deform: bool) -> SceneDesc {
    let mut desc = lit_floor(Mat4::IDENTITY, vec![]);
    desc.meshes.push(quad_mesh(
        "occluder",
        Vec3::new(0.0, 0.0, 0.3),
        0.6 * Vec3::X,
        0.6 * Vec3::Y,
        0,
    ));
    desc.instances.push(InstanceDesc {
        mesh: 2,
        object_to_world: Mat4::IDENTITY,
        name: "occluder".into(),
    });
    desc.instance_visibility.push(InstanceVisibility {
        camera_visible: false,
        ..Default::default()
    });
    let at = |x: f32| Mat4::from_translation(Vec3::new(x, 0.0, 0.0));
    if deform {
        desc.meshes[2].deformation = shifted_keys(&desc.meshes[2], &[-0.8, 0.8]);
        desc.instance_motion.push(vec![]);
    } else {
        desc.instance_motion.push(vec![at(-0.8), at(0.8)]);
    }
    desc
}

#[test]
fn a_deforming_occluder_shadows_as_a_moving_one() {
    // Shadow rays and the camera path's hits see the deforming mesh at the path's time: the
    // floor under a deforming occluder matches the floor under the same occluder moved by its
    // transform (same time samples), and differs from the still occluder's shadow.
    let size = 32;
    let moved = blocks(&render(shadowed_floor(false), size, 256), size as usize);
    let deformed = blocks(&render(shadowed_floor(true), size, 256), size as usize);
    let mut still_desc = shadowed_floor(false);
    still_desc.instance_motion[2].clear();
    let still = blocks(&render(still_desc, size, 64), size as usize);
    for (b, (d, m)) in deformed.iter().zip(&moved).enumerate() {
        assert!(
            (d - m).abs() / m.max(0.05) < 0.02,
            "block {b}: deforming {d:.4}, moving {m:.4}"
        );
    }
    assert!(
        still
            .iter()
            .zip(&moved)
            .any(|(s, m)| (s - m).abs() / m.max(0.05) > 0.15),
        "the scene must show the blurred shadow"
    );
}

#[test]
fn gltf_deformation_keys_are_read_and_bad_ones_refused() {
    let dir = test_dir("deformation_blur");
    let build = |targets: Value, flag: Value| {
        let mut b = GltfBuilder::basic();
        let m = b.emissive_material("Morph", 2.0);
        let q = b.quad_mesh("Morph", Some(m));
        let a = b.vec3(&[[-1.0, 0.0, 0.0]; 4]);
        let c = b.vec3(&[[1.0, 0.0, 0.0]; 4]);
        let targets = match targets {
            Value::Null => json!([{ "POSITION": a }, { "POSITION": c }]),
            t => t,
        };
        b.meshes[q]["primitives"][0]["targets"] = targets;
        b.meshes[q]["extras"] = json!({ "prism_deformation": flag });
        b.root(json!({ "name": "Morph", "mesh": q }));
        b
    };
    let path = build(Value::Null, json!(true)).write_gltf(&dir.join("deforming.gltf"));
    let desc = load_scene(&path, None, None).expect("loads");
    let mesh = desc
        .meshes
        .iter()
        .find(|m| m.name.contains("Morph"))
        .expect("the deforming mesh");
    let d = mesh.deformation.as_ref().expect("deformation keys");
    assert_eq!(d.positions.len(), 2);
    for (p, k0, k1) in itertools_zip(&mesh.positions, &d.positions[0], &d.positions[1]) {
        assert!((*k0 - *p).abs_diff_eq(Vec3::new(-1.0, 0.0, 0.0), 1e-6));
        assert!((*k1 - *p).abs_diff_eq(Vec3::new(1.0, 0.0, 0.0), 1e-6));
    }
    // Without the flag, morph targets stay blend shapes (weights 0: the base mesh).
    let path = build(Value::Null, json!(false)).write_gltf(&dir.join("morph.gltf"));
    let desc = load_scene(&path, None, None).expect("loads");
    assert!(desc.meshes.iter().all(|m| m.deformation.is_none()));
    for (targets, flag, want) in [
        (
            json!([{ "POSITION": 0 }]),
            json!(true),
            "at least two morph targets",
        ),
        (
            json!([{}, {}]),
            json!(true),
            "a deformation key needs POSITION",
        ),
        (
            Value::Null,
            json!("yes"),
            "prism_deformation must be true or false",
        ),
    ] {
        let path = build(targets, flag).write_gltf(&dir.join("bad_deformation.gltf"));
        let err = load_scene(&path, None, None).expect_err(want).to_string();
        assert!(err.contains(want), "{err}");
        assert!(!err.contains('\n'), "{err}");
    }
}

fn itertools_zip<'a>(
    a: &'a [Vec3],
    b: &'a [Vec3],
    c: &'a [Vec3],
) -> impl Iterator<Item = (&'a Vec3, &'a Vec3, &'a Vec3)> {
    a.iter().zip(b).zip(c).map(|((x, y), z)| (x, y, z))
}

#[test]
fn a_deforming_emitter_lights_as_a_moving_one() {
    // The emitter's vertices go -0.8 -> +0.8 in x (deformation keys) instead of its transform:
    // camera paths that hit it and light samples on it both follow the path's time, so the lit
    // floor matches the moving emitter's (same time samples; the light tree's bounds are the
    // swept box either way).
    let size = 32;
    let moving = moving_emitter_blocks(size);
    let mut desc = lit_floor(Mat4::IDENTITY, vec![]);
    desc.meshes[1].deformation = shifted_keys(&desc.meshes[1], &[-0.8, 0.8]);
    let deforming = blocks(&render(desc, size, 256), size as usize);
    for (b, (d, m)) in deforming.iter().zip(&moving).enumerate() {
        assert!(
            (d - m).abs() / m.max(0.05) < 0.04,
            "block {b}: deforming {d:.4}, moving {m:.4}"
        );
    }
}
