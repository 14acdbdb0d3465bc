//! Scene loading through the library API: small glTF files built in the test
//! (tests/common/gltf_builder.rs), the material sidecar, and the malformed corpus.

#[path = "common/gltf_builder.rs"]
mod gltf_builder;
#[path = "common/malformed_cases.rs"]
mod malformed_cases;

use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};
use std::path::Path;

use glam::{Mat3, Mat4, Quat, Vec2, Vec3, Vec4};
use gltf_builder::*;
use prism::scene::materials_json::{parse_materials_json, SUBSURFACE_PRESETS};
use prism::scene::{
    load_scene, InstanceVisibility, IorDesc, MaterialOverride, PunctualKind, SceneDesc,
    SubsurfaceCoefficients,
};
use prism::PrismError;
use serde_json::json;

fn load(path: &Path) -> SceneDesc {
    match load_scene(path, None, None) {
        Ok(s) => s,
        Err(e) => panic!("load_scene({}) failed: {e}", path.display()),
    }
}

fn input_error(r: Result<SceneDesc, PrismError>) -> String {
    match r {
        Err(PrismError::Input(m)) => {
            assert!(!m.contains('\n'), "multi-line message: {m}");
            m
        }
        Err(e) => panic!("expected an input error, got internal error {e}"),
        Ok(_) => panic!("expected an input error, the scene loaded"),
    }
}

fn approx_mat(a: Mat4, b: Mat4) -> bool {
    a.abs_diff_eq(b, 1e-5)
}

fn approx(a: f32, b: f32) -> bool {
    (a - b).abs() <= 1e-5 * (1.0 + b.abs())
}

#[test]
fn instancing_one_mesh_two_nodes() {
    let dir = test_dir("instancing");
    let mut b = GltfBuilder::basic();
    // Node 0 ("Light") uses mesh 0; add two more uses of the same mesh.
    b.root(json!({ "name": "CopyA", "mesh": 0, "translation": [2.0, 0.0, 0.0] }));
    b.root(json!({ "name": "CopyB", "mesh": 0, "scale": [2.0, 2.0, 2.0] }));
    let s = load(&b.write_gltf(&dir.join("inst.gltf")));
    assert_eq!(s.meshes.len(), 1, "the shared mesh must not be copied");
    assert_eq!(s.instances.len(), 3);
    assert!(s.instances.iter().all(|i| i.mesh == 0));
    let by_name = |n: &str| s.instances.iter().find(|i| i.name == n).unwrap();
    assert!(approx_mat(by_name("Light").object_to_world, Mat4::IDENTITY));
    assert!(approx_mat(
        by_name("CopyA").object_to_world,
        Mat4::from_translation(Vec3::new(2.0, 0.0, 0.0))
    ));
    assert!(approx_mat(
        by_name("CopyB").object_to_world,
        Mat4::from_scale(Vec3::splat(2.0))
    ));
    assert_eq!(s.meshes[0].indices.len(), 6);
    assert_eq!(s.meshes[0].positions.len(), 4);
}

#[test]
fn area_light_node_extras_set_ray_visibility() {
    let dir = test_dir("area_light_extras");
    let mut b = GltfBuilder::basic();
    b.root(json!({ "name": "Hidden", "mesh": 0, "extras": { "prism_area_light": true } }));
    b.root(json!({ "name": "Shown", "mesh": 0,
                   "extras": { "prism_area_light": true, "prism_visible_camera": true } }));
    b.root(json!({ "name": "Other", "mesh": 0, "extras": { "something": 1 } }));
    // Blender's object ray visibility and holdout, on any mesh.
    b.root(json!({ "name": "Holdout", "mesh": 0, "extras": { "prism_holdout": true } }));
    b.root(json!({ "name": "NoShadow", "mesh": 0,
                   "extras": { "prism_casts_shadows": false, "prism_visible_camera": false } }));
    let s = load(&b.write_gltf(&dir.join("extras.gltf")));
    let vis = |n: &str| {
        let i = s.instances.iter().position(|i| i.name == n).unwrap();
        s.instance_visibility.get(i).copied().unwrap_or_default()
    };
    let default = InstanceVisibility::default();
    assert_eq!(vis("Light"), default);
    assert_eq!(vis("Other"), default);
    assert_eq!(
        vis("Hidden"),
        InstanceVisibility {
            casts_shadows: false,
            camera_visible: false,
            light_only: true,
            holdout: false,
            light_visibility: Default::default(),
        }
    );
    assert_eq!(
        vis("Shown"),
        InstanceVisibility {
            casts_shadows: false,
            camera_visible: true,
            light_only: true,
            holdout: false,
            light_visibility: Default::default(),
        }
    );
    assert_eq!(
        vis("Holdout"),
        InstanceVisibility {
            holdout: true,
            light_visibility: Default::default(),
            ..default
        }
    );
    assert_eq!(
        vis("NoShadow"),
        InstanceVisibility {
            casts_shadows: false,
            camera_visible: false,
            light_only: false,
            holdout: false,
            light_visibility: Default::default(),
        }
    );
}

#[test]
fn node_hierarchy_composes_trs_and_matrix() {
    let dir = test_dir("hierarchy");
    let mut b = GltfBuilder::basic();
    let q = Quat::from_rotation_y(FRAC_PI_2);
    let parent_m = Mat4::from_scale_rotation_translation(
        Vec3::new(1.0, 2.0, 3.0),
        q,
        Vec3::new(1.0, 0.0, 0.0),
    );
    let child_m = Mat4::from_translation(Vec3::new(0.0, 5.0, 0.0))
        * Mat4::from_rotation_x(0.3)
        * Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)); // negative determinant: kept as is
    let grandchild_m = Mat4::from_translation(Vec3::new(0.0, 0.0, -1.0));
    let gc = b.node(json!({
        "name": "Grandchild", "mesh": 0, "translation": [0.0, 0.0, -1.0]
    }));
    let child = b.node(json!({
        "name": "Child", "mesh": 0, "matrix": child_m.to_cols_array(), "children": [gc]
    }));
    b.root(json!({
        "name": "Parent",
        "translation": [1.0, 0.0, 0.0],
        "rotation": q.to_array(),
        "scale": [1.0, 2.0, 3.0],
        "children": [child]
    }));
    let s = load(&b.write_gltf(&dir.join("h.gltf")));
    let by_name = |n: &str| s.instances.iter().find(|i| i.name == n).unwrap();
    assert!(approx_mat(
        by_name("Child").object_to_world,
        parent_m * child_m
    ));
    assert!(approx_mat(
        by_name("Grandchild").object_to_world,
        parent_m * child_m * grandchild_m
    ));
    assert!(by_name("Child").object_to_world.determinant() < 0.0);
}

