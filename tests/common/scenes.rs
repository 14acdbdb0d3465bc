//! Scenes built in code (no files) for integration tests of the renderer.
#![allow(dead_code)]

use glam::{Mat4, Vec3};
use prism::scene::{
    CameraDesc, DielectricDesc, GltfMaterialDesc, InstanceDesc, IorDesc, MaterialDesc,
    MaterialOverride, MeshDesc, SceneDesc, WorldDesc,
};

/// UV sphere with smooth normals, radius 1 at the origin.
pub fn sphere_mesh(material: usize, segments: u32, rings: u32) -> MeshDesc {
    let (positions, normals, triangles) = prism::geometry::shapes::uv_sphere(segments, rings);
    MeshDesc {
        name: "sphere".into(),
        positions,
        normals: Some(normals),
        uvs: None,
        tangents: None,
        indices: triangles.into_iter().flatten().collect(),
        material: Some(material),
    }
}

pub fn diffuse_material(name: &str, albedo: Vec3) -> MaterialDesc {
    MaterialDesc {
        gltf: GltfMaterialDesc {
            name: name.into(),
            base_color: albedo.extend(1.0),
            metallic: 0.0,
            roughness: 1.0,
            specular: 0.0,
            ..Default::default()
        },
        sidecar: None,
    }
}

pub fn material_with(gltf: GltfMaterialDesc, sidecar: Option<MaterialOverride>) -> MaterialDesc {
    MaterialDesc { gltf, sidecar }
}

/// A sidecar dielectric (glass) of the given IOR model and roughness.
pub fn glass_material(name: &str, ior: IorDesc, roughness: f32) -> MaterialDesc {
    material_with(
        GltfMaterialDesc {
            name: name.into(),
            ..Default::default()
        },
        Some(MaterialOverride::Dielectric(DielectricDesc {
            ior,
            roughness,
        })),
    )
}

/// Camera at (0, 0, distance) looking at the origin.
pub fn camera(distance: f32, yfov: f32) -> CameraDesc {
    CameraDesc {
        name: "cam".into(),
        camera_to_world: Mat4::from_translation(Vec3::new(0.0, 0.0, distance)),
        yfov,
        aspect: None,
        orthographic: None,
        lens: None,
    }
}

/// One unit sphere of `material` in a uniform world of radiance `world`.
pub fn furnace_scene(material: MaterialDesc, world: Vec3) -> SceneDesc {
    SceneDesc {
        meshes: vec![sphere_mesh(0, 64, 32)],
        instances: vec![InstanceDesc {
            mesh: 0,
            object_to_world: Mat4::IDENTITY,
            name: "sphere".into(),
        }],
        materials: vec![material],
        camera: Some(camera(3.0, 0.8)),
        world: WorldDesc {
            color: world,
            strength: 1.0,
            texture: None,
        },
        ..Default::default()
    }
}
