//! The render-ready scene: geometry with its BVHs, runtime materials, lights and camera,
//! built from a `SceneDesc`.

use super::camera::Camera;
use super::desc::{
    CameraDesc, MaterialDesc, PunctualLightDesc, RenderDefaults, SceneDesc, TextureDesc, WorldDesc,
};
use super::material::Material;
use crate::error::{PrismError, Result};
use crate::geometry::{BvhLayout, Geometry, Instance, Mesh, MotionTransform};
use crate::lights::envmap::EnvironmentMap;
use crate::lights::{Lights, World};
use glam::{Affine3A, Mat4, Vec3};
use rayon::prelude::*;

pub struct Scene {
    pub geometry: Geometry,
    pub materials: Vec<Material>,
    pub textures: Vec<TextureDesc>,
    pub lights: Lights,
    pub camera: CameraDesc,
    pub render_defaults: RenderDefaults,
    pub warnings: Vec<String>,
    /// What the materials and lights were built from, kept so that a live session
    /// (`crate::serve`) can replace them without reloading the geometry.
    shading: ShadingDescs,
    /// The glTF node name of each runtime instance (`geometry.instances[i]`).
    instance_names: Vec<String>,
}

/// The scene's descriptions that are rebuilt on a shading edit.
struct ShadingDescs {
    materials: Vec<MaterialDesc>,
    lights: Vec<PunctualLightDesc>,
    world: WorldDesc,
}

impl Scene {
    /// Whether anything moves during the shutter (then each camera path samples a time).
    pub fn has_motion(&self) -> bool {
        motion_of(&self.camera.motion).is_some_and(|m| !m.is_static())
            || self.geometry.instances.iter().any(|i| i.motion.is_some())
            || self.geometry.meshes.iter().any(|m| m.deforms())
    }

    /// Builds acceleration structures and light tables. Fails (as bad input) only for scenes
    /// that cannot produce an image: no camera, no light at all.
    pub fn build(desc: SceneDesc) -> Result<Scene> {
        Self::build_with_layout(desc, BvhLayout::Flattened)
    }

    /// As [`Scene::build`], with the BVH arranged as `layout` says.
    pub fn build_with_layout(desc: SceneDesc, layout: BvhLayout) -> Result<Scene> {
        let SceneDesc {
            meshes,
            instances,
            materials,
            textures,
            lights,
            camera,
            world,
            render,
            mut warnings,
            instance_visibility,
            instance_motion,
        } = desc;
        let camera = camera.ok_or_else(|| PrismError::input("the scene has no camera"))?;

        let default_material = materials.len() as u32;
        // Meshes: keep valid triangles only (indices in range, finite, non-zero area), built
        // side by side. Their BVHs come with the geometry (`Geometry::new`): one flattened BVH
        // for the meshes one instance uses, a BVH each for the shared ones.
        let described_meshes = meshes.len();
        let built: Vec<(usize, Mesh)> = meshes
            .into_par_iter()
            .enumerate()
            .filter_map(|(mi, m)| {
                let n = m.positions.len() as u32;
                let tris: Vec<[u32; 3]> = m
                    .indices
                    .par_chunks_exact(3)
                    .map(|c| [c[0], c[1], c[2]])
                    .filter(|&[a, b, c]| {
                        if a >= n || b >= n || c >= n {
                            return false;
                        }
                        let (p0, p1, p2) = (
                            m.positions[a as usize],
                            m.positions[b as usize],
                            m.positions[c as usize],
                        );
                        let cross = (p1 - p0).cross(p2 - p0);
                        p0.is_finite()
                            && p1.is_finite()
                            && p2.is_finite()
                            && cross.length_squared() > 0.0
                    })
                    .collect();
                if tris.is_empty() {
                    return None;
                }
                let normals = m.normals.filter(|v| v.len() == m.positions.len());
                let uvs = m.uvs.filter(|v| v.len() == m.positions.len());
                let material = match m.material {
                    Some(i) if i < materials.len() => i as u32,
                    _ => default_material,
                };
                let mut mesh = Mesh::without_bvh(m.positions, normals, uvs, tris, material)
                    .with_tangents(m.tangents)
                    .with_attributes(m.extra_uvs, m.colors);
                if let Some(d) = m.deformation {
                    mesh = mesh.with_deformation(d.positions, d.normals);
                }
                Some((mi, mesh))
            })
            .collect();
        let mut mesh_map = vec![u32::MAX; described_meshes];
        let mut runtime_meshes = Vec::with_capacity(built.len());
        for (mi, mesh) in built {
            mesh_map[mi] = runtime_meshes.len() as u32;
            runtime_meshes.push(mesh);
        }
        let mut motion_warnings = Vec::new();
        let (runtime_instances, instance_names): (Vec<Instance>, Vec<String>) = instances
            .iter()
            .enumerate()
            .filter_map(|(i, inst)| {
                let mesh = *mesh_map.get(inst.mesh)?;
                if mesh == u32::MAX {
                    return None;
                }
                let affine = invertible(inst.object_to_world)?;
                let vis = instance_visibility.get(i).copied().unwrap_or_default();
                let mut instance = Instance::new(mesh, affine)
                    .with_visibility(vis.casts_shadows, vis.camera_visible)
                    .with_holdout(vis.holdout)
                    .with_light_only(vis.light_only)
                    .with_light_visibility(vis.light_visibility);
                if let Some(keys) = instance_motion.get(i).filter(|k| !k.is_empty()) {
                    match motion_of(keys) {
                        Some(m) => instance = instance.with_motion(m),
                        None => motion_warnings.push(format!(
                            "object '{}': its motion has a singular or non-finite transform; rendered without motion blur",
                            inst.name
                        )),
                    }
                }
                Some((instance, inst.name.clone()))
            })
            .unzip();
        warnings.append(&mut motion_warnings);
        let geometry = Geometry::with_layout(runtime_meshes, runtime_instances, layout);
        let shading = ShadingDescs {
            materials,
            lights,
            world,
        };
        let (materials, lights) = build_shading(&geometry, &shading, &textures)?;
        // No light at all is allowed: the image is black (`load::load_scene` warns).
        Ok(Scene {
            geometry,
            materials,
            textures,
            lights,
            camera,
            render_defaults: render,
            warnings,
            shading,
            instance_names,
        })
    }

