//! Russian roulette does not count passes through non-diffuse interfaces
//! (`integrator::path::RR_MIN_DEPTH`): a camera looks at an emitter through six tinted
//! glass sheets of IOR 1. The path is then a fixed chain of six transmissions and one hit,
//! its throughput 0.7^6 = 0.12 well under the roulette's threshold; if the veils counted as
//! vertices the roulette would end about half the paths at the fifth and sixth veil and the
//! pixels would scatter by tens of percent. Not counting them, every path reaches the emitter
//! and the pixels only differ by the wavelengths they sampled.

mod common;

use common::scenes::{camera, emissive_material, quad_mesh, render_mean};
use glam::{Mat4, Vec3};
use prism::scene::{InstanceDesc, MaterialDesc, SceneDesc};

/// A smooth, thin, tinted glass sheet of IOR 1 (KHR_materials_transmission): every ray
/// passes straight through it with the tint, a specular transmission.
fn veil(tint: f32) -> MaterialDesc {
    let mut m = common::scenes::diffuse_material("veil", Vec3::splat(tint));
    m.gltf.transmission = 1.0;
    m.gltf.roughness = 0.0;
    m.gltf.ior = 1.0;
    m.gltf.specular = 1.0;
    m.gltf.double_sided = true;
    m
}

/// Mean RGB and the relative spread (standard deviation over mean) of the pixels' luminance,
/// seeing an emitter through `veils` veils of grey `tint`.
fn through_veils(veils: usize, tint: f32) -> (Vec3, f32) {
    let mut meshes = vec![quad_mesh(
        "emitter",
        Vec3::new(0.0, 0.0, -1.0),
        Vec3::X * 5.0,
        Vec3::Y * 5.0,
        0,
    )];
    for k in 0..veils {
        meshes.push(quad_mesh(
            &format!("veil{k}"),
            Vec3::new(0.0, 0.0, 0.2 * k as f32),
            Vec3::X * 5.0,
            Vec3::Y * 5.0,
            1,
        ));
    }
    let instances = (0..meshes.len())
        .map(|mesh| InstanceDesc {
            mesh,
            object_to_world: Mat4::IDENTITY,
            name: format!("i{mesh}"),
        })
        .collect();
    let desc = SceneDesc {
        meshes,
        instances,
        materials: vec![
            emissive_material("emitter", Vec3::splat(2.0), false),
            veil(tint),
        ],
        camera: Some(camera(3.0, 0.3)),
        ..Default::default()
    };
    let (mean, img) = render_mean(desc, 16, 16, 16, 7);
    let lum: Vec<f32> = img
        .iter()
        .map(|p| 0.2126 * p[0] + 0.7152 * p[1] + 0.0722 * p[2])
        .collect();
    let m = lum.iter().sum::<f32>() / lum.len() as f32;
    let var = lum.iter().map(|l| (l - m).powi(2)).sum::<f32>() / lum.len() as f32;
    (mean, var.sqrt() / m)
}

#[test]
fn transmissions_do_not_bring_the_roulette_closer() {
    let (one, spread_one) = through_veils(1, 0.7f32.powi(6));
    let (six, spread_six) = through_veils(6, 0.7);
    eprintln!("one veil {one} spread {spread_one}; six veils {six} spread {spread_six}");
    // Same light either way (the tint's RGB round trip compounds over six veils: 3%).
    let ratio = six / one;
    assert!(
        (ratio - Vec3::ONE).abs().max_element() < 0.03,
        "six veils of 0.7 pass {ratio} of one veil of 0.7^6"
    );
    // And as little noise as the single veil: only the wavelengths vary.
    assert!(
        spread_six < 2.0 * spread_one + 0.01,
        "six veils: pixel spread {spread_six} against {spread_one} through one"
    );
}
