//! Scenes built in code (no files) for integration tests of the renderer.
#![allow(dead_code)]

use glam::{Mat4, Vec3};
use prism::scene::{
    CameraDesc, DielectricDesc, GltfMaterialDesc, InstanceDesc, IorDesc, MaterialDesc,
    MaterialOverride, MeshDesc, SceneDesc, SubsurfaceCoefficients, SubsurfaceDesc, WorldDesc,
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
        ..Default::default()
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
        graph: None,
        ..Default::default()
    }
}

pub fn material_with(gltf: GltfMaterialDesc, sidecar: Option<MaterialOverride>) -> MaterialDesc {
    MaterialDesc {
        gltf,
        sidecar,
        graph: None,
        ..Default::default()
    }
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
        ..Default::default()
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

/// Closed box [-w, w] x [-w, w] x [-depth, 0] of material 0, outward normals (counter-clockwise
/// winding): a slab for subsurface tests.
pub fn slab_mesh(w: f32, depth: f32) -> MeshDesc {
    let p = |x: f32, y: f32, z: f32| Vec3::new(x * w, y * w, if z > 0.0 { 0.0 } else { -depth });
    let positions = vec![
        p(-1.0, -1.0, -1.0),
        p(1.0, -1.0, -1.0),
        p(1.0, 1.0, -1.0),
        p(-1.0, 1.0, -1.0),
        p(-1.0, -1.0, 1.0),
        p(1.0, -1.0, 1.0),
        p(1.0, 1.0, 1.0),
        p(-1.0, 1.0, 1.0),
    ];
    let quads: [[u32; 4]; 6] = [
        [4, 5, 6, 7], // top (+z)
        [0, 3, 2, 1], // bottom (-z)
        [0, 1, 5, 4], // -y
        [2, 3, 7, 6], // +y
        [1, 2, 6, 5], // +x
        [3, 0, 4, 7], // -x
    ];
    let indices = quads
        .iter()
        .flat_map(|q| [q[0], q[1], q[2], q[0], q[2], q[3]])
        .collect();
    MeshDesc {
        name: "slab".into(),
        positions,
        normals: None,
        uvs: None,
        tangents: None,
        indices,
        material: Some(0),
        ..Default::default()
    }
}

/// A [`slab_mesh`] of the subsurface material `desc` (its top face at z = 0), seen from
/// (0, 0, 5) looking down with a narrow field of view (only the top face), in a white world.
pub fn subsurface_slab_scene(desc: &SubsurfaceDesc, half_width: f32, depth: f32) -> SceneDesc {
    SceneDesc {
        meshes: vec![slab_mesh(half_width, depth)],
        instances: vec![InstanceDesc {
            mesh: 0,
            object_to_world: Mat4::IDENTITY,
            name: "slab".into(),
        }],
        materials: vec![material_with(
            GltfMaterialDesc {
                name: "sss".into(),
                ..Default::default()
            },
            Some(MaterialOverride::Subsurface(desc.clone())),
        )],
        camera: Some(camera(5.0, 0.05)),
        world: WorldDesc {
            color: Vec3::ONE,
            strength: 1.0,
            texture: None,
        },
        ..Default::default()
    }
}

/// A subsurface material of explicit coefficients (scale 1, isotropic, smooth boundary of
/// index `eta`), rendered with `method` ("table" | "random_walk") and walk `boundary`.
pub fn explicit_subsurface(
    sigma_a: Vec3,
    sigma_s: Vec3,
    eta: f32,
    method: &str,
    boundary: &str,
) -> SubsurfaceDesc {
    SubsurfaceDesc {
        coefficients: SubsurfaceCoefficients::Explicit { sigma_a, sigma_s },
        scale: 1.0,
        eta,
        ior: None,
        g: 0.0,
        roughness: 0.0,
        method: method.into(),
        boundary: boundary.into(),
        weight: 1.0,
    }
}

/// The geometry of a [`slab_mesh`] alone (no scene): what `random_walk::walk` traces against.
pub fn slab_geometry(w: f32, depth: f32) -> prism::geometry::Geometry {
    use prism::geometry::{Geometry, Instance, Mesh};
    let m = slab_mesh(w, depth);
    let tris = m
        .indices
        .chunks_exact(3)
        .map(|c| [c[0], c[1], c[2]])
        .collect();
    let mesh = Mesh::new(m.positions, None, None, tris, 0);
    Geometry::new(vec![mesh], vec![Instance::new(0, glam::Affine3A::IDENTITY)])
}

/// One pencil-beam random walk in a [`slab_geometry`] (top face at z = 0, sides and bottom
/// hundreds of mean free paths away): the beam enters at the origin along -z with weight 1,
/// `prism::bssrdf::random_walk::walk` follows it, and at each hit on the top face a smooth
/// boundary of relative index `eta` reflects it back in with probability Fresnel (no
/// reflection when `eta` is None). Returns where it leaves through the top and its weight
/// (first wavelength), or None when it leaves through the sides or bottom, is absorbed, or
/// hits the top `max_boundary_hits` times.
pub fn slab_walk_exit(
    geometry: &prism::geometry::Geometry,
    sigma_a: f32,
    sigma_s: f32,
    eta: Option<f32>,
    max_boundary_hits: usize,
    sampler: &mut prism::sampler::Sampler,
) -> Option<(Vec3, f32)> {
    use prism::geometry::Ray;
    use prism::spectrum::SampledSpectrum;
    let mut beta = SampledSpectrum::ONE;
    let mut ray = Ray::new(Vec3::new(0.0, 0.0, -1e-4), -Vec3::Z);
    for _ in 0..max_boundary_hits {
        let (hit, last) = prism::bssrdf::random_walk::walk(
            geometry,
            ray,
            SampledSpectrum::splat(sigma_a),
            SampledSpectrum::splat(sigma_s),
            0.0,
            1,
            Some(Vec3::Z), // guided towards the top face, as the renderer guides its walks
            sampler,
            &mut beta,
        )?;
        let p = last.at(hit.t);
        if p.z.abs() > 1e-2 {
            return None; // sides or bottom
        }
        // last.dir.z > 0: leaving through the top, seen from inside.
        let reflect = eta.is_some_and(|eta| {
            sampler.next_1d() < prism::bsdf::fresnel_dielectric(-last.dir.z, eta)
        });
        if !reflect {
            return Some((p, beta[0]));
        }
        let dir = Vec3::new(last.dir.x, last.dir.y, -last.dir.z);
        ray = Ray::new(Vec3::new(p.x, p.y, -1e-4), dir);
    }
    None
}

/// Builds and renders `desc` (`size` x `size`, on the current rayon pool), asserts no
/// sample was discarded as non-finite, and returns the image's mean RGB and its pixels.
pub fn render_mean(
    desc: SceneDesc,
    size: u32,
    spp: u32,
    max_depth: u32,
    seed: u64,
) -> (Vec3, Vec<[f32; 4]>) {
    let scene = prism::scene::Scene::build(desc).expect("scene builds");
    let settings = prism::render::RenderSettings {
        width: size,
        height: size,
        spp,
        max_depth,
        seed,
        ..Default::default()
    };
    let rgba = render_rgba(&scene, &settings);
    (mean_rgb(&rgba), rgba)
}

/// Renders a built `scene` (on the current rayon pool), asserts no sample was discarded as
/// non-finite, and returns its pixels.
pub fn render_rgba(
    scene: &prism::scene::Scene,
    settings: &prism::render::RenderSettings,
) -> Vec<[f32; 4]> {
    let (film, stats) = prism::render::render_quiet(scene, settings);
    assert_eq!(stats.discarded, 0, "non-finite samples");
    film.to_rgba()
}

/// Mean RGB of an image's pixels.
pub fn mean_rgb(rgba: &[[f32; 4]]) -> Vec3 {
    rgba.iter()
        .map(|p| Vec3::new(p[0], p[1], p[2]))
        .sum::<Vec3>()
        / rgba.len() as f32
}

/// One instance of each mesh in turn, in place (identity transform), named `names[i]`.
pub fn instances_in_place(names: &[&str]) -> Vec<InstanceDesc> {
    names
        .iter()
        .enumerate()
        .map(|(mesh, name)| InstanceDesc {
            mesh,
            object_to_world: Mat4::IDENTITY,
            name: (*name).into(),
        })
        .collect()
}

/// A quad (two triangles) centred at `c` with half-edges `u` and `v`; its geometric normal is
/// along u x v (the front face of a one-sided emitter).
pub fn quad_mesh(name: &str, c: Vec3, u: Vec3, v: Vec3, material: usize) -> MeshDesc {
    MeshDesc {
        name: name.into(),
        positions: vec![c - u - v, c + u - v, c + u + v, c - u + v],
        normals: None,
        uvs: None,
        tangents: None,
        indices: vec![0, 1, 2, 0, 2, 3],
        material: Some(material),
        ..Default::default()
    }
}

/// A black surface emitting radiance `rgb` (from both faces when `double_sided`).
pub fn emissive_material(name: &str, rgb: Vec3, double_sided: bool) -> MaterialDesc {
    MaterialDesc {
        gltf: GltfMaterialDesc {
            name: name.into(),
            base_color: glam::Vec4::new(0.0, 0.0, 0.0, 1.0),
            emissive: rgb,
            double_sided,
            ..Default::default()
        },
        sidecar: None,
        graph: None,
        ..Default::default()
    }
}

/// Relative MSE of an image against a reference: (a - r)^2 / (r^2 + 0.01) per pixel and
/// channel, averaged.
pub fn rel_mse(img: &[[f32; 4]], reference: &[[f32; 4]]) -> f64 {
    img.iter()
        .zip(reference)
        .map(|(a, r)| {
            (0..3)
                .map(|c| ((a[c] - r[c]) as f64).powi(2) / ((r[c] as f64).powi(2) + 1e-2))
                .sum::<f64>()
                / 3.0
        })
        .sum::<f64>()
        / img.len() as f64
}