#[test]
fn strips_and_fans_become_triangle_lists() {
    let dir = test_dir("strips");
    let mut b = GltfBuilder::basic();
    // Strip over 5 vertices in the z = 0 plane: 3 triangles, all non-degenerate.
    let strip_pos = b.positions(&[
        [0.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [2.0, 0.0, 0.0],
    ]);
    let strip = GltfBuilder::prim(strip_pos, None, None, TRIANGLE_STRIP);
    // Fan around vertex 0, indexed (indices reversed order of the vertex array).
    let fan_pos = b.positions(&[
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ]);
    let fan_idx = b.indices_u32(&[0, 1, 2, 3]);
    let fan = GltfBuilder::prim(fan_pos, Some(fan_idx), None, TRIANGLE_FAN);
    let m = b.mesh("StripFan", vec![strip, fan]);
    b.root(json!({ "name": "SF", "mesh": m }));
    let s = load(&b.write_gltf(&dir.join("sf.gltf")));
    let strip = s
        .meshes
        .iter()
        .find(|m| m.name.contains("primitive 0") && m.name.contains("StripFan"))
        .unwrap();
    let fan = s
        .meshes
        .iter()
        .find(|m| m.name.contains("primitive 1"))
        .unwrap();
    // glTF order: strip triangle i = (i, i+1+i%2, i+2-i%2); fan triangle i = (i+1, i+2, 0).
    let tri_pos = |m: &prism::scene::MeshDesc| -> Vec<[Vec3; 3]> {
        m.indices
            .chunks(3)
            .map(|t| {
                [
                    m.positions[t[0] as usize],
                    m.positions[t[1] as usize],
                    m.positions[t[2] as usize],
                ]
            })
            .collect()
    };
    let v = |x: f32, y: f32| Vec3::new(x, y, 0.0);
    assert_eq!(
        tri_pos(strip),
        vec![
            [v(0., 0.), v(0., 1.), v(1., 0.)],
            [v(0., 1.), v(1., 1.), v(1., 0.)],
            [v(1., 0.), v(1., 1.), v(2., 0.)],
        ]
    );
    assert_eq!(
        tri_pos(fan),
        vec![
            [v(1., 0.), v(1., 1.), v(0., 0.)],
            [v(1., 1.), v(0., 1.), v(0., 0.)]
        ]
    );
    // All strip triangles have the same orientation (normal -z for this layout).
    for t in tri_pos(strip) {
        assert!((t[1] - t[0]).cross(t[2] - t[0]).z < 0.0);
    }
}

#[test]
fn points_and_lines_are_skipped_with_one_warning() {
    let dir = test_dir("points");
    let mut b = GltfBuilder::basic();
    let p = b.positions(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    let m = b.mesh(
        "Cloud",
        vec![
            GltfBuilder::prim(p, None, None, POINTS),
            GltfBuilder::prim(p, None, None, LINES),
            GltfBuilder::prim(p, None, None, POINTS),
        ],
    );
    b.root(json!({ "name": "Cloud", "mesh": m }));
    let s = load(&b.write_gltf(&dir.join("p.gltf")));
    assert_eq!(
        s.meshes.len(),
        1,
        "only the emissive quad is a triangle mesh"
    );
    let w: Vec<&String> = s
        .warnings
        .iter()
        .filter(|w| w.contains("point/line"))
        .collect();
    assert_eq!(w.len(), 1, "{:?}", s.warnings);
    assert!(w[0].contains("skipped 3 point/line primitives"), "{}", w[0]);
}

#[test]
fn degenerate_triangles_dropped_and_normals_normalised() {
    let dir = test_dir("degenerate");
    let mut b = GltfBuilder::basic();
    let pos = b.positions(&[
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [2.0, 0.0, 0.0],
        [f32::NAN, 0.0, 0.0],
    ]);
    let nrm = b.vec3(&[
        [0.0, 0.0, 2.0],
        [0.0, 0.0, 0.5],
        [0.0, 0.0, 0.0], // degenerate: replaced by the face normal
        [0.0, 0.0, 1.0],
        [0.0, 0.0, 1.0],
    ]);
    let uv = b.vec2(&[[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0], [0.5, 0.5]]);
    // One good triangle, one zero-area (collinear), one with a NaN vertex, one repeated index.
    let idx = b.indices_u16(&[0, 1, 2, 0, 1, 3, 0, 4, 2, 2, 2, 1]);
    let mut prim = GltfBuilder::prim(pos, Some(idx), None, TRIANGLES);
    prim["attributes"]["NORMAL"] = json!(nrm);
    prim["attributes"]["TEXCOORD_0"] = json!(uv);
    let m = b.mesh("Mixed", vec![prim]);
    b.root(json!({ "name": "Mixed", "mesh": m }));
    let s = load(&b.write_gltf(&dir.join("d.gltf")));
    let mesh = s.meshes.iter().find(|m| m.name.contains("Mixed")).unwrap();
    assert_eq!(mesh.indices.len(), 3);
    assert_eq!(
        mesh.positions.len(),
        3,
        "unused vertices are compacted away"
    );
    assert!(mesh.positions.iter().all(|p| p.is_finite()));
    let n = mesh.normals.as_ref().unwrap();
    for v in n {
        assert!(approx(v.length(), 1.0), "{v:?}");
        assert!(approx(v.z, 1.0), "{v:?}");
    }
    let uvs = mesh.uvs.as_ref().unwrap();
    assert_eq!(uvs.len(), 3);
    assert_eq!(uvs[1], Vec2::new(1.0, 0.0));
}

/// The accessor encodings the importer must decode besides tightly packed f32: an interleaved
/// buffer view (byteStride), sparse substitution (on a view and on an all-zero accessor without
/// one), normalised unsigned-short UVs and unsigned-byte indices (glTF 2.0 spec 3.6.2, 3.6.2.3,
/// 3.7.2.1). Also a first-use vertex order that is not the identity, so the loader's vertex
/// compaction reorders instead of moving the arrays.
#[test]
fn accessor_encodings_are_decoded() {
    let dir = test_dir("accessor_encodings");
    let mut b = GltfBuilder::basic();
    let quad = [
        [0.0f32, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ];
    // Interleaved position + normal, 24-byte stride.
    let mut interleaved = Vec::new();
    for p in &quad {
        interleaved.extend(p.iter().flat_map(|x| x.to_le_bytes()));
        interleaved.extend([0.0f32, 0.0, 2.0].iter().flat_map(|x| x.to_le_bytes()));
    }
    let view = b.push_view(&interleaved);
    b.buffer_views[view]["byteStride"] = json!(24);
    // Sparse: vertex 2 moves to (1, 2, 0).
    let sparse_idx = b.push_view(&[2u8]);
    let sparse_val = b.push_view(&[1.0f32, 2.0, 0.0].map(f32::to_le_bytes).concat());
    b.accessors.push(json!({
        "bufferView": view, "byteOffset": 0, "componentType": 5126, "count": 4, "type": "VEC3",
        "min": [0.0, 0.0, 0.0], "max": [1.0, 2.0, 0.0],
        "sparse": { "count": 1,
            "indices": { "bufferView": sparse_idx, "componentType": 5121 },
            "values": { "bufferView": sparse_val } }
    }));
    let pos = b.accessors.len() - 1;
    b.accessors.push(json!({
        "bufferView": view, "byteOffset": 12, "componentType": 5126, "count": 4, "type": "VEC3"
    }));
    let nrm = b.accessors.len() - 1;
    // Normalised u16 UVs: 0, 65535, 32768 (= 0.500008).
    let uv_u16: [u16; 8] = [0, 0, 65535, 0, 65535, 32768, 0, 65535];
    let uv_view = b.push_view(&uv_u16.map(u16::to_le_bytes).concat());
    b.accessors.push(json!({
        "bufferView": uv_view, "componentType": 5123, "normalized": true, "count": 4,
        "type": "VEC2"
    }));
    let uv = b.accessors.len() - 1;
    // u8 indices, first use order 3, 2, 1, 0.
    let idx_view = b.push_view(&[3u8, 2, 1, 3, 1, 0]);
    b.accessors.push(json!({
        "bufferView": idx_view, "componentType": 5121, "count": 6, "type": "SCALAR"
    }));
    let idx = b.accessors.len() - 1;
    let mut prim = GltfBuilder::prim(pos, Some(idx), None, TRIANGLES);
    prim["attributes"]["NORMAL"] = json!(nrm);
    prim["attributes"]["TEXCOORD_0"] = json!(uv);
    let m = b.mesh("Encoded", vec![prim]);
    b.root(json!({ "name": "Encoded", "mesh": m }));

    // Positions only from sparse values on an accessor without a buffer view (zeros elsewhere).
    let zidx = b.push_view(&[1u16, 2].map(u16::to_le_bytes).concat());
    let zval = b.push_view(
        &[1.0f32, 0.0, 0.0, 0.0, 1.0, 0.0]
            .map(f32::to_le_bytes)
            .concat(),
    );
    b.accessors.push(json!({
        "componentType": 5126, "count": 3, "type": "VEC3",
        "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0],
        "sparse": { "count": 2,
            "indices": { "bufferView": zidx, "componentType": 5123 },
            "values": { "bufferView": zval } }
    }));
    let zpos = b.accessors.len() - 1;
    let zm = b.mesh(
        "SparseOnly",
        vec![GltfBuilder::prim(zpos, None, None, TRIANGLES)],
    );
    b.root(json!({ "name": "SparseOnly", "mesh": zm }));

    let s = load(&b.write_gltf(&dir.join("e.gltf")));
    let mesh = s
        .meshes
        .iter()
        .find(|m| m.name.contains("Encoded"))
        .unwrap();
    let moved = [
        Vec3::new(0.0, 0.0, 0.0),
        Vec3::new(1.0, 0.0, 0.0),
        Vec3::new(1.0, 2.0, 0.0),
        Vec3::new(0.0, 1.0, 0.0),
    ];
    let uvs_expected = [
        Vec2::new(0.0, 0.0),
        Vec2::new(1.0, 0.0),
        Vec2::new(1.0, 32768.0 / 65535.0),
        Vec2::new(0.0, 1.0),
    ];
    let (positions, uvs) = (&mesh.positions, mesh.uvs.as_ref().unwrap());
    let normals = mesh.normals.as_ref().unwrap();
    assert_eq!(mesh.indices.len(), 6);
    // Corner by corner, whatever order the vertices were compacted into.
    for (k, &original) in [3usize, 2, 1, 3, 1, 0].iter().enumerate() {
        let v = mesh.indices[k] as usize;
        assert_eq!(positions[v], moved[original], "corner {k}");
        assert!(
            (uvs[v] - uvs_expected[original]).abs().max_element() < 1e-6,
            "corner {k}"
        );
        assert!(
            approx(normals[v].z, 1.0),
            "normals normalised: {:?}",
            normals[v]
        );
    }
    let sparse = s
        .meshes
        .iter()
        .find(|m| m.name.contains("SparseOnly"))
        .unwrap();
    let corners: Vec<Vec3> = sparse
        .indices
        .iter()
        .map(|&i| sparse.positions[i as usize])
        .collect();
    assert_eq!(corners, [Vec3::ZERO, Vec3::X, Vec3::Y]);
}

#[test]
fn material_fields() {
    let dir = test_dir("materials");
    let mut b = GltfBuilder::basic();
    for e in [
        "KHR_materials_specular",
        "KHR_materials_transmission",
        "KHR_materials_ior",
        "KHR_materials_volume",
        "KHR_texture_transform",
        "KHR_materials_dispersion",
    ] {
        b.use_ext(e);
    }
    // 2x1 PNG: sRGB 128 grey, and (metallicRoughness) linear data.
    let png = png_bytes(2, 1, &[[128, 128, 128, 255], [255, 64, 0, 255]]);
    let img = b.image_embedded(&png, "image/png");
    let tex = b.texture(
        img,
        Some(json!({ "magFilter": 9728, "wrapS": 33071, "wrapT": 10497 })),
    );
    let diffuse = b.material(json!({
        "name": "Diffuse",
        "pbrMetallicRoughness": {
            "baseColorFactor": [0.5, 0.25, 1.0, 1.0],
            "metallicFactor": 0.0,
            "roughnessFactor": 0.6,
            "baseColorTexture": { "index": tex, "extensions": { "KHR_texture_transform": {
                "offset": [0.5, 0.0], "rotation": 0.0, "scale": [2.0, 2.0] } } },
            "metallicRoughnessTexture": { "index": tex }
        },
        "normalTexture": { "index": tex },
        "extensions": { "KHR_materials_specular": {
            "specularFactor": 0.0, "specularColorFactor": [1.0, 0.5, 0.25] } }
    }));
    let glass = b.material(json!({
        "name": "Glass",
        "doubleSided": true,
        "alphaMode": "BLEND",
        "pbrMetallicRoughness": { "metallicFactor": 0.0, "roughnessFactor": 0.0 },
        "extensions": {
            "KHR_materials_transmission": { "transmissionFactor": 1.0 },
            "KHR_materials_ior": { "ior": 1.45 },
            "KHR_materials_volume": { "thicknessFactor": 0.1, "attenuationColor": [0.9, 0.8, 0.7], "attenuationDistance": 0.5 },
            "KHR_materials_dispersion": { "dispersion": 0.5 }
        }
    }));
    let q1 = b.quad_mesh("D", Some(diffuse));
    let q2 = b.quad_mesh("G", Some(glass));
    b.root(json!({ "name": "D", "mesh": q1 }));
    b.root(json!({ "name": "G", "mesh": q2 }));
    let s = load(&b.write_gltf(&dir.join("m.gltf")));

    let emitter = &s.materials[0].gltf;
    assert_eq!(emitter.name, "Emitter");
    assert_eq!(
        emitter.emissive,
        Vec3::splat(5.0),
        "emissiveFactor x emissiveStrength"
    );

    let d = &s.materials[diffuse].gltf;
    assert_eq!(d.name, "Diffuse");
    assert_eq!(d.base_color, Vec4::new(0.5, 0.25, 1.0, 1.0));
    assert_eq!(d.metallic, 0.0);
    assert_eq!(d.roughness, 0.6);
    assert_eq!(
        d.specular, 0.0,
        "Blender's specularFactor 0 must be honoured"
    );
    assert_eq!(d.specular_color, Vec3::new(1.0, 0.5, 0.25));
    assert_eq!(d.transmission, 0.0);
    assert_eq!(d.ior, 1.5, "default IOR");
    assert!(!d.double_sided);
    let bt = d.base_color_texture.unwrap();
    let mt = d.metallic_roughness_texture.unwrap();
    assert_ne!(
        bt.texture, mt.texture,
        "sRGB and linear decodes are cached separately"
    );
    let want = Mat3::from_translation(Vec2::new(0.5, 0.0)) * Mat3::from_scale(Vec2::splat(2.0));
    assert!(bt.uv_transform.abs_diff_eq(want, 1e-6));
    assert_eq!(mt.uv_transform, Mat3::IDENTITY);
    let srgb = &s.textures[bt.texture];
    let lin = &s.textures[mt.texture];
    assert_eq!((srgb.image.width, srgb.image.height), (2, 1));
    let grey = prism::spectrum::rgb::srgb_to_linear(128.0 / 255.0);
    assert!(
        approx(srgb.image.texels[0].x, grey),
        "{:?}",
        srgb.image.texels[0]
    );
    assert!(approx(srgb.image.texels[0].w, 1.0));
    assert!(approx(lin.image.texels[0].x, 128.0 / 255.0));
    assert!(approx(lin.image.texels[1].y, 64.0 / 255.0));
    assert!(!srgb.bilinear, "magFilter NEAREST");
    use prism::shading::image::Extension;
    assert_eq!(
        srgb.wrap,
        [Extension::Extend, Extension::Repeat],
        "wrapS clamp, wrapT repeat"
    );

    let g = &s.materials[glass].gltf;
    assert_eq!(g.transmission, 1.0);
    assert!(approx(g.ior, 1.45));
    assert_eq!(g.attenuation_color, Vec3::new(0.9, 0.8, 0.7));
    assert_eq!(g.attenuation_distance, 0.5);
    assert!(g.double_sided);
    assert_eq!(g.dispersion, 0.5, "KHR_materials_dispersion is loaded");
    assert!(
        !s.warnings
            .iter()
            .any(|w| w.contains("KHR_materials_dispersion")),
        "dispersion is supported, not warned about: {:?}",
        s.warnings
    );
    assert!(s.materials.iter().all(|m| m.sidecar.is_none()));
    let nt = d.normal_texture.expect("normalTexture is loaded");
    assert_eq!(nt.texture, mt.texture, "normal maps are linear data");
    assert_eq!(d.normal_scale, 1.0, "default normalTexture.scale");
    assert!(
        !s.warnings.iter().any(|w| w.contains("normalTexture")),
        "{:?}",
        s.warnings
    );
    // alphaMode is rendered (stochastic transparency), not warned about.
    assert_eq!(g.alpha_mode, prism::scene::AlphaMode::Blend);
    assert!(
        !s.warnings.iter().any(|w| w.contains("alphaMode")),
        "{:?}",
        s.warnings
    );
}

/// A missing picture is an optional asset: Blender's magenta and a warning naming the image and
/// its path, not a failed render (as Cycles).
/// Writes `b` with a quad "T" whose material's base colour is image `img`, to `path`.
fn textured_quad(mut b: GltfBuilder, img: usize, path: &Path) -> std::path::PathBuf {
    let tex = b.texture(img, None);
    let m = b.material(
        json!({ "name": "T", "pbrMetallicRoughness": { "baseColorTexture": { "index": tex } } }),
    );
    let q = b.quad_mesh("T", Some(m));
    b.root(json!({ "name": "T", "mesh": q }));
    b.write_gltf(path)
}

#[test]
fn missing_image_file_is_magenta_with_a_warning() {
    let dir = test_dir("missing_image");
    let mut b = GltfBuilder::basic();
    let img = b.image_uri("textures/albedo%20map.png");
    let path = textured_quad(b, img, &dir.join("t.gltf"));
    let s = load(&path);
    assert_eq!(s.textures.len(), 1);
    assert_eq!(
        s.textures[0].image.texels,
        vec![glam::Vec4::new(1.0, 0.0, 1.0, 1.0)]
    );
    assert!(
        s.warnings.iter().any(
            |w| w.contains("image 0: cannot read 'textures/albedo%20map.png'")
                && w.contains("albedo%20map.png")
                && w.ends_with("rendered magenta")
        ),
        "{:?}",
        s.warnings
    );
    // An undecodable picture too.
    std::fs::create_dir_all(dir.join("textures")).unwrap();
    std::fs::write(dir.join("textures/albedo map.png"), b"not a png").unwrap();
    let s = load(&path);
    assert_eq!(
        s.textures[0].image.texels,
        vec![glam::Vec4::new(1.0, 0.0, 1.0, 1.0)]
    );
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("image 0 ('textures/albedo%20map.png')")
                && w.ends_with("rendered magenta")),
        "{:?}",
        s.warnings
    );
    // With the file present (percent-decoded name) it loads.
    std::fs::create_dir_all(dir.join("textures")).unwrap();
    std::fs::write(
        dir.join("textures/albedo map.png"),
        png_bytes(1, 1, &[[255, 0, 0, 255]]),
    )
    .unwrap();
    let s = load(&path);
    assert_eq!(s.textures.len(), 1);
    assert!(approx(s.textures[0].image.texels[0].x, 1.0));
    // The quad has no TEXCOORD_0: one warning names it (the texture is read at uv (0, 0)).
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("'T'") && w.contains("without TEXCOORD_0")),
        "{:?}",
        s.warnings
    );
}

