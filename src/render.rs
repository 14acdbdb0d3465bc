//! Schedules the path tracer over the image: progressive passes over the whole frame (so a
//! cancelled render is uniformly converged), each pass split into bands of rows rendered in
//! parallel with rayon. Random numbers depend only on (pixel, sample, seed), and each pixel
//! accumulates its samples in order, so the image is bit-identical for any thread count.

use crate::film::{self, Film, PixelFilter, SampleClamp};
use crate::geometry::Ray;
use crate::integrator::caustics::{CausticPhotons, MAX_GLINT_BLUR, MAX_UNPLANNED_GLINT_BLUR};
use crate::integrator::splitting::{Branches, SplitPlanner, SplitStats};
use crate::integrator::{
    CameraRay, PathSample, PathTracer, WavelengthSampling, WavelengthStrategy,
};
use crate::lights::LightSelection;
use crate::sampler::{ImageSampler, PixelSampler, SamplerKind};
use crate::scene::Scene;
use crate::spectrum::cie::d65_normalized;
use crate::spectrum::{spectrum_to_xyz, SampledSpectrum, SampledWavelengths};
use glam::Vec2;
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

#[derive(Clone, Debug)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub max_depth: u32,
    pub seed: u64,
    /// Wavelength strategy, density and optional fixed wavelength.
    pub wavelengths: WavelengthSampling,
    /// Accumulate the denoising guides (albedo, normal, depth): for the denoiser, and for the
    /// film to write when `Film::write_guides` is set.
    pub guides: bool,
    /// Pixel reconstruction filter (default: Blackman–Harris 1.5 px, as Cycles).
    pub filter: PixelFilter,
    /// Where the path's random numbers come from (default: Owen-scrambled Sobol).
    pub sampler: SamplerKind,
    /// How next-event estimation chooses a light (default: the light tree).
    pub light_selection: LightSelection,
    /// Adaptive sampling (`None`: every pixel gets `spp` samples).
    pub adaptive: Option<AdaptiveSampling>,
    /// Stop after the pass during which this much rendering time has passed (Cycles' Time
    /// Limit); the image then has fewer samples than `spp`.
    pub time_limit: Option<Duration>,
    /// Firefly clamps (Cycles' Clamp Direct / Indirect); off by default.
    pub clamp: SampleClamp,
    /// Blender's Film > Transparent: the world is not seen by camera rays and the alpha
    /// channel is coverage.
    pub film_transparent: bool,
    /// Render only this window of the `width` x `height` image (Blender's render border): the
    /// film is the window's size, and each of its pixels gets exactly the samples (and value)
    /// it gets in the full render.
    pub crop: Option<Crop>,
    /// The most samples a progressive pass takes (passes double up to it; 64 by default). A
    /// smaller cap shows results more often (the interactive viewport), at a little overhead.
    pub max_pass_samples: u32,
    /// Subsurface scattering keeps its spatial spread after diffuse bounces too (for
    /// comparisons; `PathTracer::with_full_indirect_subsurface`). Off by default, as in Cycles.
    pub full_indirect_subsurface: bool,
    /// Branches per camera path at its first vertex (`integrator::splitting`): None plans them
    /// per block of pixels from the first samples, Some(k) takes k everywhere (1: plain path
    /// tracing).
    pub splits: Option<u32>,
    /// Guide continuations at diffuse and rough surfaces towards the caustics that photons
    /// traced from the lights through sharp metals and glass find (`integrator::caustics`).
    pub caustic_guiding: bool,
}

/// A window of the image: top-left pixel and size.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Crop {
    pub x: u32,
    pub y: u32,
    pub width: u32,
    pub height: u32,
}

impl RenderSettings {
    /// The window rendered: the crop, or the whole image.
    pub fn window(&self) -> Crop {
        self.crop.unwrap_or(Crop {
            x: 0,
            y: 0,
            width: self.width,
            height: self.height,
        })
    }
}

