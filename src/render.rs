//! Schedules the path tracer over the image: progressive passes over the whole frame (so a
//! cancelled render is uniformly converged), each pass split into bands of rows rendered in
//! parallel with rayon. Random numbers depend only on (pixel, sample, seed), and each pixel
//! accumulates its samples in order, so the image is bit-identical for any thread count.

use crate::film::{Film, PixelFilter};
use crate::geometry::Ray;
use crate::integrator::{PathTracer, WavelengthSampling};
use crate::lights::LightSelection;
use crate::sampler::{ImageSampler, SamplerKind};
use crate::scene::Scene;
use crate::spectrum::cie::d65_normalized;
use crate::spectrum::{spectrum_to_xyz, SampledSpectrum};
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
    /// Accumulate the denoising guides (albedo, normal, depth) and write them with the film.
    pub guides: bool,
    /// Pixel reconstruction filter (default: Blackman–Harris 1.5 px, as Cycles).
    pub filter: PixelFilter,
    /// Where the path's random numbers come from (default: Owen-scrambled Sobol).
    pub sampler: SamplerKind,
    /// How next-event estimation chooses a light (default: the light tree).
    pub light_selection: LightSelection,
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
    /// Set when a whole pass has finished: every pixel has `pass_spp` samples.
    pub pass_spp: Option<u32>,
}

#[derive(Clone, Debug, Default)]
pub struct RenderStats {
    pub seconds: f64,
    pub rays: u64,
    pub samples: u64,
    /// Samples whose estimate was NaN/Inf and was discarded by the film.
    pub discarded: u64,
    pub cancelled: bool,
}

/// Rows per parallel work item: small enough to balance load over 2-64 threads, large enough
/// to amortise scheduling.
const BAND_ROWS: usize = 4;

/// Sample counts of successive passes: 1, 1, 2, 4, ... doubling up to 64 per pass.
fn pass_sizes(spp: u32) -> Vec<u32> {
    let mut sizes = Vec::new();
    let (mut done, mut next) = (0u32, 1u32);
    while done < spp {
        let n = next.min(spp - done);
        sizes.push(n);
        done += n;
        if sizes.len() > 1 {
            next = (next * 2).min(64);
        }
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
    let (w, h) = (settings.width as usize, settings.height as usize);
    let mut film = Film::new(settings.width, settings.height);
    film.write_guides = settings.guides;
    let camera = scene.camera_for(settings.width, settings.height);
    let forward = camera.forward();
    let tracer = PathTracer::new(scene, settings.max_depth, settings.light_selection);
    let image_sampler = ImageSampler::new(settings.sampler, settings.spp, settings.seed);
    let total = (w * h) as u64 * settings.spp as u64;
    let samples_done = AtomicU64::new(0);
    let rays = AtomicU64::new(0);
    let discarded = AtomicU64::new(0);
    let start = Instant::now();
    // The reporter waits on this channel: it wakes every 20 ms to check the time, and at once
    // when the sender is dropped at the end of the render (so finishing never waits on a sleep).
    let (stop_reporter, reporter_wakeup) = std::sync::mpsc::channel::<()>();

    std::thread::scope(|s| {
        // Dropped when the scope's body ends, also if a worker panics (else the scope would
        // never join the reporter).
        let _stop_reporter = stop_reporter;
        // Reporter: decoupled from the workers so they never block on I/O.
        let samples_done = &samples_done;
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
                    fraction: done as f64 / total.max(1) as f64,
                    samples_done: done,
                    elapsed: start.elapsed(),
                    pass_spp: None,
                });
            }
        });

        let mut spp_done = 0u32;
        for pass in pass_sizes(settings.spp) {
            if cancel.load(Ordering::Relaxed) {
                break;
            }
            let (s0, s1) = (spp_done, spp_done + pass);
            film.pixels
                .par_chunks_mut(w * BAND_ROWS)
                .enumerate()
                .for_each(|(band, pixels)| {
                    let mut band_rays = 0u64;
                    let mut band_discarded = 0u64;
                    for (i, px) in pixels.iter_mut().enumerate() {
                        if cancel.load(Ordering::Relaxed) {
                            break;
                        }
                        let index = band * w * BAND_ROWS + i;
                        let (px_x, px_y) = ((index % w) as u32, (index / w) as u32);
                        let pixel_sampler = image_sampler.pixel(px_x, px_y, w as u32);
                        let (x, y) = (px_x as f32, px_y as f32);
                        for sample in s0..s1 {
                            let mut sampler = pixel_sampler.sample(sample);
                            let (u_filter, u_lens) = sampler.camera();
                            let wavelengths = settings.wavelengths.sample(&mut sampler);
                            let raster = Vec2::new(x, y) + settings.filter.sample_2d(u_filter);
                            let ray: Ray = camera.generate_ray(raster, u_lens);
                            let result = tracer.radiance(ray, &wavelengths, &mut sampler);
                            band_rays += result.rays as u64;
                            if !px.add(spectrum_to_xyz(&result.radiance, &wavelengths)) {
                                band_discarded += 1;
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
                                .then(|| g.first_distance * ray.dir.dot(forward));
                            px.add_guides(spectrum_to_xyz(&lit, &wavelengths), g.normal, depth);
                        }
                        samples_done.fetch_add((s1 - s0) as u64, Ordering::Relaxed);
                    }
                    rays.fetch_add(band_rays, Ordering::Relaxed);
                    discarded.fetch_add(band_discarded, Ordering::Relaxed);
                });
            spp_done = s1;
            if !cancel.load(Ordering::Relaxed) {
                on_progress(&Progress {
                    fraction: samples_done.load(Ordering::Relaxed) as f64 / total.max(1) as f64,
                    samples_done: samples_done.load(Ordering::Relaxed),
                    elapsed: start.elapsed(),
                    pass_spp: Some(spp_done),
                });
                on_pass(&film, spp_done);
            }
        }
    });

    let stats = RenderStats {
        seconds: start.elapsed().as_secs_f64(),
        rays: rays.load(Ordering::Relaxed),
        samples: samples_done.load(Ordering::Relaxed),
        discarded: discarded.load(Ordering::Relaxed),
        cancelled: cancel.load(Ordering::Relaxed),
    };
    (film, stats)
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