#[test]
fn punctual_light_units_and_transforms() {
    let dir = test_dir("lights");
    let mut b = GltfBuilder::new();
    let q = b.quad_mesh("Floor", None);
    b.root(json!({ "name": "Floor", "mesh": q }));
    let c = b.camera("Cam", 0.8, Some(1.5));
    b.root(json!({ "name": "CamNode", "camera": c }));
    // Blender exports a P-watt point light as P / (4 pi) * 683 cd, a sun of S W/m^2 as S * 683 lux.
    let p_watts = 1000.0f32;
    let cd = p_watts / (4.0 * PI) * 683.0;
    let point = b.light(
        json!({ "name": "Bulb", "type": "point", "color": [1.0, 0.9, 0.8], "intensity": cd }),
    );
    let spot = b.light(json!({ "name": "Spot", "type": "spot", "intensity": cd,
        "spot": { "innerConeAngle": 0.2, "outerConeAngle": FRAC_PI_4 } }));
    let sun = b.light(json!({ "name": "Sun", "type": "directional", "intensity": 3.0 * 683.0 }));
    b.root(json!({ "name": "BulbNode", "translation": [1.0, 2.0, 3.0],
        "extensions": { "KHR_lights_punctual": { "light": point } } }));
    // Spot rotated so local -Z points down (-Y): rotation of +90 deg about X.
    let down = Quat::from_rotation_x(-FRAC_PI_2);
    b.root(
        json!({ "name": "SpotNode", "translation": [0.0, 4.0, 0.0], "rotation": down.to_array(),
        "extensions": { "KHR_lights_punctual": { "light": spot } } }),
    );
    let parent = b.node(json!({ "name": "SunNode",
        "extensions": { "KHR_lights_punctual": { "light": sun } } }));
    b.root(
        json!({ "name": "SunParent", "rotation": Quat::from_rotation_y(FRAC_PI_2).to_array(),
        "children": [parent] }),
    );
    let s = load(&b.write_gltf(&dir.join("l.gltf")));
    assert_eq!(s.lights.len(), 3);
    let l = |n: &str| s.lights.iter().find(|l| l.name == n).unwrap();

    let bulb = l("Bulb");
    assert_eq!(bulb.kind, PunctualKind::Point);
    assert!(
        approx(bulb.intensity, p_watts / (4.0 * PI)),
        "{}",
        bulb.intensity
    );
    assert_eq!(bulb.color, Vec3::new(1.0, 0.9, 0.8));
    assert!(bulb.position.abs_diff_eq(Vec3::new(1.0, 2.0, 3.0), 1e-6));

    let sp = l("Spot");
    assert_eq!(
        sp.kind,
        PunctualKind::Spot {
            inner_cone: 0.2,
            outer_cone: FRAC_PI_4
        }
    );
    assert!(
        approx(sp.intensity, p_watts / (4.0 * PI)),
        "spot = point of the same power"
    );
    assert!(
        sp.direction.abs_diff_eq(Vec3::NEG_Y, 1e-6),
        "{:?}",
        sp.direction
    );
    assert!(sp.position.abs_diff_eq(Vec3::new(0.0, 4.0, 0.0), 1e-6));

    let sun = l("Sun");
    assert_eq!(sun.kind, PunctualKind::Directional);
    assert!(approx(sun.intensity, 3.0));
    // -Z rotated +90 deg about Y is -X.
    assert!(
        sun.direction.abs_diff_eq(Vec3::NEG_X, 1e-6),
        "{:?}",
        sun.direction
    );

    let cam = s.camera.as_ref().unwrap();
    assert_eq!(cam.aspect, Some(1.5));
    assert!(approx(cam.yfov, 0.8));
}

