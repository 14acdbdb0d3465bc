//! `prism serve`: a renderer that stays up for an interactive session (Blender's rendered
//! viewport). The scene is loaded and its BVHs built once; edits then cost only what they
//! change, and every edit restarts progressive sampling:
//!
//! * a view change (camera, projection, size) costs nothing but the restart;
//! * moving objects rebuilds the top level of the BVH and the light tables (the scene is
//!   built with [`BvhLayout::TwoLevel`] so that no mesh BVH depends on a transform);
//! * a shading edit (materials, punctual lights, world) rebuilds materials and light tables;
//! * a mesh edit is a new `load`, where the BVH cache (`--bvh-cache`) rebuilds only the meshes
//!   whose content changed.
//!
//! # Protocol
//!
//! Commands arrive on stdin, one JSON object per line, with a `"cmd"` field. Unknown commands
//! and fields are errors. Commands that arrive while a render runs stop it within one pixel's
//! samples; commands queued together are applied together, then rendering restarts once.
//!
//! | `cmd` | fields | effect |
//! |---|---|---|
//! | `load` | `scene`, `materials`? | load a glTF + material JSON (replaces everything) |
//! | `shading` | `scene`, `materials`? | take materials (by name), punctual lights and world from this glTF + JSON |
//! | `transform` | `objects`: [{`name`, `matrix`}] | move every instance of each named glTF node; `matrix`: 16 numbers, column-major object-to-world in the scene's (glTF, Y-up) world |
//! | `view` | `width`, `height`, `camera`? | image size; `camera` {`to_world` (16, column-major), `yfov` (radians) or `ortho_half_height`, `shift`? [x, y] x the view height, `aperture_radius`?, `focus_distance`?}; without `camera`: the scene's own |
//! | `settings` | `samples`?, `max_depth`?, `pixel_size`?, `start_resolution`?, `denoise`?, `oidn`?, `denoise_start_sample`? | samples per pixel (0: until stopped), path depth, render at 1/`pixel_size` of the view's size, largest side of the first preview; denoise frames (Open Image Denoise, loaded from `oidn`: a file or a folder, else the system's) from `denoise_start_sample` samples on |
//! | `stop` | | stop rendering until the next command |
//! | `quit` | | end the process (so does the end of stdin) |
//!
//! Events go to stdout, one JSON object per line:
//! `{"event":"ready","version":...}` at start; `{"event":"loaded","generation":..,"seconds":..,
//! "warnings":[..],"bvh_cache_hits":..,"bvh_cache_misses":..}` after `load` (the BVHs this load
//! found in the cache or built: with `--bvh-cache`, a re-load after a mesh edit builds one); `{"event":"ok","cmd":..,"generation":..,"seconds":..}` after
//! other commands;
//! `{"event":"error","cmd":..,"message":..}` when a command fails (the session goes on with what
//! it had); `{"event":"done","generation":..,"spp":..,"seconds":..}` when a render finishes;
//! `{"event":"idle","generation":..}` when there is nothing to render (no scene or no view yet,
//! or after `stop`).
//! A frame is `{"event":"frame","generation":G,"width":W,"height":H,"spp":S,"bytes":N}`
//! followed by N = W x H x 16 raw bytes: little-endian f32 RGBA, scene-linear Rec.709, rows
//! from the bottom up (a texture's layout). The generation counts restarts, so a client can
//! drop frames of a view it has left. The first frames of a generation are 1-spp previews at
//! reduced resolution (largest side `start_resolution`, then doubled), then the full size
//! refines progressively.

use crate::error::{PrismError, Result};
use crate::film::denoise::{DenoiseOptions, Oidn, OidnLocation};
use crate::film::{FilterKind, PixelFilter};
use crate::geometry::BvhLayout;
use crate::integrator::{WavelengthPdf, WavelengthSampling, WavelengthStrategy};
use crate::lights::LightSelection;
use crate::render::{render, RenderSettings};
use crate::sampler::SamplerKind;
use crate::scene::desc::{CameraDesc, LensDesc};
use crate::scene::{load_scene_any_camera, Scene};
use glam::{Mat4, Vec2};
use serde::Deserialize;
use std::io::{BufRead, Write};
use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc;
use std::sync::{Arc, Mutex};
use std::thread::JoinHandle;
use std::time::Instant;

