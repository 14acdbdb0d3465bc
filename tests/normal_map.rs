//! Tangent-space normal maps (glTF `normalTexture`), checked against physics rather than
//! reference images.
//!
//! The main scene: a large flat Lambertian plane (albedo 0.5) in y = 0, seen from straight
//! above, lit by a directional light of irradiance E = pi W/m^2 (glTF lux = E x 683) and
//! nothing else (black world, one bounce). Its radiance is
//!
//! ```text
//! L = albedo / pi * E * max(0, n . l) = 0.5 * max(0, n . l)
//! ```
//!
//! with n the normal-mapped shading normal, times the bump-terminator shadowing factor G of
//! Conty Estevez, Lecocq & Stein 2019 (Ray Tracing Gems ch. 12) that Prism, like Cycles,
//! applies to normal-mapped diffuse lobes: G = 2 / (1 + sqrt(1 + a2 tan^2 t_i)), a2 =
//! tan^2(t_d) / 8, t_d the tilt of n from the plane's normal N, t_i the light's angle from N
//! (G = 1 for an untilted map; 0.99 for the cases below, 0.94 in the grazing one). The
//! expected n is computed here from the
//! definition of tangent space (glTF 2.0 spec 3.7.2.1 and 5.23): +X of the map along
//! increasing u, +Y towards the top of the image (decreasing glTF v), +Z along the surface
//! normal, in the world, from the plane's world-space corners and UVs -- independently of
//! how the renderer orients its tangent frames (TANGENT w, mirroring transforms).
//!
//! Tolerance: the mean of 8x8 pixels x 64 samples of a pure direct-lighting estimate with a
//! delta light has only spectral noise (hero wavelengths, grey albedo, white light) and the
//! RGB -> spectrum -> RGB round trip of grey: measured 0.02% (all cases). 0.5% relative keeps
//! a margin for other seeds/platforms while a tilt error of 1 degree already moves n . l by
//! 1-3% for the light used here (and a wrong handedness by 30-100%).

mod common;
#[path = "common/gltf_builder.rs"]
mod gltf_builder;

use std::f32::consts::PI;
use std::path::PathBuf;

use common::scenes::{diffuse_material, furnace_scene};
use glam::{Mat4, Quat, Vec2, Vec3, Vec4};
use gltf_builder::*;
use prism::render::{render_quiet, RenderSettings};
use prism::scene::{load_scene, Scene, TextureDesc, TextureRef};
use serde_json::json;

/// Half size of the plane (the camera sees a ~0.3 wide patch at its centre).
const HALF: f32 = 10.0;

#[derive(Clone, Copy)]
enum Tangents {
    /// No TANGENT attribute: the renderer derives them from the UVs.
    Generated,
    /// A TANGENT attribute (the exact tangents of the plane's UV mapping).
    Attribute,
}

#[derive(Clone, Copy)]
struct Case {
    tangents: Tangents,
    /// u decreases along +x (a mirrored UV layout: left-handed tangent frame).
    mirror_u: bool,
    /// normalTexture.scale.
    scale: f32,
    /// The plane node's transform.
    node: Mat4,
}

impl Case {
    fn new(tangents: Tangents) -> Self {
        Case {
            tangents,
            mirror_u: false,
            scale: 1.0,
            node: Mat4::IDENTITY,
        }
    }
}

/// Object-space corners of the plane (winding gives +y) and their UVs.
fn plane_vertices(mirror_u: bool) -> ([[f32; 3]; 4], [[f32; 2]; 4]) {
    let p = [
        [-HALF, 0.0, -HALF],
        [HALF, 0.0, -HALF],
        [HALF, 0.0, HALF],
        [-HALF, 0.0, HALF],
    ];
    let uv = p.map(|v| {
        let u = (v[0] + HALF) / (2.0 * HALF);
        [
            if mirror_u { 1.0 - u } else { u },
            (v[2] + HALF) / (2.0 * HALF),
        ]
    });
    (p, uv)
}

/// The 8-bit RGB encoding of a unit tangent-space normal.
fn encode(n: Vec3) -> [u8; 3] {
    let c = (n * 0.5 + Vec3::splat(0.5)) * 255.0;
    [c.x.round() as u8, c.y.round() as u8, c.z.round() as u8]
}

/// glTF 2.0 spec 5.23: the tangent-space normal a texel stands for.
fn decode(c: [u8; 3], scale: f32) -> Vec3 {
    let v = Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32) / 255.0 * 2.0 - Vec3::ONE;
    (v * Vec3::new(scale, scale, 1.0)).normalize()
}