#[test]
fn camera_selection_by_name() {
    let dir = test_dir("cameras");
    let mut b = GltfBuilder::basic(); // "Camera" node with camera "CameraData" at z = 3
    let c2 = b.camera("Closeup", 0.3, None);
    let holder =
        b.node(json!({ "name": "CloseNode", "camera": c2, "translation": [0.0, 0.0, 1.0] }));
    b.root(json!({ "name": "Rig", "translation": [5.0, 0.0, 0.0], "children": [holder] }));
    let path = b.write_gltf(&dir.join("c.gltf"));

    let first = load_scene(&path, None, None).unwrap().camera.unwrap();
    assert_eq!(first.name, "Camera");
    assert!(approx(first.yfov, 0.7));
    assert!(first
        .camera_to_world
        .abs_diff_eq(Mat4::from_translation(Vec3::new(0.0, 0.0, 3.0)), 1e-6));
    assert_eq!(first.aspect, None);

    let by_node = load_scene(&path, None, Some("CloseNode"))
        .unwrap()
        .camera
        .unwrap();
    assert_eq!(by_node.name, "CloseNode");
    assert!(approx(by_node.yfov, 0.3));
    assert!(by_node
        .camera_to_world
        .abs_diff_eq(Mat4::from_translation(Vec3::new(5.0, 0.0, 1.0)), 1e-6));

    let by_cam = load_scene(&path, None, Some("Closeup"))
        .unwrap()
        .camera
        .unwrap();
    assert_eq!(by_cam.name, "CloseNode");
    let by_data = load_scene(&path, None, Some("CameraData"))
        .unwrap()
        .camera
        .unwrap();
    assert_eq!(by_data.name, "Camera");

    let e = input_error(load_scene(&path, None, Some("Nope")));
    assert!(e.contains("no camera named 'Nope'"), "{e}");
    assert!(e.contains("'Camera' (camera 'CameraData')"), "{e}");
    assert!(e.contains("'CloseNode' (camera 'Closeup')"), "{e}");
}