    /// Moves the instances of the named glTF nodes to new object-to-world matrices (in the
    /// scene's world space): the top level of the BVH and the light tables are rebuilt, the
    /// meshes' BVHs are kept. Returns how many instances moved; a name no instance has, or a
    /// singular matrix, is an input error (and nothing moves).
    pub fn set_transforms(&mut self, moves: &[(String, Mat4)]) -> Result<usize> {
        let mut resolved = Vec::new();
        for (name, m) in moves {
            let affine = invertible(*m).ok_or_else(|| {
                PrismError::input(format!(
                    "transform of '{name}': the matrix is not invertible"
                ))
            })?;
            let before = resolved.len();
            for (i, n) in self.instance_names.iter().enumerate() {
                if n == name {
                    resolved.push((i as u32, affine));
                }
            }
            if resolved.len() == before {
                return Err(PrismError::input(format!(
                    "transform of '{name}': no instance of the scene has that name"
                )));
            }
        }
        self.geometry.set_transforms(&resolved);
        (self.materials, self.lights) =
            build_shading(&self.geometry, &self.shading, &self.textures)?;
        Ok(resolved.len())
    }

    /// Replaces the materials (matched by name: every material of the scene must be in
    /// `desc`), the punctual lights and the world by those of `desc`, keeping the geometry.
    /// `desc`'s meshes, instances and camera are ignored.
    pub fn replace_shading(&mut self, desc: SceneDesc) -> Result<()> {
        let mut materials = Vec::with_capacity(self.shading.materials.len());
        for old in &self.shading.materials {
            let name = &old.gltf.name;
            let new = desc
                .materials
                .iter()
                .find(|m| &m.gltf.name == name)
                .ok_or_else(|| {
                    PrismError::input(format!(
                        "material '{name}' of the scene is not in the new shading"
                    ))
                })?;
            materials.push(new.clone());
        }
        let shading = ShadingDescs {
            materials,
            lights: desc.lights,
            world: desc.world,
        };
        let (runtime, lights) = build_shading(&self.geometry, &shading, &desc.textures)?;
        self.materials = runtime;
        self.lights = lights;
        self.textures = desc.textures;
        self.shading = shading;
        self.warnings = desc.warnings;
        Ok(())
    }

    /// The camera for an image of the given size.
    pub fn camera_for(&self, width: u32, height: u32) -> Camera {
        let to_world = Affine3A::from_mat4(self.camera.camera_to_world);
        if let Some(p) = self.camera.panorama {
            return self.with_camera_motion(Camera::panoramic(to_world, p, width, height));
        }
        let camera = match self.camera.orthographic {
            Some(mag) => Camera::orthographic(to_world, mag.y, width, height),
            None => Camera::new(to_world, self.camera.yfov, width, height),
        }
        .with_shift(self.camera.shift);
        let camera = match self.camera.lens {
            Some(l) => camera.with_thin_lens(l.aperture_radius, l.focus_distance),
            None => camera,
        };
        self.with_camera_motion(camera)
    }

    /// The camera moving as `camera.motion` says (unchanged without motion).
    fn with_camera_motion(&self, camera: Camera) -> Camera {
        match motion_of(&self.camera.motion) {
            Some(m) if self.camera.motion.len() >= 2 => camera.with_motion(m),
            _ => camera,
        }
    }
}

