//! The scene loading entry point: glTF + optional material JSON sidecar -> [`SceneDesc`].

use std::path::{Path, PathBuf};

use crate::error::PrismError;
use crate::scene::desc::SceneDesc;
use crate::scene::gltf_import::import_gltf;
use crate::scene::materials_json::load_materials_file;

/// `<dir>/<stem>.materials.json` for `<dir>/<stem>.gltf|.glb`.
pub fn sidecar_path_for(scene_path: &Path) -> PathBuf {
    let stem = scene_path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    scene_path.with_file_name(format!("{stem}.materials.json"))
}

/// Loads a `.gltf` / `.glb` scene and its material sidecar.
///
/// * `materials_path`: the sidecar; when `None`, `<scene stem>.materials.json` beside the scene
///   is used if it exists.
/// * `camera_name`: pick the camera whose node or camera name matches (default: the first camera
///   node in traversal order).
///
/// Every problem with the input is a one-line [`PrismError::Input`] naming the file; in
/// particular a scene with no light at all (no emissive material on an instanced mesh, no
/// punctual light, and a black world) is rejected.
pub fn load_scene(
    scene_path: &Path,
    materials_path: Option<&Path>,
    camera_name: Option<&str>,
) -> Result<SceneDesc, PrismError> {
    let scene = load_scene_any_camera(scene_path, materials_path, camera_name)?;
    if scene.camera.is_none() {
        return Err(PrismError::input(format!(
            "no camera in {}",
            scene_path.display()
        )));
    }
    Ok(scene)
}

/// As [`load_scene`], but a scene without a camera loads (with `camera` None): for a viewport,
/// which brings its own view.
pub fn load_scene_any_camera(
    scene_path: &Path,
    materials_path: Option<&Path>,
    camera_name: Option<&str>,
) -> Result<SceneDesc, PrismError> {
    load_scene_inner(scene_path, materials_path, camera_name).map_err(|e| match e {
        // Names inside messages come from the files: keep every message on one line.
        PrismError::Input(m) => PrismError::Input(m.replace(['\r', '\n'], " ")),
        other => other,
    })
}

fn load_scene_inner(
    scene_path: &Path,
    materials_path: Option<&Path>,
    camera_name: Option<&str>,
) -> Result<SceneDesc, PrismError> {
    let file = scene_path.display().to_string();
    let ext = scene_path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    match ext.as_deref() {
        Some("gltf") | Some("glb") => {}
        _ => {
            return Err(PrismError::input(format!(
                "{file}: unsupported scene format (expected a .gltf or .glb file)"
            )))
        }
    }
    let imported = import_gltf(scene_path, camera_name)?;
    let mut scene = imported.scene;

    let sidecar = match materials_path {
        Some(p) => Some(p.to_path_buf()),
        None => {
            let p = sidecar_path_for(scene_path);
            p.is_file().then_some(p)
        }
    };
    if let Some(sidecar) = sidecar {
        let names: Vec<String> = imported.material_names.iter().flatten().cloned().collect();
        let mf = load_materials_file(&sidecar, Some(&names))?;
        for (name, ov) in &mf.materials {
            for (i, n) in imported.material_names.iter().enumerate() {
                if n.as_deref() == Some(name.as_str()) {
                    scene.materials[i].sidecar = Some(ov.clone());
                }
            }
        }
        // A Holdout material makes every instance drawn with it a holdout.
        for name in &mf.holdouts {
            for (i, inst) in scene.instances.iter().enumerate() {
                let material = scene.meshes[inst.mesh].material;
                let named =
                    material.and_then(|m| imported.material_names.get(m).cloned().flatten());
                if named.as_deref() == Some(name.as_str()) {
                    let vis = &mut scene.instance_visibility;
                    vis.resize(vis.len().max(i + 1), Default::default());
                    vis[i].holdout = true;
                }
            }
        }
        for (name, volume, null_surface) in &mf.volumes {
            for (i, n) in imported.material_names.iter().enumerate() {
                if n.as_deref() == Some(name.as_str()) {
                    scene.materials[i].volume = Some(volume.clone());
                    scene.materials[i].null_surface = *null_surface;
                }
            }
        }
        for name in &mf.gltf_models {
            for (i, n) in imported.material_names.iter().enumerate() {
                if n.as_deref() == Some(name.as_str()) {
                    scene.materials[i].gltf_brdf = true;
                }
            }
        }
        for name in &mf.principled_v1_models {
            for (i, n) in imported.material_names.iter().enumerate() {
                if n.as_deref() == Some(name.as_str()) {
                    scene.materials[i].principled_v1 = true;
                }
            }
        }
        for (name, graph) in &mf.graphs {
            for (i, n) in imported.material_names.iter().enumerate() {
                if n.as_deref() == Some(name.as_str()) {
                    scene.materials[i].graph = Some(graph.clone());
                }
            }
        }
        scene.warnings.extend(mf.warnings.iter().cloned());
        if let Some(w) = mf.world {
            scene.world = w;
        }
        if let (Some(c), Some(cam)) = (mf.camera, scene.camera.as_mut()) {
            cam.lens = c.lens;
            cam.shift = c.shift;
            cam.panorama = c.panorama;
        }
        scene.render = mf.render;
        if scene.render.texture_filtering.as_deref() == Some("cycles") {
            for texture in &mut scene.textures {
                texture.filter_encoded_as_cycles();
            }
        }
    }

    if !has_light(&scene) {
        // Blender renders a scene without light black; refusing it would stop a render farm
        // on a valid (if dark) file.
        scene.warnings.push(format!(
            "{file}: the scene has no light (no emissive material on any mesh, no KHR_lights_punctual light, and the world strength is 0): the image is black"
        ));
    }
    Ok(scene)
}

/// True when something in the scene emits: an instanced mesh with an emissive material, a
/// punctual light with non-zero power, or a non-black world.
pub fn has_light(scene: &SceneDesc) -> bool {
    let emissive_mesh = scene.instances.iter().any(|inst| {
        scene
            .meshes
            .get(inst.mesh)
            .and_then(|m| m.material)
            .and_then(|mi| scene.materials.get(mi))
            .is_some_and(|mat| {
                mat.gltf.emissive.max_element() > 0.0
                    || mat.graph.as_ref().is_some_and(|g| g.drives_emission())
                    || mat
                        .volume
                        .as_ref()
                        .is_some_and(|v| v.emission.max_element() > 0.0)
            })
    });
    let punctual = scene
        .lights
        .iter()
        .any(|l| l.intensity > 0.0 && l.color.max_element() > 0.0);
    let world = scene.world.strength > 0.0 && scene.world.color.max_element() > 0.0;
    emissive_mesh || punctual || world
}