#[test]
fn orthographic_camera_is_imported_and_validated() {
    let dir = test_dir("ortho");
    let mut b = GltfBuilder::basic();
    b.cameras[0] = json!({ "type": "orthographic",
        "orthographic": { "xmag": 2.0, "ymag": 1.5, "znear": 0.1, "zfar": 10.0 } });
    let s = load(&b.write_gltf(&dir.join("o.gltf")));
    let cam = s.camera.unwrap();
    assert_eq!(cam.orthographic, Some(glam::Vec2::new(2.0, 1.5)));
    assert!(cam.lens.is_none());
    b.cameras[0] = json!({ "type": "orthographic",
        "orthographic": { "xmag": 2.0, "ymag": 0.0, "znear": 0.1, "zfar": 10.0 } });
    let e = input_error(load_scene(&b.write_gltf(&dir.join("z.gltf")), None, None));
    assert!(
        e.contains("orthographic ymag must be a non-zero number, got 0"),
        "{e}"
    );
    assert!(!e.contains('\n'), "{e}");
}

#[test]
fn glb_and_external_buffers_load() {
    let dir = test_dir("glb");
    let b = GltfBuilder::basic();
    let glb = load(&b.write_glb(&dir.join("scene.glb")));
    let ext = load(&b.write_gltf_external(&dir.join("ext.gltf"), "ext.bin", true));
    for s in [&glb, &ext] {
        assert_eq!(s.meshes.len(), 1);
        assert_eq!(s.meshes[0].indices, vec![0, 1, 2, 0, 2, 3]);
        assert_eq!(s.meshes[0].positions[2], Vec3::new(0.5, 0.5, 0.0));
    }
    let e = input_error(load_scene(
        &b.write_gltf_external(&dir.join("gone.gltf"), "gone.bin", false),
        None,
        None,
    ));
    assert!(
        e.ends_with("gone.gltf: buffers[0]: cannot read 'gone.bin': No such file or directory"),
        "{e}"
    );
}

#[test]
fn sidecar_auto_discovery_and_explicit_path() {
    let dir = test_dir("sidecar");
    let mut b = GltfBuilder::basic();
    let skin = b.material(json!({ "name": "Skin" }));
    let q = b.quad_mesh("S", Some(skin));
    b.root(json!({ "name": "S", "mesh": q }));
    let path = b.write_gltf(&dir.join("room.gltf"));

    // No sidecar: nothing overridden, black world.
    let s = load(&path);
    assert!(s.materials.iter().all(|m| m.sidecar.is_none()));
    assert_eq!(s.world.strength, 0.0);

    std::fs::write(
        dir.join("room.materials.json"),
        r#"{ "version": 1,
             "materials": { "Skin": { "subsurface": { "preset": "Skin1", "scale": 1000.0 } } },
             "world": { "color": [0.1, 0.2, 0.3], "strength": 2.0 },
             "render": { "spp": 16, "wavelengths": "hero" } }"#,
    )
    .unwrap();
    let s = load(&path);
    match &s.materials[skin].sidecar {
        Some(MaterialOverride::Subsurface(ss)) => {
            assert_eq!(
                ss.coefficients,
                SubsurfaceCoefficients::Preset("Skin1".into())
            );
            assert_eq!(ss.scale, 1000.0);
        }
        other => panic!("expected a subsurface override, got {other:?}"),
    }
    assert!(s.materials[0].sidecar.is_none());
    assert_eq!(s.world.color, Vec3::new(0.1, 0.2, 0.3));
    assert_eq!(s.world.strength, 2.0);
    assert_eq!(s.render.spp, Some(16));
    assert_eq!(s.render.wavelengths.as_deref(), Some("hero"));

    // An explicit path wins over the auto-discovered file.
    let other = dir.join("other.json");
    std::fs::write(
        &other,
        r#"{ "version": 1, "materials": { "Skin": { "dielectric": { "ior": 1.33 } } } }"#,
    )
    .unwrap();
    let s = load_scene(&path, Some(&other), None).unwrap();
    assert!(matches!(
        &s.materials[skin].sidecar,
        Some(MaterialOverride::Dielectric(d)) if d.ior == IorDesc::Constant(1.33) && d.roughness == 0.0
    ));
    assert_eq!(s.world.strength, 0.0);

    // An explicit path that does not exist is an error naming it.
    let e = input_error(load_scene(&path, Some(&dir.join("nope.json")), None));
    assert!(e.contains("nope.json: cannot read"), "{e}");
}