/// A motion over the shutter from its keys; `None` when a key is singular or not finite.
fn motion_of(keys: &[Mat4]) -> Option<MotionTransform> {
    let affine: Option<Vec<Affine3A>> = keys.iter().map(|&m| invertible(m)).collect();
    MotionTransform::new(affine?)
}

/// The affine form of an object-to-world matrix; `None` when it is singular or not finite.
fn invertible(m: Mat4) -> Option<Affine3A> {
    let affine = Affine3A::from_mat4(m);
    let det = glam::Mat3::from(affine.matrix3).determinant();
    (det.is_finite() && det.abs() > 1e-30).then_some(affine)
}

/// Runtime materials (the described ones, then glTF's default material for primitives without
/// one: white, metallic 1, roughness 1 per the spec) and the light tables, over `geometry`.
fn build_shading(
    geometry: &Geometry,
    shading: &ShadingDescs,
    textures: &[TextureDesc],
) -> Result<(Vec<Material>, Lights)> {
    let mut materials: Vec<Material> = shading
        .materials
        .iter()
        .map(|m| Material::new(m, textures))
        .collect();
    materials.push(Material::new(
        &MaterialDesc {
            gltf: super::desc::GltfMaterialDesc {
                name: "(glTF default)".into(),
                ..Default::default()
            },
            ..Default::default()
        },
        textures,
    ));
    estimate_density_bounds(geometry, &mut materials);
    let world = &shading.world;
    let tint = if world.strength > 0.0 {
        world.color.max(Vec3::ZERO) * world.strength
    } else {
        Vec3::ZERO
    };
    let world_light = match &world.texture {
        Some(tex) if tint.max_element() > 0.0 => {
            if tex.width == 0
                || tex.height == 0
                || tex.texels.len() != (tex.width * tex.height) as usize
            {
                return Err(PrismError::input(format!(
                    "{}: the environment texture's size does not match its data",
                    tex.name
                )));
            }
            World::Map(Box::new(EnvironmentMap::new(
                tex.width,
                tex.height,
                &tex.texels,
                tint,
                tex.rotation_z,
            )))
        }
        Some(_) => World::Black,
        None => World::Uniform(tint),
    };
    let lights = Lights::build(geometry, &materials, &shading.lights, world_light);
    Ok((materials, lights))
}

/// Points per majorant-grid cell at which a heterogeneous volume's density is sampled.
const DENSITY_SAMPLES_PER_CELL: u64 = 16;

/// Bounds the density field of every heterogeneous volume (`crate::media::DensityField`): a
/// majorant grid per instance over its mesh's box (`crate::media::grid`), each cell the largest
/// of 16 densities sampled in it plus 25%, and the largest of them as the global
/// bound. Delta tracking needs a majorant; shading graphs have no analytic bound, so densities
/// above it (narrow peaks between the samples) are clamped to it.
fn estimate_density_bounds(geometry: &Geometry, materials: &mut [Material]) {
    use crate::media::grid::{MajorantGrid, GRID_RES};
    use crate::sampler::mix64;
    let unit = |k: u64, axis: u64| (mix64(k * 4 + axis) >> 40) as f32 / (1u64 << 24) as f32;
    let n_cells = (GRID_RES * GRID_RES * GRID_RES) as u64;
    for (mi, material) in materials.iter_mut().enumerate() {
        let Some(field) = material.interior().and_then(|m| m.density()).cloned() else {
            continue;
        };
        let mut grids = Vec::new();
        let mut max_density = 0.0f32;
        for (ii, inst) in geometry.instances.iter().enumerate() {
            let mesh = &geometry.meshes[inst.mesh as usize];
            if mesh.material != mi as u32 {
                continue;
            }
            let b = mesh.aabb();
            let (lo, hi) = (glam::Vec3::from(b.min), glam::Vec3::from(b.max));
            let sampled: Vec<f32> = (0..n_cells)
                .into_par_iter()
                .map(|cell| {
                    (0..DENSITY_SAMPLES_PER_CELL)
                        .map(|j| {
                            let k = cell * DENSITY_SAMPLES_PER_CELL + j;
                            let u = glam::Vec3::new(unit(k, 1), unit(k, 2), unit(k, 3));
                            let object = MajorantGrid::cell_point(lo, hi, cell as usize, u);
                            let world = inst.placement.object_to_world.transform_point3(object);
                            let inputs = geometry.volume_inputs(ii as u32, world);
                            // A graph driving only the colour: density 1 everywhere.
                            field.graph.volume_density(&inputs).unwrap_or(1.0)
                        })
                        .fold(0.0f32, f32::max)
                })
                .collect();
            let grid = MajorantGrid::from_samples(lo, hi, &sampled, 1.25);
            max_density = max_density.max(grid.max());
            grids.push((ii as u32, std::sync::Arc::new(grid)));
        }
        if let Some(m) = material.interior_mut() {
            m.set_bounds(max_density, grids);
        }
    }
}