#[derive(Deserialize)]
#[serde(tag = "cmd", rename_all = "snake_case")]
enum Command {
    Load(SceneFiles),
    Shading(SceneFiles),
    Transform(TransformCommand),
    View(ViewCommand),
    Settings(SettingsCommand),
    Stop(Empty),
    Quit(Empty),
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct Empty {}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SceneFiles {
    scene: PathBuf,
    materials: Option<PathBuf>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct TransformCommand {
    objects: Vec<ObjectMove>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ObjectMove {
    name: String,
    matrix: [f32; 16],
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct ViewCommand {
    width: u32,
    height: u32,
    camera: Option<ViewCamera>,
}

#[derive(Clone, Deserialize)]
#[serde(deny_unknown_fields)]
struct ViewCamera {
    to_world: [f32; 16],
    yfov: Option<f32>,
    ortho_half_height: Option<f32>,
    #[serde(default)]
    shift: [f32; 2],
    #[serde(default)]
    aperture_radius: f32,
    #[serde(default)]
    focus_distance: f32,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct SettingsCommand {
    samples: Option<u32>,
    max_depth: Option<u32>,
    pixel_size: Option<u32>,
    start_resolution: Option<u32>,
    denoise: Option<bool>,
    oidn: Option<PathBuf>,
    denoise_start_sample: Option<u32>,
}

/// Viewport sampling settings (`settings` command).
#[derive(Clone, Copy, Debug)]
struct Sampling {
    /// 0: until stopped.
    samples: u32,
    max_depth: Option<u32>,
    pixel_size: u32,
    start_resolution: u32,
    /// Denoise frames from this many samples on (`None`: no denoising).
    denoise_from: Option<u32>,
}

/// Samples per progressive pass in a session: a frame every few samples, not every 64.
const SESSION_PASS_SAMPLES: u32 = 4;
/// "Until stopped": a sample count no session reaches.
const ENDLESS_SPP: u32 = 1 << 24;

type Output = Arc<Mutex<Box<dyn Write + Send>>>;

/// Writes one event line (and an optional binary payload after it) in one piece.
fn emit(out: &Output, event: &serde_json::Value, payload: Option<&[u8]>) {
    let Ok(mut w) = out.lock() else { return };
    // A closed stdout (the client went away) is not an error worth reporting: stdin's end
    // will end the session.
    let _ = writeln!(w, "{event}");
    if let Some(p) = payload {
        let _ = w.write_all(p);
    }
    let _ = w.flush();
}

/// A render running on its own thread.
struct Job {
    cancel: Arc<AtomicBool>,
    handle: JoinHandle<()>,
}

struct Session {
    out: Output,
    pool: Arc<rayon::ThreadPool>,
    scene: Option<Arc<Scene>>,
    /// The loaded scene's own camera (a `view` without `camera` goes back to it).
    scene_camera: Option<CameraDesc>,
    view: Option<(u32, u32)>,
    sampling: Sampling,
    /// The Open Image Denoise library, once a `settings` command turned denoising on.
    oidn: Option<Arc<Oidn>>,
    generation: u64,
    job: Option<Job>,
}

/// Runs a session: commands from `input` until `quit` or its end, events to `output`.
pub fn serve(
    input: impl BufRead + Send + 'static,
    output: impl Write + Send + 'static,
    pool: rayon::ThreadPool,
) -> Result<()> {
    let out: Output = Arc::new(Mutex::new(Box::new(output)));
    emit(
        &out,
        &serde_json::json!({"event": "ready", "version": env!("CARGO_PKG_VERSION")}),
        None,
    );
    // Lines are read on their own thread so that commands queued during a render are seen
    // together (and applied before one restart).
    let (tx, rx) = mpsc::channel::<String>();
    std::thread::spawn(move || {
        for line in input.lines() {
            let Ok(line) = line else { break };
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    let mut session = Session {
        out,
        pool: Arc::new(pool),
        scene: None,
        scene_camera: None,
        view: None,
        sampling: Sampling {
            samples: 0,
            max_depth: None,
            pixel_size: 1,
            start_resolution: 64,
            denoise_from: None,
        },
        oidn: None,
        generation: 0,
        job: None,
    };
    while let Ok(first) = rx.recv() {
        let mut lines = vec![first];
        lines.extend(rx.try_iter());
        session.stop();
        let mut restart = true;
        for line in lines.iter().filter(|l| !l.trim().is_empty()) {
            match session.apply(line) {
                Ok(Flow::Continue) => restart = true,
                Ok(Flow::Pause) => restart = false,
                Ok(Flow::Quit) => return Ok(()),
                Err(e) => {
                    let cmd = serde_json::from_str::<serde_json::Value>(line)
                        .ok()
                        .and_then(|v| v.get("cmd").cloned())
                        .unwrap_or(serde_json::Value::Null);
                    let message = e.to_string().replace('\n', " ");
                    emit(
                        &session.out,
                        &serde_json::json!({"event": "error", "cmd": cmd, "message": message,
                            "generation": session.generation}),
                        None,
                    );
                }
            }
        }
        if restart {
            session.start();
        } else {
            emit(
                &session.out,
                &serde_json::json!({"event": "idle", "generation": session.generation}),
                None,
            );
        }
    }
    session.stop();
    Ok(())
}

enum Flow {
    Continue,
    Pause,
    Quit,
}

impl Session {
    /// Stops the running render, if any, and waits for it (so the scene is ours to change).
    fn stop(&mut self) {
        if let Some(job) = self.job.take() {
            job.cancel.store(true, Ordering::Relaxed);
            let _ = job.handle.join();
        }
    }

    /// The scene, for changing: no render holds it (`stop` ran before).
    fn scene_mut(&mut self) -> Result<&mut Scene> {
        let scene = self
            .scene
            .as_mut()
            .ok_or_else(|| PrismError::input("no scene is loaded (send a 'load' first)"))?;
        Arc::get_mut(scene).ok_or_else(|| PrismError::internal("the scene is still rendering"))
    }

    fn apply(&mut self, line: &str) -> Result<Flow> {
        let start = Instant::now();
        let command: Command = serde_json::from_str(line)
            .map_err(|e| PrismError::input(format!("bad command: {e}")))?;
        // Every command but stop and quit starts a new generation of frames.
        if !matches!(command, Command::Stop(_) | Command::Quit(_)) {
            self.generation += 1;
        }
        let generation = self.generation;
        let ok = |out: &Output, cmd: &str| {
            emit(
                out,
                &serde_json::json!({"event": "ok", "cmd": cmd, "generation": generation,
                    "seconds": start.elapsed().as_secs_f64()}),
                None,
            )
        };
        match command {
            Command::Load(files) => {
                // Dropped first: two scenes need not fit in memory at once.
                self.scene = None;
                let mut desc =
                    load_scene_any_camera(&files.scene, files.materials.as_deref(), None)?;
                if desc.camera.is_none() {
                    // A viewport needs no scene camera: until a `view` brings one, look down
                    // -Z from the origin.
                    desc.camera = Some(CameraDesc {
                        name: "(default)".into(),
                        camera_to_world: Mat4::IDENTITY,
                        yfov: 0.8,
                        ..Default::default()
                    });
                }
                self.scene_camera = desc.camera.clone();
                let (hits, misses) = crate::geometry::bvh_cache::counters();
                let scene = Scene::build_with_layout(desc, BvhLayout::TwoLevel)?;
                let (hits_after, misses_after) = crate::geometry::bvh_cache::counters();
                let warnings = scene.warnings.clone();
                self.scene = Some(Arc::new(scene));
                emit(
                    &self.out,
                    &serde_json::json!({"event": "loaded", "generation": generation,
                        "seconds": start.elapsed().as_secs_f64(), "warnings": warnings,
                        "bvh_cache_hits": hits_after - hits,
                        "bvh_cache_misses": misses_after - misses}),
                    None,
                );
                return Ok(Flow::Continue);
            }
            Command::Shading(files) => {
                let desc = load_scene_any_camera(&files.scene, files.materials.as_deref(), None)?;
                self.scene_mut()?.replace_shading(desc)?;
                ok(&self.out, "shading");
            }
            Command::Transform(t) => {
                let moves: Vec<(String, Mat4)> = t
                    .objects
                    .into_iter()
                    .map(|o| (o.name, Mat4::from_cols_array(&o.matrix)))
                    .collect();
                self.scene_mut()?.set_transforms(&moves)?;
                ok(&self.out, "transform");
            }
            Command::View(v) => {
                if v.width == 0 || v.height == 0 || v.width > 16384 || v.height > 16384 {
                    return Err(PrismError::input(format!(
                        "view size {}x{} is out of range (1 to 16384 per side)",
                        v.width, v.height
                    )));
                }
                let camera = match &v.camera {
                    Some(c) => Some(view_camera(c)?),
                    None => self.scene_camera.clone(),
                };
                let scene = self.scene_mut()?;
                if let Some(c) = camera {
                    scene.camera = c;
                }
                self.view = Some((v.width, v.height));
                ok(&self.out, "view");
            }
            Command::Settings(s) => {
                let mut sampling = self.sampling;
                if let Some(n) = s.samples {
                    sampling.samples = n;
                }
                if let Some(d) = s.max_depth {
                    if !(1..=1024).contains(&d) {
                        return Err(PrismError::input("max_depth must be 1 to 1024"));
                    }
                    sampling.max_depth = Some(d);
                }
                if let Some(p) = s.pixel_size {
                    if !(1..=64).contains(&p) {
                        return Err(PrismError::input("pixel_size must be 1 to 64"));
                    }
                    sampling.pixel_size = p;
                }
                if let Some(r) = s.start_resolution {
                    sampling.start_resolution = r;
                }
                if let Some(n) = s.denoise_start_sample {
                    sampling.denoise_from = sampling.denoise_from.map(|_| n.max(1));
                }
                match s.denoise {
                    Some(false) => sampling.denoise_from = None,
                    Some(true) => {
                        if self.oidn.is_none() {
                            let location = match &s.oidn {
                                Some(p) => OidnLocation::Path(p.clone()),
                                None => OidnLocation::System,
                            };
                            let oidn = Oidn::load(&location).map_err(|e| {
                                PrismError::input(format!("denoise: {e}; frames stay noisy"))
                            })?;
                            self.oidn = Some(Arc::new(oidn));
                        }
                        sampling.denoise_from = Some(s.denoise_start_sample.unwrap_or(1).max(1));
                    }
                    None => {}
                }
                self.sampling = sampling;
                ok(&self.out, "settings");
            }
            Command::Stop(_) => {
                ok(&self.out, "stop");
                return Ok(Flow::Pause);
            }
            Command::Quit(_) => return Ok(Flow::Quit),
        }
        Ok(Flow::Continue)
    }

    /// Starts rendering the current scene and view, if both are there.
    fn start(&mut self) {
        let (Some(scene), Some((width, height))) = (self.scene.clone(), self.view) else {
            emit(
                &self.out,
                &serde_json::json!({"event": "idle", "generation": self.generation}),
                None,
            );
            return;
        };
        let sampling = self.sampling;
        let oidn = self
            .oidn
            .clone()
            .filter(|_| sampling.denoise_from.is_some());
        let mut settings = session_settings(
            &scene,
            width / sampling.pixel_size,
            height / sampling.pixel_size,
            sampling.samples,
            sampling.max_depth,
        );
        // The denoiser's albedo and normal guides.
        settings.guides = oidn.is_some();
        let cancel = Arc::new(AtomicBool::new(false));
        let (out, pool, generation) = (self.out.clone(), self.pool.clone(), self.generation);
        let job_cancel = cancel.clone();
        let handle = std::thread::spawn(move || {
            pool.install(|| {
                let denoiser = oidn.as_deref().map(|o| (o, pool.current_num_threads()));
                run_job(
                    &scene,
                    settings,
                    sampling,
                    denoiser,
                    generation,
                    &job_cancel,
                    &out,
                );
            })
        });
        self.job = Some(Job { cancel, handle });
    }
}

/// The scene's camera description for a `view` command's camera.
fn view_camera(c: &ViewCamera) -> Result<CameraDesc> {
    let to_world = Mat4::from_cols_array(&c.to_world);
    if !to_world.is_finite() || to_world.determinant().abs() < 1e-12 {
        return Err(PrismError::input(
            "view camera: to_world is not an invertible matrix",
        ));
    }
    let positive = |v: f32| v.is_finite() && v > 0.0;
    let (yfov, orthographic) = match (c.yfov, c.ortho_half_height) {
        (Some(f), None) if positive(f) && f < std::f32::consts::PI => (f, None),
        (None, Some(h)) if positive(h) => (0.0, Some(Vec2::new(h, h))),
        _ => {
            return Err(PrismError::input(
                "view camera: give either yfov (0 to pi radians) or ortho_half_height (> 0)",
            ))
        }
    };
    let lens = (positive(c.aperture_radius) && positive(c.focus_distance)).then_some(LensDesc {
        aperture_radius: c.aperture_radius,
        focus_distance: c.focus_distance,
    });
    Ok(CameraDesc {
        name: "(view)".into(),
        camera_to_world: to_world,
        yfov,
        aspect: None,
        orthographic,
        lens,
        shift: Vec2::from(c.shift),
        panorama: None,
        motion: Vec::new(),
    })
}

/// Render settings of a session at `width` x `height` (after the pixel size) and `samples` per
/// pixel (0: until stopped): the scene's render defaults where they describe the image
/// (wavelengths, filter, sampler, light selection, transparency, path depth unless
/// `max_depth` is given), no adaptive sampling, time limit, clamps or crop, and short passes.
pub fn session_settings(
    scene: &Scene,
    width: u32,
    height: u32,
    samples: u32,
    max_depth: Option<u32>,
) -> RenderSettings {
    let d = &scene.render_defaults;
    let filter = d
        .filter
        .as_ref()
        .and_then(|(name, w)| PixelFilter::new(FilterKind::from_name(name)?, *w).ok())
        .unwrap_or_default();
    RenderSettings {
        width: width.max(1),
        height: height.max(1),
        spp: if samples == 0 { ENDLESS_SPP } else { samples },
        max_depth: max_depth.or(d.max_depth).unwrap_or(16),
        wavelengths: WavelengthSampling {
            strategy: named(&d.wavelengths, WavelengthStrategy::from_name),
            pdf: named(&d.wavelength_pdf, WavelengthPdf::from_name),
            fixed: None,
        },
        filter,
        sampler: named(&d.sampler, SamplerKind::from_name),
        light_selection: named(&d.light_sampler, LightSelection::from_name),
        film_transparent: d.film_transparent.unwrap_or(false),
        max_pass_samples: SESSION_PASS_SAMPLES,
        // render.splits: 0 is "auto".
        splits: d.splits.filter(|&k| k > 0),
        caustic_guiding: d.caustic_guiding.unwrap_or(true),
        ..RenderSettings::default()
    }
}

/// The option a render-defaults name stands for (the sidecar loader has validated it), else
/// the default.
fn named<T: Default>(name: &Option<String>, parse: fn(&str) -> Option<T>) -> T {
    name.as_deref().and_then(parse).unwrap_or_default()
}

/// The divisors of the quick 1-spp previews that come before the full-size render: the first
/// brings the largest side to at most `start_resolution`, each next one halves it, down to 2.
fn preview_divisors(width: u32, height: u32, start_resolution: u32) -> Vec<u32> {
    let largest = width.max(height);
    let mut d = 1u32;
    while start_resolution > 0 && largest / d > start_resolution && d < 1 << 12 {
        d *= 2;
    }
    let mut out = Vec::new();
    while d >= 2 {
        out.push(d);
        d /= 2;
    }
    out
}

/// Renders one generation: the coarse previews, then the progressive full-size passes, each
/// sent as a frame (denoised from `sampling.denoise_from` samples on when a denoiser and its
/// thread count are given).
fn run_job(
    scene: &Scene,
    settings: RenderSettings,
    sampling: Sampling,
    denoiser: Option<(&Oidn, usize)>,
    generation: u64,
    cancel: &AtomicBool,
    out: &Output,
) {
    let start = Instant::now();
    let frame = |film: &crate::film::Film, spp: u32| {
        let (w, h) = (film.width as usize, film.height as usize);
        let mut rgba = film.to_rgba();
        if let (Some((oidn, threads)), Some(from)) = (denoiser, sampling.denoise_from) {
            if spp >= from {
                // Cycles' viewport denoising settings: quick filters, so frames keep coming.
                let options = DenoiseOptions {
                    threads,
                    ..DenoiseOptions::default()
                }
                .for_previews();
                let (albedo, normal) = (film.albedo_guide(), film.normal_guide());
                let denoised = oidn.denoise(
                    w,
                    h,
                    &film.color(),
                    Some(&albedo),
                    Some(&normal),
                    &options,
                    cancel,
                );
                match denoised {
                    Ok(rgb) => {
                        for (px, c) in rgba.iter_mut().zip(rgb) {
                            px[..3].copy_from_slice(&c.to_array());
                        }
                    }
                    // Cancelled by the next edit, or the library failed: the noisy frame.
                    Err(_) if cancel.load(Ordering::Relaxed) => return,
                    Err(_) => {}
                }
            }
        }
        let mut bytes = Vec::with_capacity(w * h * 16);
        // Bottom row first, as a texture is laid out.
        for row in rgba.chunks(w.max(1)).rev() {
            for px in row {
                for c in px {
                    // The film discards non-finite samples; this keeps a broken pixel from
                    // reaching the client all the same.
                    let c = if c.is_finite() { *c } else { 0.0 };
                    bytes.extend_from_slice(&c.to_le_bytes());
                }
            }
        }
        emit(
            out,
            &serde_json::json!({"event": "frame", "generation": generation, "width": w,
                "height": h, "spp": spp, "bytes": bytes.len()}),
            Some(&bytes),
        );
    };
    for d in preview_divisors(settings.width, settings.height, sampling.start_resolution) {
        let preview = RenderSettings {
            width: (settings.width / d).max(1),
            height: (settings.height / d).max(1),
            spp: 1,
            ..settings.clone()
        };
        let (film, stats) = render(scene, &preview, cancel, &|_| {}, &mut |_, _| {});
        if stats.cancelled {
            return;
        }
        frame(&film, 0);
    }
    let (_, stats) = render(scene, &settings, cancel, &|_| {}, &mut |film, spp| {
        frame(film, spp)
    });
    if !stats.cancelled {
        emit(
            out,
            &serde_json::json!({"event": "done", "generation": generation,
                "spp": stats.samples / (settings.width as u64 * settings.height as u64).max(1),
                "seconds": start.elapsed().as_secs_f64()}),
            None,
        );
    }
}

#[cfg(test)]
mod tests {
    use super::preview_divisors;

    #[test]
    fn previews_start_small_and_double() {
        assert_eq!(preview_divisors(1024, 512, 64), vec![16, 8, 4, 2]);
        assert_eq!(preview_divisors(100, 50, 64), vec![2]);
        assert_eq!(preview_divisors(64, 64, 64), Vec::<u32>::new());
        assert_eq!(preview_divisors(1024, 512, 0), Vec::<u32>::new());
    }
}