#[test]
fn world_light_alone_is_enough() {
    let dir = test_dir("world_light");
    let mut b = GltfBuilder::new();
    let q = b.quad_mesh("Q", None);
    b.root(json!({ "name": "Q", "mesh": q }));
    let c = b.camera("C", 0.7, None);
    b.root(json!({ "name": "C", "camera": c }));
    let path = b.write_gltf(&dir.join("w.gltf"));
    // Without a light the scene loads with a warning (it renders black).
    let s = load_scene(&path, None, None).unwrap();
    assert!(
        s.warnings
            .iter()
            .any(|w| w.contains("the scene has no light")),
        "{:?}",
        s.warnings
    );
    std::fs::write(
        dir.join("w.materials.json"),
        r#"{ "version": 1, "world": { "color": [1, 1, 1], "strength": 0.5 } }"#,
    )
    .unwrap();
    let s = load(&path);
    assert_eq!(s.world.strength, 0.5);
}

#[test]
fn sidecar_full_example_parses() {
    let text = r#"{ "version": 1,
  "materials": {
    "Marble":  { "subsurface": { "preset": "Marble", "scale": 1000.0, "eta": 1.33, "g": 0.0 } },
    "Skin":    { "subsurface": { "sigma_a": [0.032, 0.17, 0.48], "sigma_s": [0.74, 0.88, 1.01], "scale": 1000.0, "eta": 1.4 } },
    "Wax":     { "subsurface": { "reflectance": [0.8, 0.7, 0.6], "mfp": [0.01, 0.005, 0.0025], "eta": 1.33 } },
    "Diamond": { "dielectric": { "cauchy": { "a": 2.38, "b": 0.0117 }, "roughness": 0.0 } } },
  "world": { "color": [0.05, 0.05, 0.05], "strength": 1.0 },
  "render": { "spp": 64, "width": 512, "height": 512, "max_depth": 16 } }"#;
    let names: Vec<String> = ["Marble", "Skin", "Wax", "Diamond", "Unused"]
        .iter()
        .map(|s| s.to_string())
        .collect();
    let f = parse_materials_json(text, "example.materials.json", Some(&names)).unwrap();
    assert_eq!(f.materials.len(), 4);
    let get = |n: &str| &f.materials.iter().find(|(m, _)| m == n).unwrap().1;
    let MaterialOverride::Subsurface(marble) = get("Marble") else {
        panic!()
    };
    assert_eq!(
        marble.coefficients,
        SubsurfaceCoefficients::Preset("Marble".into())
    );
    assert_eq!(
        (marble.scale, marble.eta, marble.g, marble.roughness),
        (1000.0, 1.33, 0.0, 0.0)
    );
    assert_eq!(marble.method, "table");
    let MaterialOverride::Subsurface(skin) = get("Skin") else {
        panic!()
    };
    assert_eq!(
        skin.coefficients,
        SubsurfaceCoefficients::Explicit {
            sigma_a: Vec3::new(0.032, 0.17, 0.48),
            sigma_s: Vec3::new(0.74, 0.88, 1.01)
        }
    );
    assert_eq!((skin.scale, skin.eta), (1000.0, 1.4));
    let MaterialOverride::Subsurface(wax) = get("Wax") else {
        panic!()
    };
    assert_eq!(
        wax.coefficients,
        SubsurfaceCoefficients::Reflectance {
            reflectance: Vec3::new(0.8, 0.7, 0.6),
            mfp: Vec3::new(0.01, 0.005, 0.0025)
        }
    );
    assert_eq!((wax.scale, wax.eta), (1.0, 1.33));
    let MaterialOverride::Dielectric(diamond) = get("Diamond") else {
        panic!()
    };
    assert_eq!(
        diamond.ior,
        IorDesc::Cauchy {
            a: 2.38,
            b: 0.0117,
            c: 0.0
        }
    );
    assert_eq!(diamond.roughness, 0.0);
    let w = f.world.unwrap();
    assert_eq!((w.color, w.strength), (Vec3::splat(0.05), 1.0));
    assert_eq!(f.render.spp, Some(64));
    assert_eq!(f.render.width, Some(512));
    assert_eq!(f.render.height, Some(512));
    assert_eq!(f.render.max_depth, Some(16));
    assert_eq!(f.render.wavelengths, None);
    assert_eq!(SUBSURFACE_PRESETS.len(), 12);
    assert!(SUBSURFACE_PRESETS.contains(&"Wholemilk"));
}

#[test]
fn cornell_scene_loads() {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("scenes/cornell/cornell.gltf");
    let s = load(&path);
    assert!(!s.meshes.is_empty());
    assert!(!s.instances.is_empty());
    assert!(s.camera.is_some());
    assert_eq!(
        s.render.spp,
        Some(64),
        "cornell.materials.json is auto-discovered"
    );
    let light = s.materials.iter().find(|m| m.gltf.name == "Light").unwrap();
    assert!(light.gltf.emissive.max_element() > 0.0);
}

#[test]
fn malformed_corpus_through_library() {
    let dir = malformed_cases::corpus_dir();
    let mut failures = Vec::new();
    for (file, fragment) in malformed_cases::CASES {
        let path = dir.join(file);
        match std::panic::catch_unwind(|| load_scene(&path, None, None)) {
            Err(_) => failures.push(format!("{file}: panicked")),
            Ok(Ok(_)) => failures.push(format!("{file}: loaded without error")),
            Ok(Err(PrismError::Internal(m))) => {
                failures.push(format!("{file}: internal error {m}"))
            }
            Ok(Err(PrismError::Input(m))) => {
                if !m.contains(fragment) || m.contains('\n') {
                    failures.push(format!("{file}: got '{m}', want '{fragment}'"));
                }
                if !m.contains(&path.display().to_string()) && !m.contains(".materials.json") {
                    failures.push(format!("{file}: message does not name the file: {m}"));
                }
            }
        }
    }
    let (file, fragment) = malformed_cases::NONEXISTENT;
    let e = input_error(load_scene(&dir.join(file), None, None));
    if !e.contains(fragment) {
        failures.push(format!("{file}: got '{e}'"));
    }
    assert!(failures.is_empty(), "\n{}", failures.join("\n"));
}

/// Deterministic corruption fuzzing: flipped bytes, truncations and JSON edits of valid files
/// must give input errors (or load), never panic.
#[test]
fn corrupted_files_never_panic() {
    let dir = test_dir("fuzz");
    let mut b = GltfBuilder::basic();
    let png = png_bytes(2, 2, &[[10, 20, 30, 255]; 4]);
    let img = b.image_embedded(&png, "image/png");
    let tex = b.texture(img, None);
    let m = b.material(
        json!({ "name": "T", "pbrMetallicRoughness": { "baseColorTexture": { "index": tex } } }),
    );
    let q = b.quad_mesh("T", Some(m));
    b.root(json!({ "name": "T", "mesh": q, "children": [] }));
    b.light(json!({ "type": "spot", "spot": { "outerConeAngle": 0.5 } }));
    b.root(json!({ "name": "L", "extensions": { "KHR_lights_punctual": { "light": 0 } } }));
    let glb = b.to_glb();
    let gltf = serde_json::to_vec(&b.to_json()).unwrap();
    let mut seed = 0x2545_F491_4F6C_DD1Du64;
    let mut rnd = move || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed
    };
    let glb_path = dir.join("f.glb");
    let gltf_path = dir.join("f.gltf");
    let mut outcomes = [0usize; 2];
    // PRISM_FUZZ_ITERS=N runs a longer campaign.
    let iters: usize = std::env::var("PRISM_FUZZ_ITERS")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(600);
    for iter in 0..iters {
        let (src, path) = if iter % 2 == 0 {
            (&glb, &glb_path)
        } else {
            (&gltf, &gltf_path)
        };
        let mut data = src.clone();
        match rnd() % 4 {
            0 => data.truncate((rnd() as usize) % data.len()),
            1 => {
                for _ in 0..1 + rnd() % 4 {
                    let i = (rnd() as usize) % data.len();
                    data[i] = rnd() as u8;
                }
            }
            2 => {
                // Replace a digit with another one (keeps JSON valid more often).
                let digits: Vec<usize> = (0..data.len())
                    .filter(|&i| data[i].is_ascii_digit())
                    .collect();
                if !digits.is_empty() {
                    let i = digits[(rnd() as usize) % digits.len()];
                    data[i] = b'0' + (rnd() % 10) as u8;
                }
            }
            _ => {
                let i = (rnd() as usize) % data.len();
                data.insert(i, b"9-.e,]}"[(rnd() % 7) as usize]);
            }
        }
        std::fs::write(path, &data).unwrap();
        let r = std::panic::catch_unwind(|| load_scene(path, None, None));
        match r {
            Err(_) => panic!(
                "iteration {iter}: load_scene panicked (file kept at {})",
                path.display()
            ),
            Ok(Ok(_)) => outcomes[0] += 1,
            Ok(Err(PrismError::Input(m))) => {
                assert!(!m.contains('\n'), "{m}");
                outcomes[1] += 1;
            }
            Ok(Err(e)) => panic!("iteration {iter}: internal error {e}"),
        }
    }
    assert!(outcomes[1] > 0);
}