/// Direction towards the light (unit).
fn light_dir() -> Vec3 {
    Vec3::new(0.8, 1.0, -0.5).normalize()
}

/// Writes the plane scene; `texel` is the constant normal map (None: no normal map).
fn write_plane(dir: &std::path::Path, case: Case, texel: Option<Vec<u8>>) -> PathBuf {
    write_plane_lit(dir, case, texel, light_dir())
}

/// [`write_plane`] with the light coming from `l` (unit, towards the light).
fn write_plane_lit(dir: &std::path::Path, case: Case, texel: Option<Vec<u8>>, l: Vec3) -> PathBuf {
    let mut b = GltfBuilder::new();
    b.use_ext("KHR_materials_specular");
    let (p, uv) = plane_vertices(case.mirror_u);
    let pos = b.positions(&p);
    let nrm = b.vec3(&[[0.0, 1.0, 0.0]; 4]);
    let tc = b.vec2(&uv);
    let idx = b.indices_u16(&[0, 2, 1, 0, 3, 2]);
    let mut material = json!({
        "name": "Plane",
        "pbrMetallicRoughness": {
            "baseColorFactor": [0.5, 0.5, 0.5, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0
        },
        "extensions": { "KHR_materials_specular": { "specularFactor": 0.0 } }
    });
    if let Some(png) = texel {
        let img = b.image_embedded(&png, "image/png");
        let tex = b.texture(img, None);
        material["normalTexture"] = json!({ "index": tex, "scale": case.scale });
    }
    let mat = b.material(material);
    let mut prim = GltfBuilder::prim(pos, Some(idx), Some(mat), TRIANGLES);
    prim["attributes"]["NORMAL"] = json!(nrm);
    prim["attributes"]["TEXCOORD_0"] = json!(tc);
    if let Tangents::Attribute = case.tangents {
        // u runs along +x (or -x when mirrored); "up" in the image is -z (v grows along +z);
        // w = sign of (cross(n, t) . up): cross(+y, +x) = -z, so +1, and -1 when mirrored.
        let t = if case.mirror_u {
            [-1.0, 0.0, 0.0, -1.0]
        } else {
            [1.0, 0.0, 0.0, 1.0]
        };
        prim["attributes"]["TANGENT"] = json!(b.vec4(&[t; 4]));
    }
    let mesh = b.mesh("Plane", vec![prim]);
    b.root(json!({ "name": "Plane", "mesh": mesh, "matrix": case.node.to_cols_array() }));
    let light = b.light(json!({
        "name": "Sun", "type": "directional", "intensity": PI * 683.0
    }));
    // The light travels along -light_dir(); a glTF light shines down its node's -z.
    let rot = Quat::from_rotation_arc(Vec3::NEG_Z, -l);
    b.root(json!({
        "name": "Sun", "rotation": rot.to_array(),
        "extensions": { "KHR_lights_punctual": { "light": light } }
    }));
    let cam = b.camera("Cam", 0.1, Some(1.0));
    let cam_rot = Quat::from_rotation_x(-PI / 2.0);
    b.root(json!({
        "name": "Cam", "camera": cam, "translation": [0.0, 3.0, 0.0], "rotation": cam_rot.to_array()
    }));
    b.write_gltf(&dir.join("plane.gltf"))
}

fn render(path: &std::path::Path, max_depth: u32) -> Vec<[f32; 4]> {
    let desc = load_scene(path, None, None).expect("scene loads");
    assert!(
        desc.warnings.is_empty(),
        "unexpected warnings: {:?}",
        desc.warnings
    );
    let scene = Scene::build(desc).expect("scene builds");
    let settings = RenderSettings {
        width: 8,
        height: 8,
        spp: 64,
        max_depth,
        seed: 11,
        ..Default::default()
    };
    let (film, stats) = render_quiet(&scene, &settings);
    assert_eq!(stats.discarded, 0);
    film.to_rgba()
}

fn mean(px: &[[f32; 4]]) -> Vec3 {
    px.iter().map(|p| Vec3::new(p[0], p[1], p[2])).sum::<Vec3>() / px.len() as f32
}

/// The world-space mapped normal by the definition of tangent space, from the plane's world
/// corners and UVs (the UV mapping is affine, so dp/du and dp/dv are constant).
fn expected_normal(case: Case, nt: Vec3) -> Vec3 {
    let (p, uv) = plane_vertices(case.mirror_u);
    let w = |i: usize| case.node.transform_point3(Vec3::from_array(p[i]));
    let (e1, e2) = (w(1) - w(0), w(3) - w(0));
    let (d1, d2) = (
        Vec2::from_array(uv[1]) - Vec2::from_array(uv[0]),
        Vec2::from_array(uv[3]) - Vec2::from_array(uv[0]),
    );
    let det = d1.x * d2.y - d1.y * d2.x;
    let dpdu = (e1 * d2.y - e2 * d1.y) / det;
    let dpdv = (e2 * d1.x - e1 * d2.x) / det;
    // Normals transform by the inverse transpose.
    let m3 = glam::Mat3::from_mat4(case.node);
    let n = (m3.inverse().transpose() * Vec3::Y).normalize();
    let t = dpdu.normalize();
    let up = (-dpdv).normalize();
    assert!(t.dot(up).abs() < 1e-5 && t.dot(n).abs() < 1e-5);
    (t * nt.x + up * nt.y + n * nt.z).normalize()
}

/// The plane's world normal.
fn plane_normal(case: Case) -> Vec3 {
    let m3 = glam::Mat3::from_mat4(case.node);
    (m3.inverse().transpose() * Vec3::Y).normalize()
}

/// Conty Estevez et al. 2019 shadowing (closed form, see the file comment).
fn conty_g(n_smooth: Vec3, n: Vec3, l: Vec3) -> f32 {
    let (cd, ci) = (n_smooth.dot(n) as f64, n_smooth.dot(l) as f64);
    let a2 = ((1.0 - cd * cd) / (cd * cd) / 8.0).min(1.0);
    let t2 = (1.0 - ci * ci) / (ci * ci);
    (2.0 / (1.0 + (1.0 + a2 * t2).sqrt())) as f32
}

/// Renders `case` with a constant normal map encoding `nt` and compares with the analytic
/// radiance; returns the relative error.
fn check(name: &str, case: Case, nt: Vec3) -> f32 {
    check_with_light(name, case, nt, light_dir())
}

fn check_with_light(name: &str, case: Case, nt: Vec3, l: Vec3) -> f32 {
    let dir = test_dir(&format!("normal_map_{name}"));
    let c = encode(nt.normalize());
    let png = png_bytes(1, 1, &[[c[0], c[1], c[2], 255]]);
    let path = write_plane_lit(&dir, case, Some(png), l);
    let got = mean(&render(&path, 1));
    let n = expected_normal(case, decode(c, case.scale));
    let g = conty_g(plane_normal(case), n, l);
    let want = 0.5 * n.dot(l).max(0.0) * g;
    let flat = 0.5 * expected_normal(case, Vec3::Z).dot(l);
    let err = (got - Vec3::splat(want)).abs().max_element() / want;
    eprintln!(
        "{name}: got {got}, analytic {want:.5} (G {g:.4}; unperturbed {flat:.5}), rel. error {err:.5}"
    );
    assert!(
        err < 0.005,
        "{name}: radiance {got} vs analytic {want} (unperturbed {flat}); relative error {err}"
    );
    // The map must matter (else the comparison would be vacuous).
    assert!((want - flat).abs() > 0.05 * flat, "{name}: tilt too small");
    err
}

/// A tilt with components along both tangent axes (each with a different effect on n . l).
fn tilt() -> Vec3 {
    Vec3::new(-0.45, 0.3, 0.84)
}

#[test]
fn generated_tangents_match_analytic_radiance() {
    check("generated", Case::new(Tangents::Generated), tilt());
}

#[test]
fn tangent_attribute_matches_analytic_radiance() {
    check("attribute", Case::new(Tangents::Attribute), tilt());
}

#[test]
fn mirrored_uvs_flip_the_tangent_frame() {
    for t in [Tangents::Generated, Tangents::Attribute] {
        let case = Case {
            mirror_u: true,
            ..Case::new(t)
        };
        let name = match t {
            Tangents::Generated => "mirrored_generated",
            Tangents::Attribute => "mirrored_attribute",
        };
        check(name, case, tilt());
    }
}

#[test]
fn scale_multiplies_x_and_y() {
    for (t, name) in [
        (Tangents::Generated, "scale_generated"),
        (Tangents::Attribute, "scale_attribute"),
    ] {
        let case = Case {
            scale: 0.4,
            ..Case::new(t)
        };
        check(name, case, Vec3::new(-0.6, 0.45, 0.66));
    }
}

/// A grazing light (69 degrees from the normal) on a map tilted towards it: the shadowing
/// factor G is 0.94 here, and the radiance must follow n . l x G.
#[test]
fn grazing_light_gets_the_bump_terminator_shadowing() {
    let l = Vec3::new(0.9, 0.36, 0.25).normalize();
    check_with_light(
        "grazing",
        Case::new(Tangents::Generated),
        Vec3::new(0.45, -0.2, 0.87),
        l,
    );
}

/// Instances that mirror (negative determinant), rotate and scale non-uniformly: the
/// TANGENT attribute goes through the matrix with the handedness flip, generated tangents
/// come from world-space edges; both must give the mapped normal of the placed surface.
#[test]
fn mirroring_and_non_uniform_instances() {
    let node = Mat4::from_rotation_y(0.6) * Mat4::from_scale(Vec3::new(-1.5, 1.0, 0.7));
    for (t, name) in [
        (Tangents::Generated, "instance_generated"),
        (Tangents::Attribute, "instance_attribute"),
    ] {
        check(
            name,
            Case {
                node,
                ..Case::new(t)
            },
            tilt(),
        );
    }
}

/// A flat map (0.5, 0.5, 1) -- 16-bit so that 0.5 is (almost) exact -- renders the same image
/// as no map at all.
#[test]
fn flat_normal_map_changes_nothing() {
    let dir = test_dir("normal_map_flat");
    let none = render(&write_plane(&dir, Case::new(Tangents::Generated), None), 2);
    for t in [Tangents::Generated, Tangents::Attribute] {
        let png = png16_bytes(1, 1, &[[32768, 32768, 65535, 65535]]);
        let flat = render(&write_plane(&dir, Case::new(t), Some(png)), 2);
        let mut worst = 0.0f32;
        for (a, b) in none.iter().zip(&flat) {
            for k in 0..3 {
                worst = worst.max((a[k] - b[k]).abs() / a[k].max(1e-3));
            }
        }
        eprintln!("flat map: worst pixel relative difference {worst:e}");
        assert!(worst < 1e-3, "flat normal map changed the image by {worst}");
    }
}

/// A white furnace around a sphere whose normal map tilts by up to ~75 degrees, changing from
/// texel to texel: nothing absorbs and nothing emits, so no pixel may exceed the world's
/// radiance 1 (beyond noise): shading normals can lose energy at the geometric horizon but
/// must never create it, nor produce NaNs.
#[test]
fn furnace_with_a_wild_normal_map_gains_no_energy() {
    let n = 8u32;
    let mut rng = 0x2545_f491u32;
    let mut next = || {
        rng ^= rng << 13;
        rng ^= rng >> 17;
        rng ^= rng << 5;
        rng as f32 / u32::MAX as f32
    };
    let texels: Vec<Vec4> = (0..n * n)
        .map(|_| {
            let (phi, theta) = (2.0 * PI * next(), 1.3 * next());
            let nt = Vec3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            );
            (nt * 0.5 + Vec3::splat(0.5)).extend(1.0)
        })
        .collect();
    for (name, mut material) in [
        ("lambertian", diffuse_material("white", Vec3::ONE)),
        ("glossy", {
            let mut m = diffuse_material("glossy", Vec3::ONE);
            m.gltf.specular = 1.0;
            m.gltf.roughness = 0.3;
            m
        }),
    ] {
        material.gltf.normal_texture = Some(TextureRef {
            texture: 0,
            tex_coord: 0,
            uv_transform: glam::Mat3::IDENTITY,
        });
        let mut desc = furnace_scene(material, Vec3::ONE);
        // Spherical UVs, 4 repeats of the 8x8 map around and 2 from pole to pole: the
        // normal changes every few triangles.
        let uvs = desc.meshes[0]
            .positions
            .iter()
            .map(|p| {
                Vec2::new(
                    4.0 * (p.z.atan2(p.x) / (2.0 * PI) + 0.5),
                    2.0 * p.y.acos() / PI,
                )
            })
            .collect();
        desc.meshes[0].uvs = Some(uvs);
        desc.textures.push(TextureDesc::new(
            "wild".into(),
            n,
            n,
            texels.clone(),
            [prism::shading::image::Extension::Repeat; 2],
            false,
        ));
        let scene = Scene::build(desc).expect("scene builds");
        let settings = RenderSettings {
            width: 16,
            height: 16,
            spp: 64,
            max_depth: 16,
            seed: 5,
            ..Default::default()
        };
        let (film, stats) = render_quiet(&scene, &settings);
        assert_eq!(stats.discarded, 0, "{name}: discarded (non-finite) samples");
        let px = film.to_rgba();
        assert!(px.iter().flatten().all(|x| x.is_finite()), "{name}: NaN");
        let m = mean(&px);
        // The centre 8x8 pixels see the sphere only.
        let mut centre = Vec3::ZERO;
        for y in 4..12 {
            for x in 4..12 {
                let p = px[y * 16 + x];
                centre += Vec3::new(p[0], p[1], p[2]) / 64.0;
            }
        }
        eprintln!("furnace {name}: image mean {m}, sphere mean {centre}");
        assert!(m.max_element() <= 1.01, "{name}: furnace mean {m} > 1");
        assert!(
            centre.max_element() <= 1.01,
            "{name}: sphere mean {centre} > 1"
        );
        // Shading normals lose some energy at the horizon, but most must remain.
        assert!(centre.min_element() > 0.7, "{name}: sphere mean {centre}");
    }
}