/// Adaptive sampling settings (`film::adaptive`): `spp` becomes the maximum.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AdaptiveSampling {
    /// Noise threshold (Cycles' convention, e.g. 0.01); > 0.
    pub threshold: f32,
    /// Samples every pixel gets before convergence is tested; 0 = automatic
    /// (`AdaptiveSampling::min_samples_for`).
    pub min_samples: u32,
}

impl AdaptiveSampling {
    /// The minimum spp actually used for a render of at most `spp`: the given one, or
    /// automatically max(16, sqrt(spp)) rounded up to a power of two (so the first test sees a
    /// stratified prefix), never more than `spp`.
    pub fn min_samples_for(&self, spp: u32) -> u32 {
        let auto = ((spp as f32).sqrt().ceil() as u32)
            .max(16)
            .next_power_of_two();
        let m = if self.min_samples > 0 {
            self.min_samples
        } else {
            auto
        };
        m.clamp(1, spp.max(1))
    }
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            width: 512,
            height: 512,
            spp: 64,
            max_depth: 16,
            seed: 0,
            wavelengths: WavelengthSampling::default(),
            guides: false,
            filter: PixelFilter::default(),
            sampler: SamplerKind::default(),
            light_selection: LightSelection::default(),
            adaptive: None,
            time_limit: None,
            clamp: SampleClamp::default(),
            film_transparent: false,
            crop: None,
            max_pass_samples: 64,
            full_indirect_subsurface: false,
            splits: None,
            caustic_guiding: true,
        }
    }
}

/// A progress report, sent from a reporter thread a few times per second and at pass ends.
#[derive(Clone, Copy, Debug)]
pub struct Progress {
    pub fraction: f64,
    /// Pixel samples finished so far (over the whole image).
    pub samples_done: u64,
    pub elapsed: Duration,
    /// Set when a whole pass has finished: every active pixel has `pass_spp` samples.
    pub pass_spp: Option<u32>,
    /// With adaptive sampling: the fraction of pixels still sampling.
    pub active_fraction: Option<f64>,
}

#[derive(Clone, Debug, Default)]
pub struct RenderStats {
    pub seconds: f64,
    pub rays: u64,
    pub samples: u64,
    /// Samples whose estimate was NaN/Inf and was discarded by the film.
    pub discarded: u64,
    pub cancelled: bool,
    /// Photons that guide bounces towards caustics (`integrator::caustics`; 0: none).
    pub caustic_photons: u64,
    /// Whether the photons guided the render's samples after the splitting pilot (which
    /// turns guiding off where it does not pay, `SplitPlanner::plan`).
    pub caustic_guided: bool,
}

/// Rows per parallel work item: small enough to balance load over 2-64 threads, large enough
/// to amortise scheduling.
const BAND_ROWS: usize = 4;
/// Pixels per parallel work item in a prioritised adaptive pass, whose samples gather in a few
/// regions of the image (a caustic): with whole bands one thread worked alone at the end of
/// each pass.
const PRIORITISED_CHUNK: usize = 16;

/// Samples of the uniform pass after `done` of `spp`: 1, 1, 2, 4, ... doubling up to `cap`
/// (64 by default) per pass (so passes end at stratified prefixes of every pixel's sequence).
/// With adaptive sampling the uniform passes land exactly on `warm_up`, after which passes are
/// planned pixel by pixel (`film::adaptive::plan_pass`).
fn next_pass(done: u32, spp: u32, warm_up: Option<u32>, cap: u32) -> u32 {
    let cap = cap.max(1);
    let doubling = if done <= 1 { 1 } else { done.min(cap) };
    let n = match warm_up {
        Some(w) if done < w => doubling.min(w - done),
        _ => doubling,
    };
    n.min(spp - done)
}

/// Sample counts of successive passes of a fixed-spp render.
#[cfg(test)]
fn pass_sizes(spp: u32) -> Vec<u32> {
    let mut sizes = Vec::new();
    let mut done = 0;
    while done < spp {
        let n = next_pass(done, spp, None, 64);
        sizes.push(n);
        done += n;
    }
    sizes
}