#[test]
fn deep_hierarchies_and_node_explosions() {
    let dir = test_dir("deep");
    // A 20000-level chain of nested nodes loads (no recursion limit, no stack overflow).
    let mut b = GltfBuilder::basic();
    let depth = 20000;
    let first = b.nodes.len();
    for k in 0..depth {
        let mut n = json!({ "name": format!("N{k}"), "translation": [0.0, 0.001, 0.0] });
        if k + 1 < depth {
            n["children"] = json!([first + k + 1]);
        } else {
            n["mesh"] = json!(0);
        }
        b.node(n);
    }
    b.scene_nodes.push(first);
    let s = load(&b.write_gltf(&dir.join("chain.gltf")));
    let leaf = s
        .instances
        .iter()
        .find(|i| i.name == format!("N{}", depth - 1))
        .unwrap();
    let y = leaf.object_to_world.w_axis.y;
    assert!((y - 0.001 * depth as f32).abs() < 1e-2, "{y}");

    // 40 levels each referencing the next level twice: 2^40 paths -> input error, quickly.
    let mut b = GltfBuilder::basic();
    let first = b.nodes.len();
    for k in 0..40 {
        let mut n = json!({ "name": format!("D{k}") });
        if k + 1 < 40 {
            n["children"] = json!([first + k + 1, first + k + 1]);
        } else {
            n["mesh"] = json!(0);
        }
        b.node(n);
    }
    b.scene_nodes.push(first);
    let e = input_error(load_scene(&b.write_gltf(&dir.join("dag.gltf")), None, None));
    assert!(e.contains("instantiates more than"), "{e}");
}

#[test]
fn names_with_newlines_stay_on_one_line() {
    let dir = test_dir("newline_names");
    let mut b = GltfBuilder::basic();
    b.nodes[1]["name"] = json!("Cam\nera");
    let e = input_error(load_scene(
        &b.write_gltf(&dir.join("n.gltf")),
        None,
        Some("x"),
    ));
    assert!(e.contains("'Cam era'"), "{e}");
}

#[test]
fn unsupported_optional_extensions_are_named_in_one_warning() {
    let dir = test_dir("unsupported_ext");
    let mut b = GltfBuilder::basic();
    b.use_ext("KHR_materials_anisotropy");
    b.use_ext("KHR_materials_diffuse_transmission");
    b.use_ext("KHR_materials_sheen");
    b.use_ext("KHR_texture_transform");
    let s = load(&b.write_gltf(&dir.join("t.gltf")));
    let hits: Vec<&String> = s
        .warnings
        .iter()
        .filter(|w| w.contains("extensions not supported"))
        .collect();
    assert_eq!(hits.len(), 1, "{:?}", s.warnings);
    assert!(
        hits[0].contains("KHR_materials_anisotropy, KHR_materials_diffuse_transmission")
            && !hits[0].contains("KHR_texture_transform")
            && !hits[0].contains("KHR_materials_sheen"),
        "{}",
        hits[0]
    );
    // A plain file warns about nothing of the sort.
    let plain = load(&GltfBuilder::basic().write_gltf(&dir.join("plain.gltf")));
    assert!(plain.warnings.iter().all(|w| !w.contains("extensions")));
}