/// Broken normal-map inputs are one-line errors or warnings, never panics.
#[test]
fn bad_inputs_are_reported() {
    let dir = test_dir("normal_map_bad");
    let c = encode(tilt().normalize());
    let png = png_bytes(1, 1, &[[c[0], c[1], c[2], 255]]);
    let good = write_plane(&dir, Case::new(Tangents::Attribute), Some(png));
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&good).unwrap()).unwrap();

    let load = |name: &str, doc: &serde_json::Value| {
        let p = dir.join(name);
        std::fs::write(&p, serde_json::to_string(doc).unwrap()).unwrap();
        load_scene(&p, None, None)
    };
    // normalTexture index out of range: an input error naming the problem.
    let mut d = doc.clone();
    d["materials"][0]["normalTexture"]["index"] = json!(7);
    let e = load("bad_index.gltf", &d).unwrap_err().to_string();
    eprintln!("bad index: {e}");
    assert!(!e.contains('\n') && e.contains("normalTexture"), "{e}");

    // TANGENT of the wrong type: a warning, tangents derived from the UVs instead.
    let mut d = doc.clone();
    let nrm = d["meshes"][0]["primitives"][0]["attributes"]["NORMAL"].clone();
    d["meshes"][0]["primitives"][0]["attributes"]["TANGENT"] = nrm;
    let s = load("bad_type.gltf", &d).expect("loads with a warning");
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("TANGENT must be VEC4")),
        "{:?}",
        s.warnings
    );
    assert!(s.meshes[0].tangents.is_none());

    // NaN tangents: a warning; they are zeroed (the renderer then derives tangents).
    let mut d = doc.clone();
    let tan_acc = d["meshes"][0]["primitives"][0]["attributes"]["TANGENT"]
        .as_u64()
        .unwrap() as usize;
    // Point the TANGENT accessor's data at NaNs: rewrite the buffer (base64) in place.
    let view = d["accessors"][tan_acc]["bufferView"].as_u64().unwrap() as usize;
    let off = d["bufferViews"][view]["byteOffset"].as_u64().unwrap() as usize;
    let uri = d["buffers"][0]["uri"].as_str().unwrap().to_string();
    let b64 = uri.split_once(',').unwrap().1;
    let mut bin = prism::scene::texture::base64_decode(b64).unwrap();
    for k in 0..4 {
        bin[off + k * 16..off + k * 16 + 4].copy_from_slice(&f32::NAN.to_le_bytes());
    }
    d["buffers"][0]["uri"] = json!(format!(
        "data:application/octet-stream;base64,{}",
        base64_encode(&bin)
    ));
    let s = load("nan_tangents.gltf", &d).expect("loads with a warning");
    assert!(
        s.warnings.iter().any(|w| w.contains("TANGENT value(s)")),
        "{:?}",
        s.warnings
    );
    assert!(s.meshes[0].tangents.as_ref().unwrap()[0] == Vec4::ZERO);
    // ... and renders finite, with generated tangents giving the analytic radiance.
    let scene = Scene::build(s).expect("builds");
    let (film, _) = render_quiet(
        &scene,
        &RenderSettings {
            width: 4,
            height: 4,
            spp: 16,
            max_depth: 1,
            ..Default::default()
        },
    );
    let got = mean(&film.to_rgba());
    let n = expected_normal(Case::new(Tangents::Attribute), decode(c, 1.0));
    let want = 0.5 * n.dot(light_dir()) * conty_g(Vec3::Y, n, light_dir());
    assert!(
        (got - Vec3::splat(want)).abs().max_element() < 0.02 * want,
        "{got} vs {want}"
    );

    // Degenerate UVs (all corners at one UV): an arbitrary tangent frame, finite image.
    let mut d = doc.clone();
    d["meshes"][0]["primitives"][0]["attributes"]
        .as_object_mut()
        .unwrap()
        .remove("TANGENT");
    let uv_acc = d["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"]
        .as_u64()
        .unwrap() as usize;
    let view = d["accessors"][uv_acc]["bufferView"].as_u64().unwrap() as usize;
    let off = d["bufferViews"][view]["byteOffset"].as_u64().unwrap() as usize;
    for k in 0..8 {
        bin[off + k * 4..off + k * 4 + 4].copy_from_slice(&0.25f32.to_le_bytes());
    }
    d["buffers"][0]["uri"] = json!(format!(
        "data:application/octet-stream;base64,{}",
        base64_encode(&bin)
    ));
    let s = load("degenerate_uv.gltf", &d).expect("loads");
    let scene = Scene::build(s).expect("builds");
    let (film, stats) = render_quiet(
        &scene,
        &RenderSettings {
            width: 4,
            height: 4,
            spp: 16,
            max_depth: 2,
            ..Default::default()
        },
    );
    assert_eq!(stats.discarded, 0);
    let px = film.to_rgba();
    assert!(px.iter().flatten().all(|x| x.is_finite()));
    assert!(mean(&px).min_element() > 0.0);
}