/// Renders `scene` into a new film. `cancel` is polled between pixels; `on_progress` is called
/// from a reporter thread (and once per finished pass with the film state available through
/// `on_pass`).
pub fn render(
    scene: &Scene,
    settings: &RenderSettings,
    cancel: &AtomicBool,
    on_progress: &(dyn Fn(&Progress) + Sync),
    on_pass: &mut dyn FnMut(&Film, u32),
) -> (Film, RenderStats) {
    let window = settings.window();
    let (w, h) = (window.width as usize, window.height as usize);
    // Guides are accumulated when asked for; writing them is the caller's choice
    // (`Film::write_guides`): they may be wanted only as the denoiser's input.
    let mut film = Film::new(window.width, window.height);
    let camera = scene.camera_for(settings.width, settings.height);
    let has_motion = scene.has_motion();
    let has_lens = camera.has_lens();
    let splitting = SplitPlanner::new(settings.spp, window, settings.splits);
    // Photons for caustic guiding, traced once before the first pass: for broader glints
    // only where the splitting pilot will tell whether guiding towards them pays.
    let photons_started = Instant::now();
    let max_blur = if splitting.pilot_end() > 0 {
        MAX_GLINT_BLUR
    } else {
        MAX_UNPLANNED_GLINT_BLUR
    };
    let photons = settings
        .caustic_guiding
        .then(|| CausticPhotons::trace(scene, settings.seed, max_blur))
        .flatten();
    let tracer = PathTracer::new(scene, settings.max_depth, settings.light_selection)
        .with_caustic_photons(photons.as_ref())
        .with_transparent_background(settings.film_transparent)
        .with_pixel_footprint(camera.pixel_footprint())
        .with_full_indirect_subsurface(settings.full_indirect_subsurface);
    // Alpha is coverage only with a transparent background or holdouts; else 1 everywhere.
    film.track_alpha = settings.film_transparent || scene.geometry.has_holdout();
    let track_alpha = film.track_alpha;
    let clamp_off = settings.clamp.is_off();
    // The film takes a uniform world seen directly exactly where the path's wavelengths are
    // the hero's four (`PathSample::world_exact`); single-wavelength paths estimate it.
    let exact_world = settings.wavelengths.strategy == WavelengthStrategy::Hero
        && settings.wavelengths.fixed.is_none();
    let image_sampler = ImageSampler::new(settings.sampler, settings.spp, settings.seed);
    // Branches per camera path at its first vertex, per pixel (`SplitPlanner`).
    let mut splits = vec![splitting.pilot_splits(); w * h];
    let mut split_stats = vec![SplitStats::default(); w * h];
    // A sample's cost per pixel relative to an unsplit one (adaptive passes weigh by it).
    let mut sample_costs = vec![1.0f32; w * h];
    let total = (w * h) as u64 * settings.spp as u64;
    let samples_done = AtomicU64::new(0);
    let rays = AtomicU64::new(0);
    let discarded = AtomicU64::new(0);
    // Samples that pixels which stopped early (adaptive sampling) will not take: counted as
    // done for the progress fraction.
    let skipped = AtomicU64::new(0);
    let adaptive_min = settings
        .adaptive
        .filter(|a| a.threshold > 0.0)
        .map(|a| a.min_samples_for(settings.spp));
    // Pixels still sampling.
    let mut active = vec![true; w * h];
    let mut active_count = w * h;
    let start = Instant::now();
    // Share of the render done: of its samples, or with a time limit of its time if more (an
    // adaptive render's maximum spp is rarely reached, so its samples alone would leave a
    // time-limited progress bar near 0 until the end).
    let time_limit = settings.time_limit;
    let fraction_done = move |samples: u64| {
        let by_samples = samples as f64 / total.max(1) as f64;
        let by_time = time_limit.map_or(0.0, |t| {
            (start.elapsed().as_secs_f64() / t.as_secs_f64().max(1e-9)).min(1.0)
        });
        by_samples.max(by_time)
    };
    // One camera sample of a pixel of the full image, up to its path's result.
    let camera_sample =
        |px_x: u32, px_y: u32, pixel_sampler: &PixelSampler, sample: u32, k: Branches| {
            let mut sampler = pixel_sampler.sample(sample);
            let u_filter = sampler.pixel_filter();
            let u_lens = if has_lens { sampler.lens() } else { Vec2::ZERO };
            let raster = Vec2::new(px_x as f32, px_y as f32) + settings.filter.sample_2d(u_filter);
            let time = if has_motion {
                sampler.shutter_time()
            } else {
                0.5
            };
            let Some(ray): Option<Ray> = camera.generate_ray_at(raster, u_lens, time) else {
                return CameraSample::Outside;
            };
            let first_hit = match tracer.camera_ray(&ray, exact_world) {
                CameraRay::Background { xyz, alpha } => {
                    return CameraSample::Background { xyz, alpha }
                }
                CameraRay::Path { first_hit } => first_hit,
            };
            // The wavelengths' own dimensions (`Sampler::wavelength`): the same values here as
            // before the camera ray (the independent sampler's one stream now gives the shutter
            // time its value first).
            let wavelengths = settings.wavelengths.sample(&mut sampler);
            let result = tracer.radiance_split(ray, first_hit, &wavelengths, &mut sampler, k);
            CameraSample::Path {
                ray,
                wavelengths,
                result,
            }
        };
    // A pilot sample's statistics for the splitting plan. The plan sees the samples before any
    // clamping, so that a clamped render takes the same samples as an unclamped one.
    let add_pilot =
        |stats: &mut SplitStats, result: &PathSample, wavelengths: &SampledWavelengths| {
            let (world, world_xyz) = result
                .world_exact
                .unwrap_or((SampledSpectrum::ZERO, glam::Vec3::ZERO));
            let y = spectrum_to_xyz(&(result.radiance - world), wavelengths).y + world_xyz.y;
            stats.add(result, y);
        };
    // A window of the image plans its splitting from the whole image's pilot samples, so that
    // its pixels take exactly the samples they take in the full render (`--crop`, Blender's
    // render border). Costs the pilot's samples over the whole image (4 of them, split in two).
    let window_plan = if splitting.pilot_end() > 0
        && (window.x, window.y, window.width, window.height)
            != (0, 0, settings.width, settings.height)
    {
        let (fw, fh) = (settings.width as usize, settings.height as usize);
        let full = Crop {
            x: 0,
            y: 0,
            width: settings.width,
            height: settings.height,
        };
        let stats: Vec<SplitStats> = (0..fw * fh)
            .into_par_iter()
            .map(|index| {
                let (px_x, px_y) = ((index % fw) as u32, (index / fw) as u32);
                let pixel_sampler = image_sampler.pixel(px_x, px_y, settings.width);
                let mut stats = SplitStats::default();
                if cancel.load(Ordering::Relaxed) {
                    return stats;
                }
                for sample in 0..splitting.pilot_end() {
                    let k = splitting.pilot_splits();
                    if let CameraSample::Path {
                        wavelengths,
                        result,
                        ..
                    } = camera_sample(px_x, px_y, &pixel_sampler, sample, k)
                    {
                        add_pilot(&mut stats, &result, &wavelengths);
                    }
                }
                stats
            })
            .collect();
        let mut full_splits = vec![Branches::ONE; fw * fh];
        let mut full_costs = vec![1f32; fw * fh];
        SplitPlanner::new(settings.spp, full, settings.splits).plan(
            &stats,
            &mut full_splits,
            &mut full_costs,
        );
        let mut plan = (vec![Branches::ONE; w * h], vec![1f32; w * h]);
        for y in 0..h {
            for x in 0..w {
                let i = (y + window.y as usize) * fw + x + window.x as usize;
                plan.0[y * w + x] = full_splits[i];
                plan.1[y * w + x] = full_costs[i];
            }
        }
        Some(plan)
    } else {
        None
    };

    // The reporter waits on this channel: it wakes every 20 ms to check the time, and at once
    // when the sender is dropped at the end of the render (so finishing never waits on a sleep).
    let (stop_reporter, reporter_wakeup) = std::sync::mpsc::channel::<()>();

    std::thread::scope(|s| {
        // Dropped when the scope's body ends, also if a worker panics (else the scope would
        // never join the reporter).
        let _stop_reporter = stop_reporter;
        // Reporter: decoupled from the workers so they never block on I/O.
        let samples_done = &samples_done;
        let skipped = &skipped;
        s.spawn(move || {
            let mut last_report = Instant::now();
            while let Err(std::sync::mpsc::RecvTimeoutError::Timeout) =
                reporter_wakeup.recv_timeout(Duration::from_millis(20))
            {
                if last_report.elapsed() < Duration::from_millis(250) {
                    continue;
                }
                last_report = Instant::now();
                let done = samples_done.load(Ordering::Relaxed);
                on_progress(&Progress {
                    fraction: fraction_done(done + skipped.load(Ordering::Relaxed)),
                    samples_done: done,
                    elapsed: start.elapsed(),
                    pass_spp: None,
                    active_fraction: None,
                });
            }
        });

        // A time limit ends the render inside a pass (between pixels): the pixels after that
        // point keep the samples of the passes before, each still a prefix of its sequence.
        let out_of_time = || settings.time_limit.is_some_and(|t| start.elapsed() >= t);
        // Samples every pixel has had (the uniform passes); with adaptive sampling, past
        // `warm_up` the passes are planned pixel by pixel (`film::adaptive::plan_pass`).
        let mut spp_done = 0u32;
        let warm_up = adaptive_min.map(|min| min.min(film::adaptive::PRIORITY_WARM_UP));
        let mut prioritised = false;
        // The sample count each pixel reaches in the current pass.
        let mut pass_end = vec![0u32; w * h];
        // The pixels' errors after the last pass (`film::adaptive::pixel_errors`).
        let mut errors = Vec::new();
        let mut splitting_planned = false;
        loop {
            if cancel.load(Ordering::Relaxed) || active_count == 0 {
                break;
            }
            if prioritised {
                let (Some(a), Some(min)) = (settings.adaptive, adaptive_min) else {
                    break;
                };
                let planned = film::adaptive::plan_pass_with_costs(
                    &film,
                    &errors,
                    &active,
                    splitting_planned.then_some(&sample_costs[..]),
                    film::adaptive::PassLimits {
                        threshold: a.threshold,
                        min_samples: min,
                        spp: settings.spp,
                        cap: settings.max_pass_samples,
                    },
                    &mut pass_end,
                );
                if planned == 0 {
                    break;
                }
            } else {
                if spp_done >= settings.spp {
                    break;
                }
                let pass = next_pass(spp_done, settings.spp, warm_up, settings.max_pass_samples);
                spp_done += pass;
                pass_end.fill(spp_done);
            }
            let chunk = if prioritised {
                PRIORITISED_CHUNK
            } else {
                w * BAND_ROWS
            };
            film.pixels
                .par_chunks_mut(chunk)
                .zip(active.par_chunks(chunk))
                .zip(pass_end.par_chunks(chunk))
                .zip(splits.par_chunks(chunk))
                .zip(split_stats.par_chunks_mut(chunk))
                .enumerate()
                // Every chunk its own job: rayon's default splitting can leave one thread a
                // long run of chunks that the idle thread cannot steal.
                .with_max_len(1)
                .for_each(
                    |(band, ((((pixels, band_active), band_end), band_splits), band_stats))| {
                        let mut band_rays = 0u64;
                        let mut band_discarded = 0u64;
                        // Counted per band, not per pixel: the early passes take one or two
                        // samples per pixel, and an atomic add per pixel on a counter both threads
                        // write cost about 1% of a render.
                        let mut band_samples = 0u64;
                        for (i, px) in pixels.iter_mut().enumerate() {
                            if cancel.load(Ordering::Relaxed) || out_of_time() {
                                break;
                            }
                            let (s0, s1) = (px.samples, band_end[i]);
                            if !band_active[i] || s1 <= s0 {
                                continue;
                            }
                            let index = band * chunk + i;
                            // Pixel coordinates in the full image (the same samples with a crop).
                            let (px_x, px_y) =
                                ((index % w) as u32 + window.x, (index / w) as u32 + window.y);
                            let pixel_sampler = image_sampler.pixel(px_x, px_y, settings.width);
                            for sample in s0..s1 {
                                let k = band_splits[i];
                                let (ray, wavelengths, result) =
                                    match camera_sample(px_x, px_y, &pixel_sampler, sample, k) {
                                        // Outside a fisheye's image circle: black and
                                        // transparent, as in Cycles; a background the film
                                        // takes exactly: its colour, for one camera ray.
                                        sampled @ (CameraSample::Outside
                                        | CameraSample::Background { .. }) => {
                                            let (xyz, alpha) = match sampled {
                                                CameraSample::Background { xyz, alpha } => {
                                                    band_rays += 1;
                                                    (xyz, alpha)
                                                }
                                                _ => (glam::Vec3::ZERO, 0.0),
                                            };
                                            let xyz = if clamp_off {
                                                xyz
                                            } else {
                                                settings.clamp.apply(xyz, glam::Vec3::ZERO)
                                            };
                                            if !px.add(xyz) {
                                                band_discarded += 1;
                                            }
                                            if track_alpha {
                                                px.add_alpha(alpha);
                                            }
                                            if settings.guides {
                                                px.add_guides(
                                                    glam::Vec3::ZERO,
                                                    glam::Vec3::ZERO,
                                                    None,
                                                );
                                            }
                                            continue;
                                        }
                                        CameraSample::Path {
                                            ray,
                                            wavelengths,
                                            result,
                                        } => (ray, wavelengths, result),
                                    };
                                band_rays += result.rays as u64;
                                // The world seen directly counts with its exact colour.
                                let (world, world_xyz) = result
                                    .world_exact
                                    .unwrap_or((SampledSpectrum::ZERO, glam::Vec3::ZERO));
                                let xyz = if clamp_off {
                                    spectrum_to_xyz(&(result.radiance - world), &wavelengths)
                                        + world_xyz
                                } else {
                                    let direct =
                                        spectrum_to_xyz(&(result.direct - world), &wavelengths)
                                            + world_xyz;
                                    let indirect = spectrum_to_xyz(
                                        &(result.radiance - result.direct),
                                        &wavelengths,
                                    );
                                    settings.clamp.apply(direct, indirect)
                                };
                                if !px.add(xyz) {
                                    band_discarded += 1;
                                }
                                if track_alpha {
                                    px.add_alpha(result.alpha);
                                }
                                if sample < splitting.pilot_end() {
                                    add_pilot(&mut band_stats[i], &result, &wavelengths);
                                }
                                if !settings.guides {
                                    continue;
                                }
                                let g = &result.guides;
                                // The albedo's colour under a white (normalised D65) light.
                                let lit = g.albedo
                                    * SampledSpectrum::from_fn(|i| {
                                        d65_normalized(wavelengths.lambda[i])
                                    });
                                let depth = g
                                    .first_distance
                                    .is_finite()
                                    .then(|| camera.depth(g.first_distance, ray.dir));
                                px.add_guides(spectrum_to_xyz(&lit, &wavelengths), g.normal, depth);
                            }
                            band_samples += (s1 - s0) as u64;
                        }
                        samples_done.fetch_add(band_samples, Ordering::Relaxed);
                        rays.fetch_add(band_rays, Ordering::Relaxed);
                        discarded.fetch_add(band_discarded, Ordering::Relaxed);
                    },
                );
            if cancel.load(Ordering::Relaxed) {
                break;
            }
            if !splitting_planned && (spp_done >= splitting.pilot_end() || prioritised) {
                match &window_plan {
                    Some((planned, costs)) => {
                        splits.copy_from_slice(planned);
                        sample_costs.copy_from_slice(costs);
                    }
                    None => splitting.plan(&split_stats, &mut splits, &mut sample_costs),
                }
                splitting_planned = true;
            }
            let mut active_fraction = None;
            let mut pass_spp = spp_done;
            if let (Some(min), Some(warm_up), Some(a)) = (adaptive_min, warm_up, settings.adaptive)
            {
                prioritised |= spp_done >= warm_up;
                if prioritised {
                    let mut now = vec![false; w * h];
                    errors = film::adaptive::pixel_errors(&film);
                    film::adaptive::update_active(&film, &errors, a.threshold, min, &mut now);
                    // A pixel that stopped stays stopped (its neighbours' later convergence
                    // tests must not restart it with a gap in its sequence).
                    let mut newly_stopped = 0u64;
                    for (i, (was, is)) in active.iter().zip(&now).enumerate() {
                        let samples = film.pixels[i].samples;
                        if *was && (!*is || samples >= settings.spp) {
                            newly_stopped += (settings.spp.saturating_sub(samples)) as u64;
                        }
                    }
                    for (i, (a, is)) in active.iter_mut().zip(&now).enumerate() {
                        *a = *a && *is && film.pixels[i].samples < settings.spp;
                    }
                    active_count = active.iter().filter(|&&a| a).count();
                    skipped.fetch_add(newly_stopped, Ordering::Relaxed);
                    active_fraction = Some(active_count as f64 / (w * h).max(1) as f64);
                    // The samples every pixel still sampling has (all of them at the end).
                    pass_spp = (0..w * h)
                        .filter(|&i| active[i])
                        .map(|i| film.pixels[i].samples)
                        .min()
                        .unwrap_or(settings.spp);
                }
            }
            let done = samples_done.load(Ordering::Relaxed);
            on_progress(&Progress {
                fraction: fraction_done(done + skipped.load(Ordering::Relaxed)),
                samples_done: done,
                elapsed: start.elapsed(),
                pass_spp: Some(pass_spp),
                active_fraction,
            });
            on_pass(&film, pass_spp);
            if out_of_time() {
                break;
            }
        }
    });

    let stats = RenderStats {
        // With the photons traced before the first pass.
        seconds: photons_started.elapsed().as_secs_f64(),
        rays: rays.load(Ordering::Relaxed),
        samples: samples_done.load(Ordering::Relaxed),
        discarded: discarded.load(Ordering::Relaxed),
        cancelled: cancel.load(Ordering::Relaxed),
        caustic_photons: photons.as_ref().map_or(0, |p| p.len() as u64),
        caustic_guided: photons.is_some() && splits.iter().any(|k| k.caustic_guiding),
    };
    (film, stats)
}

/// Where one camera sample went (`render`'s sample loop and the splitting pilot of a window).
enum CameraSample {
    /// Outside a fisheye's image circle.
    Outside,
    /// Escaped to a background the film takes exactly (`CameraRay::Background`).
    Background { xyz: glam::Vec3, alpha: f32 },
    Path {
        ray: Ray,
        wavelengths: SampledWavelengths,
        result: PathSample,
    },
}

/// Renders without progress reports or cancellation (library users, tests, benchmarks).
pub fn render_quiet(scene: &Scene, settings: &RenderSettings) -> (Film, RenderStats) {
    render(
        scene,
        settings,
        &AtomicBool::new(false),
        &|_| {},
        &mut |_, _| {},
    )
}

#[cfg(test)]
mod tests {
    use super::pass_sizes;

    #[test]
    fn passes_cover_spp_exactly() {
        for spp in [1, 2, 3, 7, 64, 100, 1000] {
            assert_eq!(pass_sizes(spp).iter().sum::<u32>(), spp);
        }
        assert_eq!(pass_sizes(8), vec![1, 1, 2, 4]);
    }
}