#[test]
fn vertex_colours_and_extra_uv_sets_are_loaded() {
    let dir = test_dir("color_0");
    let mut b = GltfBuilder::basic();
    let pos = b.positions(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
    let col = b.vec4(&[[1.0, 0.0, 0.0, 1.0]; 3]);
    let rgb = b.vec3(&[[0.0, 0.5, 0.0]; 3]);
    let uv = b.vec2(&[[0.25, 0.75]; 3]);
    let mut p = GltfBuilder::prim(pos, None, None, 4);
    p["attributes"]["COLOR_0"] = json!(col);
    p["attributes"]["COLOR_1"] = json!(rgb);
    p["attributes"]["TEXCOORD_2"] = json!(uv);
    let m = b.mesh("Painted", vec![p]);
    b.root(json!({ "name": "Painted", "mesh": m }));
    let s = load(&b.write_gltf(&dir.join("t.gltf")));
    assert!(s.warnings.is_empty(), "{:?}", s.warnings);
    let mesh = s
        .meshes
        .iter()
        .find(|m| m.name.contains("Painted"))
        .unwrap();
    assert_eq!(
        mesh.colors[0].as_ref().unwrap()[0],
        glam::Vec4::new(1.0, 0.0, 0.0, 1.0)
    );
    // RGB colours get alpha 1.
    assert_eq!(
        mesh.colors[1].as_ref().unwrap()[2],
        glam::Vec4::new(0.0, 0.5, 0.0, 1.0)
    );
    assert!(mesh.extra_uvs[0].is_none());
    assert_eq!(
        mesh.extra_uvs[1].as_ref().unwrap()[1],
        glam::Vec2::new(0.25, 0.75)
    );
}

/// KHR_materials_sheen's factors reach the material (its textures: tests/layer_textures.rs); a
/// colour out of [0, 1] and a texture that does not exist are one-line errors.
#[test]
fn sheen_is_read() {
    let dir = test_dir("sheen");
    let mut b = GltfBuilder::basic();
    b.use_ext("KHR_materials_sheen");
    let velvet = b.material(json!({
        "name": "Velvet",
        "extensions": { "KHR_materials_sheen": {
            "sheenColorFactor": [0.9, 0.4, 0.2], "sheenRoughnessFactor": 0.6 } }
    }));
    let q = b.quad_mesh("V", Some(velvet));
    b.root(json!({ "name": "V", "mesh": q }));
    let s = load(&b.write_gltf(&dir.join("v.gltf")));
    let m = &s.materials[velvet].gltf;
    assert_eq!(m.sheen_color, Vec3::new(0.9, 0.4, 0.2));
    assert_eq!(m.sheen_roughness, 0.6);
    assert!(s
        .warnings
        .iter()
        .all(|w| !w.contains("extensions not supported")));
    let mut bad = GltfBuilder::basic();
    bad.use_ext("KHR_materials_sheen");
    let m = bad.material(json!({ "name": "Bad", "extensions": {
        "KHR_materials_sheen": { "sheenColorFactor": [1.2, 0.0, 0.0] } } }));
    let q = bad.quad_mesh("B", Some(m));
    bad.root(json!({ "name": "B", "mesh": q }));
    let e = input_error(load_scene(
        &bad.write_gltf(&dir.join("bad.gltf")),
        None,
        None,
    ));
    assert!(
        e.contains("KHR_materials_sheen.sheenColorFactor must be three numbers in [0, 1]"),
        "{e}"
    );
    let mut missing = GltfBuilder::basic();
    missing.use_ext("KHR_materials_sheen");
    let m = missing.material(json!({ "name": "Missing", "extensions": {
        "KHR_materials_sheen": { "sheenColorFactor": [1.0, 1.0, 1.0],
                                 "sheenColorTexture": { "index": 3 } } } }));
    let q = missing.quad_mesh("M", Some(m));
    missing.root(json!({ "name": "M", "mesh": q }));
    let e = input_error(load_scene(
        &missing.write_gltf(&dir.join("missing.gltf")),
        None,
        None,
    ));
    assert!(
        e.contains("sheenColorTexture") && e.contains("index 3"),
        "{e}"
    );
}

/// KHR_materials_clearcoat (+ the add-on's coat extras) and KHR_materials_iridescence reach the
/// material; their textures are named in a warning; out-of-range values are one-line errors.
#[test]
fn clearcoat_and_iridescence_are_read() {
    let dir = test_dir("coat_film");
    let mut b = GltfBuilder::basic();
    b.use_ext("KHR_materials_clearcoat");
    b.use_ext("KHR_materials_iridescence");
    let coated = b.material(json!({
        "name": "Coated",
        "extras": { "prism_coat_ior": 1.6, "prism_coat_tint": [0.9, 0.5, 0.2] },
        "extensions": {
            "KHR_materials_clearcoat": { "clearcoatFactor": 0.8, "clearcoatRoughnessFactor": 0.2 },
            "KHR_materials_iridescence": { "iridescenceFactor": 1.0, "iridescenceIor": 1.4,
                                           "iridescenceThicknessMaximum": 520.0 }
        }
    }));
    let q = b.quad_mesh("C", Some(coated));
    b.root(json!({ "name": "C", "mesh": q }));
    let s = load(&b.write_gltf(&dir.join("c.gltf")));
    let m = &s.materials[coated].gltf;
    assert_eq!((m.coat, m.coat_roughness, m.coat_ior), (0.8, 0.2, 1.6));
    assert_eq!(m.coat_tint, Vec3::new(0.9, 0.5, 0.2));
    assert_eq!(
        (m.iridescence, m.iridescence_ior, m.iridescence_thickness),
        (1.0, 1.4, 520.0)
    );
    assert!(s
        .warnings
        .iter()
        .all(|w| !w.contains("extensions not supported")));
    // Defaults: no coat, IOR 1.5, white tint; the extension's film defaults.
    let plain = load(&GltfBuilder::basic().write_gltf(&dir.join("plain.gltf")));
    let p = &plain.materials[0].gltf;
    assert_eq!((p.coat, p.coat_ior, p.iridescence), (0.0, 1.5, 0.0));
    for (ext, bad, want) in [
        (
            "KHR_materials_clearcoat",
            json!({ "clearcoatFactor": 1.5 }),
            "KHR_materials_clearcoat.clearcoatFactor must be a number in [0, 1], got 1.5",
        ),
        (
            // The coat's normal map is read (tests/layer_textures.rs): its texture must exist.
            "KHR_materials_clearcoat",
            json!({ "clearcoatFactor": 1.0, "clearcoatNormalTexture": { "index": 3 } }),
            "clearcoatNormalTexture: index 3 out of range",
        ),
        (
            "KHR_materials_iridescence",
            json!({ "iridescenceIor": 0.5 }),
            "KHR_materials_iridescence.iridescenceIor must be a number >= 1, got 0.5",
        ),
        (
            "KHR_materials_iridescence",
            json!({ "iridescenceThicknessMaximum": -3 }),
            "iridescenceThicknessMaximum must be a non-negative number, got -3",
        ),
    ] {
        let mut b = GltfBuilder::basic();
        b.use_ext(ext);
        let m = b.material(json!({ "name": "Bad", "extensions": { ext: bad } }));
        let q = b.quad_mesh("B", Some(m));
        b.root(json!({ "name": "B", "mesh": q }));
        let e = input_error(load_scene(&b.write_gltf(&dir.join("bad.gltf")), None, None));
        assert!(e.contains(want), "{e}");
    }
}

/// 8-bit sRGB glTF textures are decoded before bilinear filtering by default (the glTF
/// specification; Khronos' TextureLinearInterpolationTest), and filtered in their encoded values
/// and decoded after with the sidecar's `render.texture_filtering: "cycles"` (what Cycles does,
/// and what the Blender add-on asks for). Halfway between texels of 0.8 and 0.1 (encoded) the
/// two differ by 44%; at a texel's centre they agree.
#[test]
fn srgb_textures_filter_as_gltf_by_default_and_as_cycles_on_request() {
    use prism::shading::image::{Extension, Interpolation};
    use prism::spectrum::rgb::srgb_to_linear;
    let dir = test_dir("srgb_filtering");
    let mut b = GltfBuilder::basic();
    let png = png_bytes(2, 1, &[[204, 204, 204, 255], [26, 26, 26, 255]]);
    let img = b.image_embedded(&png, "image/png");
    let path = textured_quad(b, img, &dir.join("t.gltf"));
    let (hi, lo) = (204.0 / 255.0, 26.0 / 255.0);
    let at = |s: &SceneDesc, u: f32| {
        let t = &s.textures[0];
        t.image
            .sample(
                Vec2::new(u, 0.5),
                Interpolation::Linear,
                [Extension::Extend; 2],
            )
            .x
    };
    let gltf = load(&path);
    assert!(!gltf.textures[0].image.srgb_encoded);
    let mid = 0.5 * (srgb_to_linear(hi) + srgb_to_linear(lo));
    assert!(
        (at(&gltf, 0.5) - mid).abs() < 1e-5,
        "{} vs {mid}",
        at(&gltf, 0.5)
    );
    std::fs::write(
        dir.join("t.materials.json"),
        r#"{ "version": 1, "render": { "texture_filtering": "cycles" } }"#,
    )
    .unwrap();
    let cycles = load(&path);
    assert!(cycles.textures[0].image.srgb_encoded);
    let mid_encoded = srgb_to_linear(0.5 * (hi + lo));
    assert!(
        (at(&cycles, 0.5) - mid_encoded).abs() < 1e-5,
        "{} vs {mid_encoded}",
        at(&cycles, 0.5)
    );
    assert!(mid_encoded < 0.7 * mid);
    // Texel centres (u = 1/4, 3/4) read the texel's decoded value either way.
    for u in [0.25, 0.75] {
        assert!((at(&gltf, u) - at(&cycles, u)).abs() < 1e-6);
    }
    // A misspelt value is a one-line error naming the key.
    std::fs::write(
        dir.join("t.materials.json"),
        r#"{ "version": 1, "render": { "texture_filtering": "blender" } }"#,
    )
    .unwrap();
    let e = input_error(prism::scene::load_scene(&path, None, None));
    assert!(
        e.contains("render.texture_filtering") && e.contains("gltf, cycles"),
        "{e}"
    );
}