/// normalTexture's `scale`, `texCoord` and KHR_texture_transform (which the gltf crate leaves as
/// raw JSON for this slot) are loaded like the other textures' (glTF 2.0 spec 5.23,
/// KHR_texture_transform); tangents of a primitive without normals are ignored (spec 3.7.2.1).
#[test]
fn normal_texture_fields_are_loaded() {
    let dir = test_dir("normal_map_fields");
    let png = png_bytes(1, 1, &[[128, 128, 255, 255]]);
    let path = write_plane(
        &dir,
        Case {
            scale: 0.25,
            ..Case::new(Tangents::Attribute)
        },
        Some(png),
    );
    let mut doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    doc["extensionsUsed"] = json!(["KHR_materials_specular", "KHR_texture_transform"]);
    doc["materials"][0]["normalTexture"]["extensions"] = json!({ "KHR_texture_transform": {
        "offset": [0.5, 0.0], "rotation": 0.0, "scale": [2.0, 2.0] } });
    let p = dir.join("transform.gltf");
    std::fs::write(&p, serde_json::to_string(&doc).unwrap()).unwrap();
    let s = load_scene(&p, None, None).expect("loads");
    let m = &s.materials[0].gltf;
    assert_eq!(m.normal_scale, 0.25);
    let nt = m.normal_texture.expect("normal texture");
    let want = glam::Mat3::from_translation(Vec2::new(0.5, 0.0))
        * glam::Mat3::from_scale(Vec2::splat(2.0));
    assert!(
        nt.uv_transform.abs_diff_eq(want, 1e-6),
        "{:?}",
        nt.uv_transform
    );
    assert!(
        s.textures[nt.texture].image.texels[0].x < 0.51,
        "linear, not sRGB-decoded"
    );
    assert!(s.meshes[0].tangents.is_some());

    // A malformed transform is a one-line error naming the slot.
    doc["materials"][0]["normalTexture"]["extensions"]["KHR_texture_transform"]["offset"] =
        json!("up");
    std::fs::write(&p, serde_json::to_string(&doc).unwrap()).unwrap();
    let e = load_scene(&p, None, None).unwrap_err().to_string();
    assert!(
        e.contains("normalTexture: KHR_texture_transform: offset"),
        "{e}"
    );

    // TANGENT without NORMAL: ignored with a warning.
    let mut d: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&path).unwrap()).unwrap();
    d["meshes"][0]["primitives"][0]["attributes"]
        .as_object_mut()
        .unwrap()
        .remove("NORMAL");
    std::fs::write(&p, serde_json::to_string(&d).unwrap()).unwrap();
    let s = load_scene(&p, None, None).expect("loads");
    assert!(s.meshes[0].tangents.is_none());
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("TANGENT without NORMAL")),
        "{:?}",
        s.warnings
    );
}
