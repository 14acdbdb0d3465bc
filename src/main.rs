//! `prism` command line: parse flags, load the scene, render, report progress, write the EXR,
//! map errors to exit codes (0 success, 2 bad input, 1 internal error).

use clap::{Parser, Subcommand, ValueEnum};
use prism::error::{PrismError, Result};
use prism::film::denoise::{DenoiseOptions, DenoisePrefilter, DenoiseQuality, Oidn, OidnLocation};
use prism::film::{ExrCompression, FilterKind, PixelFilter, SampleClamp};
use prism::integrator::{WavelengthPdf, WavelengthSampling, WavelengthStrategy};
use prism::lights::LightSelection;
use prism::render::{render, AdaptiveSampling, Progress, RenderSettings, RenderStats};
use prism::sampler::SamplerKind;
use prism::scene::{load_scene, Scene};
use prism::spectrum::{LAMBDA_MAX, LAMBDA_MIN};
use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

mod huge_pages;

#[global_allocator]
static ALLOCATOR: huge_pages::HugePageHintAllocator = huge_pages::HugePageHintAllocator;

static CANCEL: AtomicBool = AtomicBool::new(false);

#[derive(Parser)]
#[command(
    name = "prism",
    version,
    about = "Spectral path tracer: glTF + material JSON in, EXR out"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum ProgressMode {
    Bar,
    Json,
    None,
}

#[derive(clap::Args, Clone)]
struct SceneArgs {
    /// glTF 2.0 scene (.gltf or .glb)
    scene: PathBuf,
    /// Material JSON sidecar (default: <scene stem>.materials.json beside the scene, if present)
    #[arg(long)]
    materials: Option<PathBuf>,
    /// Samples per pixel (default: the JSON's render.spp, else 64)
    #[arg(long)]
    spp: Option<u32>,
    #[arg(long)]
    width: Option<u32>,
    #[arg(long)]
    height: Option<u32>,
    /// Maximum path depth: 1 = direct light only, as pbrt's maxdepth; Cycles' Max Bounces B is
    /// depth B + 1 (default: the JSON's render.max_depth, else 16)
    #[arg(long)]
    max_depth: Option<u32>,
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// Camera node or camera name (default: the scene's first camera)
    #[arg(long)]
    camera: Option<String>,
    /// Wavelength strategy: hero (4 per path, spectral MIS), single (1 per path, independent)
    /// or stratified (1 per path, stratified over a pixel's samples). Default: the JSON's
    /// render.wavelengths, else hero
    #[arg(long, value_enum)]
    wavelengths: Option<WavelengthsArg>,
    /// Density wavelengths are drawn from: rgb (least colour noise in the Rec.709 image),
    /// visible (a bell over the visible band, tuned for luminance) or uniform over 360-830 nm
    /// (default: the JSON's render.wavelength_pdf, else rgb)
    #[arg(long, value_enum)]
    wavelength_pdf: Option<WavelengthPdfArg>,
    /// Diagnostic: render every path at this one wavelength (nm, 360-830)
    #[arg(long)]
    lambda: Option<f32>,
    /// Cache mesh BVHs in this directory and reuse them when a mesh is unchanged (re-renders
    /// skip the build; entries are validated, the directory is kept under 1 GiB)
    #[arg(long)]
    bvh_cache: Option<PathBuf>,
    /// Pixel filter (default: the JSON's render.filter, else blackman-harris, as Cycles)
    #[arg(long, value_enum)]
    filter: Option<FilterArg>,
    /// Pixel filter width in pixels, Cycles' convention: box +-w/2, gaussian sigma w/4,
    /// blackman-harris +-w (default: the JSON's render.filter.width, else 1.5)
    #[arg(long)]
    filter_width: Option<f32>,
    /// Random numbers: sobol (Owen-scrambled Sobol, blue-noise pixel order) or independent
    /// (PCG, for comparisons). Default: the JSON's render.sampler, else sobol
    #[arg(long, value_enum)]
    sampler: Option<SamplerArg>,
    /// How next-event estimation chooses a light: tree (a light tree: by each light's estimated
    /// irradiance at the shading point, with the sun and the world sampled besides its
    /// choice), tree-single (one light per shading point) or power (by emitted power); the last
    /// two for comparisons. Default: the JSON's render.light_sampler, else tree
    #[arg(long, value_enum)]
    light_sampler: Option<LightSamplerArg>,
    /// Subsurface scattering keeps its full spatial spread after a diffuse bounce too (for
    /// comparisons). By default, as in Cycles, light entering a subsurface object after a
    /// diffuse bounce leaves where it entered, with the medium's total diffuse reflectance
    #[arg(long)]
    full_indirect_subsurface: bool,
    /// Branches per camera path at its first diffuse, glossy or subsurface vertex: auto
    /// (default; light samples and continuations planned apart per 8 x 8 pixels from the first
    /// 4 samples, 1-4 of each where it pays, none below 16 spp) or a number 1-4 of whole
    /// branches, each with its own light sample and continuation (1 = plain path tracing)
    #[arg(long, value_name = "auto|1-4", value_parser = parse_splits)]
    splits: Option<Splits>,
    /// Caustic guiding: photons traced from the lights through sharp metals and glass show
    /// diffuse and rough surfaces where their caustics come from (a near-mirror's glint solved
    /// exactly), and 15-35% of the bounces there are sampled towards them, where the first
    /// samples show that removes noise
    /// (default: the JSON's render.caustic_guiding, else on)
    #[arg(long, value_name = "on|off", value_parser = parse_on_off)]
    caustic_guiding: Option<bool>,
    /// Adaptive sampling: pixels whose estimated error (Cycles' definition) is below this stop
    /// early; --spp becomes the maximum. 0 = off (default: the JSON's render.noise_threshold,
    /// else 0)
    #[arg(long)]
    noise_threshold: Option<f32>,
    /// Samples every pixel takes before adaptive sampling tests it; 0 = automatic (default:
    /// the JSON's render.min_samples, else 0)
    #[arg(long)]
    min_samples: Option<u32>,
    /// Stop after the pass during which this many seconds of rendering have passed; 0 = no
    /// limit (default: the JSON's render.time_limit, else 0)
    #[arg(long)]
    time_limit: Option<f64>,
    /// Limit each sample's direct light (at most one bounce) to this luminance, as Cycles'
    /// Clamp Direct; 0 = off (default: the JSON's render.clamp_direct, else 0)
    #[arg(long)]
    clamp_direct: Option<f32>,
    /// Limit each sample's indirect light (two or more bounces) to this luminance, as Cycles'
    /// Clamp Indirect; 0 = off (default: the JSON's render.clamp_indirect, else 0)
    #[arg(long)]
    clamp_indirect: Option<f32>,
    /// Transparent background, as Blender's Film > Transparent: camera rays see no world and
    /// the alpha channel is coverage (default: the JSON's render.film_transparent, else off)
    #[arg(long)]
    film_transparent: bool,
    /// Render only the window X,Y,W,H of the image (pixels, X and Y from the top-left corner;
    /// Blender's render border): the output image is that window, each pixel as in the full
    /// render (default: the JSON's render.crop, else the whole image)
    #[arg(long, value_name = "X,Y,W,H", value_parser = parse_crop)]
    crop: Option<[u32; 4]>,
}

fn parse_on_off(s: &str) -> std::result::Result<bool, String> {
    match s {
        "on" => Ok(true),
        "off" => Ok(false),
        _ => Err(format!("'{s}' is not on or off")),
    }
}

/// `--splits`: None = auto.
#[derive(Clone, Copy, Debug)]
struct Splits(Option<u32>);

fn parse_splits(s: &str) -> std::result::Result<Splits, String> {
    if s == "auto" {
        return Ok(Splits(None));
    }
    match s.parse::<u32>() {
        Ok(k) if (1..=prism::integrator::splitting::MAX_SPLITS).contains(&k) => Ok(Splits(Some(k))),
        _ => Err(format!(
            "'{s}' is not auto or a number of branches from 1 to {}",
            prism::integrator::splitting::MAX_SPLITS
        )),
    }
}

fn parse_crop(s: &str) -> std::result::Result<[u32; 4], String> {
    let v: Vec<&str> = s.split(',').collect();
    let n: std::result::Result<Vec<u32>, _> = v.iter().map(|x| x.trim().parse::<u32>()).collect();
    match n {
        Ok(n) if n.len() == 4 => Ok([n[0], n[1], n[2], n[3]]),
        _ => Err(format!(
            "expected four non-negative integers X,Y,W,H, got '{s}'"
        )),
    }
}

#[derive(clap::Args, Clone)]
struct DenoiseArgs {
    /// Denoise the final image with Intel Open Image Denoise (RT filter, albedo and normal
    /// guides); the noisy image is kept in the EXR's Noisy.RGBA channels. Without a usable
    /// library: a warning and the noisy image (default: the JSON's render.denoise, else off)
    #[arg(long)]
    denoise: bool,
    /// Also denoise the progressive previews (--preview); they stay noisy (and fast) otherwise
    #[arg(long)]
    denoise_previews: bool,
    /// The Open Image Denoise library, or a folder holding it (e.g. Blender's lib folder);
    /// default: $PRISM_OIDN, else the system's library
    #[arg(long)]
    oidn: Option<PathBuf>,
    /// OIDN's quality, as Cycles' Denoise > Quality: high (default), balanced (about 2x
    /// faster) or fast (default: the JSON's render.denoise_quality, else high)
    #[arg(long, value_enum)]
    denoise_quality: Option<DenoiseQualityArg>,
    /// Guides, as Cycles' Denoise > Prefilter: accurate (denoise albedo and normal first, the
    /// default), fast (use them as they are, possibly noisy) or none (use them as clean)
    /// (default: the JSON's render.denoise_prefilter, else accurate)
    #[arg(long, value_enum)]
    denoise_prefilter: Option<DenoisePrefilterArg>,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum DenoiseQualityArg {
    High,
    Balanced,
    Fast,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum DenoisePrefilterArg {
    Accurate,
    Fast,
    None,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum LightSamplerArg {
    Tree,
    TreeSingle,
    Power,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum SamplerArg {
    Sobol,
    Independent,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum ExrCompressionArg {
    Rle,
    Zip,
    None,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum FilterArg {
    Box,
    Gaussian,
    BlackmanHarris,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum WavelengthsArg {
    Hero,
    Single,
    Stratified,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum WavelengthPdfArg {
    Rgb,
    Visible,
    Uniform,
}

#[derive(clap::Args)]
struct BenchArgs {
    #[arg(default_value = "scenes/cornell/cornell.gltf")]
    scene: PathBuf,
    #[arg(long, default_value_t = 256)]
    width: u32,
    #[arg(long, default_value_t = 256)]
    height: u32,
    #[arg(long, default_value_t = 64)]
    spp: u32,
    #[arg(long, default_value_t = 16)]
    max_depth: u32,
    /// Thread counts to measure, e.g. 1,2
    #[arg(long, value_delimiter = ',', default_value = "1,2")]
    threads: Vec<usize>,
    /// Repetitions per thread count (the median is reported)
    #[arg(long, default_value_t = 3)]
    repeat: usize,
    /// Wavelength strategy (default: the scene JSON's, else hero)
    #[arg(long, value_enum)]
    wavelengths: Option<WavelengthsArg>,
}

#[derive(clap::Args)]
struct RenderArgs {
    #[command(flatten)]
    scene: SceneArgs,
    /// Output EXR (default: <scene stem>.exr in the current directory); its folder is created if missing
    #[arg(short, long)]
    output: Option<PathBuf>,
    /// Worker threads (default: all cores)
    #[arg(long)]
    threads: Option<usize>,
    /// Progress on stderr: an interactive bar, JSON lines, or nothing (default: bar on a terminal)
    #[arg(long, value_enum)]
    progress: Option<ProgressMode>,
    /// Also write the image after every progressive pass to this EXR (for live previews)
    #[arg(long)]
    preview: Option<PathBuf>,
    /// Also write denoising guides and Blender passes as extra EXR channels: Albedo.RGB
    /// (first non-Dirac surface, under white light), Normal.XYZ (world space, glTF axes),
    /// Depth.Z (distance along the view axis, 1e10 for the background)
    #[arg(long)]
    guides: bool,
    /// Compression of the EXR output and previews (all lossless): rle (default), zip
    /// (smallest files) or none (fastest to write and read; the Blender add-on uses it)
    #[arg(long, value_enum, default_value = "rle")]
    exr_compression: ExrCompressionArg,
    #[command(flatten)]
    denoise: DenoiseArgs,
}

#[derive(Subcommand)]
enum Command {
    /// Render a scene to an OpenEXR file (float32 RGBA, linear Rec.709).
    Render(Box<RenderArgs>),
    /// Convert an EXR to an sRGB PNG for viewing (clamped, optional exposure in stops).
    ToPng {
        input: PathBuf,
        output: PathBuf,
        #[arg(long, default_value_t = 0.0)]
        exposure: f32,
    },
    /// Compare an EXR with a reference: channel means and relative MSE (optionally after
    /// averaging k x k blocks to remove residual noise).
    Compare {
        test: PathBuf,
        reference: PathBuf,
        #[arg(long, default_value_t = 1)]
        block: usize,
        /// Clamp pixel values to [0, CLAMP] in both images first (tames fireflies)
        #[arg(long)]
        clamp: Option<f32>,
    },
    /// Measure samples/s and rays/s per thread on a scene (default: the Cornell box).
    Bench(BenchArgs),
    /// Stay up for an interactive session (Blender's rendered viewport): JSON commands on
    /// stdin (load, view, transform, shading, settings, stop, quit), events and raw float
    /// frames on stdout; the protocol is documented in `src/serve.rs`
    Serve {
        /// Worker threads (default: all cores)
        #[arg(long)]
        threads: Option<usize>,
        /// Cache mesh BVHs here, so a re-load after a mesh edit rebuilds only that mesh
        #[arg(long)]
        bvh_cache: Option<PathBuf>,
    },
}

/// A portable x86-64 build (the add-on's zip) hands the whole run over to the AVX2 build beside
/// it when this CPU has every x86-64-v3 feature: renders are 10-15% faster (bench/README.md), as
/// Cycles picks its AVX2 kernels at run time. exec keeps the process (its id, its standard
/// streams, the add-on's signals). `PRISM_PORTABLE=1` stays on the portable build. Builds that
/// already use AVX2 (from source, `target-cpu=native`) have nothing to hand over.
#[cfg(all(unix, target_arch = "x86_64", not(target_feature = "avx2")))]
fn hand_over_to_avx2_build() {
    use std::os::unix::process::CommandExt;
    /// What `blender_addon/package.py` names the x86-64-v3 build it puts beside this one.
    const AVX2_BUILD_NAME: &str = "prism-x86-64-v3";
    if std::env::var_os("PRISM_PORTABLE").is_some() {
        return;
    }
    let v3 = is_x86_feature_detected!("avx")
        && is_x86_feature_detected!("avx2")
        && is_x86_feature_detected!("bmi1")
        && is_x86_feature_detected!("bmi2")
        && is_x86_feature_detected!("f16c")
        && is_x86_feature_detected!("fma")
        && is_x86_feature_detected!("lzcnt")
        && is_x86_feature_detected!("movbe")
        && is_x86_feature_detected!("xsave");
    let Some(fast) = std::env::current_exe()
        .ok()
        .map(|exe| exe.with_file_name(AVX2_BUILD_NAME))
        .filter(|p| v3 && p.is_file())
    else {
        return;
    };
    let err = std::process::Command::new(&fast)
        .args(std::env::args_os().skip(1))
        .exec();
    // Only reached when exec failed: the portable build renders the same image. The warning
    // goes out the way the run reports (a JSON event for the add-on, which shows it).
    let message = format!(
        "could not start {} ({err}); rendering with the portable build",
        fast.display()
    );
    let args: Vec<String> = std::env::args().collect();
    let json = args
        .windows(2)
        .any(|a| a[0] == "--progress" && a[1] == "json")
        || args.iter().any(|a| a == "--progress=json");
    if json {
        eprintln!(
            "{{\"event\":\"warning\",\"message\":{}}}",
            json_escape(&message)
        );
    } else {
        eprintln!("prism: warning: {message}");
    }
}

fn main() {
    #[cfg(all(unix, target_arch = "x86_64", not(target_feature = "avx2")))]
    hand_over_to_avx2_build();
    let cli = Cli::parse();
    let result = match cli.command {
        Command::Render(args) => run_render(&args),
        Command::Compare {
            test,
            reference,
            block,
            clamp,
        } => compare(&test, &reference, block, clamp),
        Command::ToPng {
            input,
            output,
            exposure,
        } => to_png(&input, &output, exposure),
        Command::Bench(args) => run_bench(&args),
        Command::Serve { threads, bvh_cache } => run_serve(threads, bvh_cache.as_deref()),
    };
    // BVH cache entries are written while the render runs; let them finish before exiting.
    prism::geometry::bvh_cache::wait_for_stores();
    if let Err(e) = result {
        // One line, whatever the message contained.
        let msg = e.to_string().replace('\n', " ");
        eprintln!("prism: error: {msg}");
        std::process::exit(e.exit_code());
    }
}

/// A loaded scene with its settings.
struct Loaded {
    scene: Scene,
    settings: RenderSettings,
    /// Seconds spent in [`Scene::build`] (BVHs, light tables), reported in the JSON start event
    /// so round-trip benchmarks can split the load.
    build_seconds: f64,
    /// The JSON's `render.denoise`.
    denoise: bool,
    /// The JSON's `render.denoise_quality` and `render.denoise_prefilter`.
    denoise_quality: DenoiseQuality,
    denoise_prefilter: DenoisePrefilter,
}

/// Loads and builds the scene and resolves its settings (flags over the JSON's render block).
fn load(args: &SceneArgs) -> Result<Loaded> {
    let desc = load_scene(
        &args.scene,
        args.materials.as_deref(),
        args.camera.as_deref(),
    )?;
    let defaults = desc.render.clone();
    if let Some(dir) = &args.bvh_cache {
        prism::geometry::bvh_cache::set_cache_dir(dir).map_err(|e| {
            PrismError::input(format!("--bvh-cache {}: cannot create: {e}", dir.display()))
        })?;
    }
    let build_start = Instant::now();
    let scene = Scene::build(desc)?;
    let build_seconds = build_start.elapsed().as_secs_f64();
    let strategy = match args.wavelengths {
        Some(WavelengthsArg::Hero) => WavelengthStrategy::Hero,
        Some(WavelengthsArg::Single) => WavelengthStrategy::Single,
        Some(WavelengthsArg::Stratified) => WavelengthStrategy::Stratified,
        // The sidecar loader has already validated the name.
        None => defaults
            .wavelengths
            .as_deref()
            .and_then(WavelengthStrategy::from_name)
            .unwrap_or_default(),
    };
    let pdf = match args.wavelength_pdf {
        Some(WavelengthPdfArg::Rgb) => WavelengthPdf::Rgb,
        Some(WavelengthPdfArg::Visible) => WavelengthPdf::Visible,
        Some(WavelengthPdfArg::Uniform) => WavelengthPdf::Uniform,
        None => defaults
            .wavelength_pdf
            .as_deref()
            .and_then(WavelengthPdf::from_name)
            .unwrap_or_default(),
    };
    if let Some(l) = args.lambda {
        if !(LAMBDA_MIN..=LAMBDA_MAX).contains(&l) {
            return Err(PrismError::input(format!(
                "--lambda {l} is outside the spectral range {LAMBDA_MIN}-{LAMBDA_MAX} nm"
            )));
        }
    }
    let (json_filter, json_width) = match &defaults.filter {
        Some((name, width)) => (FilterKind::from_name(name), Some(*width)),
        None => (None, None),
    };
    let filter_kind = match args.filter {
        Some(FilterArg::Box) => FilterKind::Box,
        Some(FilterArg::Gaussian) => FilterKind::Gaussian,
        Some(FilterArg::BlackmanHarris) => FilterKind::BlackmanHarris,
        None => json_filter.unwrap_or(FilterKind::BlackmanHarris),
    };
    let filter_width = args.filter_width.or(json_width).unwrap_or(1.5);
    let filter = PixelFilter::new(filter_kind, filter_width)
        .map_err(|e| PrismError::input(format!("--filter-width: {e}")))?;
    let settings = RenderSettings {
        width: args.width.or(defaults.width).unwrap_or(512),
        height: args.height.or(defaults.height).unwrap_or(512),
        spp: args.spp.or(defaults.spp).unwrap_or(64),
        max_depth: args.max_depth.or(defaults.max_depth).unwrap_or(16),
        seed: args.seed,
        wavelengths: WavelengthSampling {
            strategy,
            pdf,
            fixed: args.lambda,
        },
        guides: false,
        filter,
        sampler: match args.sampler {
            Some(SamplerArg::Sobol) => SamplerKind::Sobol,
            Some(SamplerArg::Independent) => SamplerKind::Independent,
            None => defaults
                .sampler
                .as_deref()
                .and_then(SamplerKind::from_name)
                .unwrap_or_default(),
        },
        light_selection: match args.light_sampler {
            Some(LightSamplerArg::Tree) => LightSelection::Tree,
            Some(LightSamplerArg::TreeSingle) => LightSelection::TreeSingle,
            Some(LightSamplerArg::Power) => LightSelection::Power,
            None => defaults
                .light_sampler
                .as_deref()
                .and_then(LightSelection::from_name)
                .unwrap_or_default(),
        },
        adaptive: None,
        time_limit: None,
        clamp: SampleClamp::default(),
        film_transparent: args.film_transparent || defaults.film_transparent.unwrap_or(false),
        crop: None,
        max_pass_samples: 64,
        full_indirect_subsurface: args.full_indirect_subsurface,
        splits: match args.splits {
            Some(s) => s.0,
            None => defaults.splits.filter(|&k| k > 0),
        },
        caustic_guiding: args
            .caustic_guiding
            .or(defaults.caustic_guiding)
            .unwrap_or(true),
    };
    let threshold = args
        .noise_threshold
        .or(defaults.noise_threshold)
        .unwrap_or(0.0);
    if !(threshold.is_finite() && threshold >= 0.0) {
        return Err(PrismError::input(format!(
            "--noise-threshold must be a number >= 0, got {threshold}"
        )));
    }
    let min_samples = args.min_samples.or(defaults.min_samples).unwrap_or(0);
    let mut settings = settings;
    if threshold > 0.0 {
        settings.adaptive = Some(AdaptiveSampling {
            threshold,
            min_samples,
        });
    }
    let time_limit = args.time_limit.or(defaults.time_limit).unwrap_or(0.0);
    if !(time_limit.is_finite() && time_limit >= 0.0) {
        return Err(PrismError::input(format!(
            "--time-limit must be a number of seconds >= 0, got {time_limit}"
        )));
    }
    if time_limit > 0.0 {
        settings.time_limit = Some(std::time::Duration::from_secs_f64(time_limit));
    }
    if settings.width == 0
        || settings.height == 0
        || settings.width > 32768
        || settings.height > 32768
    {
        return Err(PrismError::input(format!(
            "image size {}x{} is out of range (1 to 32768 per side)",
            settings.width, settings.height
        )));
    }
    if settings.spp == 0 {
        return Err(PrismError::input("--spp must be at least 1"));
    }
    if settings.max_depth > 1024 {
        return Err(PrismError::input("--max-depth must be at most 1024"));
    }
    if let Some([x, y, cw, ch]) = args.crop.or(defaults.crop) {
        let fits = cw > 0
            && ch > 0
            && x.checked_add(cw).is_some_and(|r| r <= settings.width)
            && y.checked_add(ch).is_some_and(|b| b <= settings.height);
        if !fits {
            return Err(PrismError::input(format!(
                "--crop {x},{y},{cw},{ch} is not a non-empty window inside the {}x{} image",
                settings.width, settings.height
            )));
        }
        settings.crop = Some(prism::render::Crop {
            x,
            y,
            width: cw,
            height: ch,
        });
    }
    settings.clamp = SampleClamp::new(
        args.clamp_direct.or(defaults.clamp_direct).unwrap_or(0.0),
        args.clamp_indirect
            .or(defaults.clamp_indirect)
            .unwrap_or(0.0),
    )
    .map_err(|e| PrismError::input(format!("--{}", e.replace('_', "-"))))?;
    Ok(Loaded {
        scene,
        settings,
        build_seconds,
        denoise: defaults.denoise.unwrap_or(false),
        // The sidecar loader has already validated the names.
        denoise_quality: defaults
            .denoise_quality
            .as_deref()
            .and_then(DenoiseQuality::from_name)
            .unwrap_or_default(),
        denoise_prefilter: defaults
            .denoise_prefilter
            .as_deref()
            .and_then(DenoisePrefilter::from_name)
            .unwrap_or_default(),
    })
}

fn thread_pool(threads: Option<usize>) -> Result<rayon::ThreadPool> {
    let mut builder = rayon::ThreadPoolBuilder::new();
    if let Some(t) = threads {
        if t == 0 {
            return Err(PrismError::input("--threads must be at least 1"));
        }
        builder = builder.num_threads(t);
    }
    builder
        .build()
        .map_err(|e| PrismError::internal(format!("cannot start worker threads: {e}")))
}

fn run_serve(threads: Option<usize>, bvh_cache: Option<&Path>) -> Result<()> {
    if let Some(dir) = bvh_cache {
        prism::geometry::bvh_cache::set_cache_dir(dir).map_err(|e| {
            PrismError::input(format!("--bvh-cache {}: cannot create: {e}", dir.display()))
        })?;
    }
    let pool = thread_pool(threads)?;
    let stdin = std::io::BufReader::new(std::io::stdin());
    prism::serve::serve(stdin, std::io::stdout(), pool)
}

fn json_escape(s: &str) -> String {
    serde_json::Value::String(s.to_string()).to_string()
}

fn run_render(render_args: &RenderArgs) -> Result<()> {
    let RenderArgs {
        scene: args,
        output,
        threads,
        progress,
        preview,
        guides,
        exr_compression,
        denoise: denoise_args,
    } = render_args;
    let (threads, progress, guides) = (*threads, *progress, *guides);
    let output = output.clone();
    let compression = match exr_compression {
        ExrCompressionArg::Rle => ExrCompression::Rle,
        ExrCompressionArg::Zip => ExrCompression::Zip,
        ExrCompressionArg::None => ExrCompression::None,
    };
    let mode = progress.unwrap_or(if std::io::stderr().is_terminal() {
        ProgressMode::Bar
    } else {
        ProgressMode::None
    });
    let output = output.unwrap_or_else(|| {
        let stem = args
            .scene
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or("prism".into());
        PathBuf::from(format!("{stem}.exr"))
    });
    // Before the render: a folder that cannot be made must not cost the render.
    for path in std::iter::once(&output).chain(preview.as_ref()) {
        create_parent_folder(path)?;
    }
    let load_start = Instant::now();
    let Loaded {
        scene,
        mut settings,
        build_seconds,
        denoise,
        denoise_quality,
        denoise_prefilter,
    } = load(args)?;
    let pool = thread_pool(threads)?;
    let warn = |w: &str| match mode {
        ProgressMode::Json => {
            eprintln!("{{\"event\":\"warning\",\"message\":{}}}", json_escape(w))
        }
        _ => eprintln!("prism: warning: {w}"),
    };
    for w in &scene.warnings {
        warn(w);
    }
    let oidn = if denoise_args.denoise || denoise {
        load_oidn(denoise_args.oidn.as_deref())?
            .map_err(|e| warn(&format!("{e}; the image is not denoised")))
            .ok()
    } else {
        None
    };
    // The denoiser reads the albedo and normal guides.
    settings.guides = guides || oidn.is_some();
    let denoise_previews = denoise_args.denoise_previews && oidn.is_some();
    let threads_used = pool.current_num_threads();
    let denoise_options = DenoiseOptions {
        quality: match denoise_args.denoise_quality {
            Some(DenoiseQualityArg::High) => DenoiseQuality::High,
            Some(DenoiseQualityArg::Balanced) => DenoiseQuality::Balanced,
            Some(DenoiseQualityArg::Fast) => DenoiseQuality::Fast,
            None => denoise_quality,
        },
        prefilter: match denoise_args.denoise_prefilter {
            Some(DenoisePrefilterArg::Accurate) => DenoisePrefilter::Accurate,
            Some(DenoisePrefilterArg::Fast) => DenoisePrefilter::Fast,
            Some(DenoisePrefilterArg::None) => DenoisePrefilter::None,
            None => denoise_prefilter,
        },
        threads: threads_used,
    };
    let (bvh_hits, bvh_misses) = prism::geometry::bvh_cache::counters();
    if mode == ProgressMode::Json {
        eprintln!(
            "{{\"event\":\"start\",\"width\":{},\"height\":{},\"spp\":{},\"threads\":{},\"load_s\":{:.4},\"build_s\":{:.4},\"bvh_cache_hits\":{},\"bvh_cache_misses\":{}}}",
            settings.window().width,
            settings.window().height,
            settings.spp,
            threads_used,
            load_start.elapsed().as_secs_f64(),
            build_seconds,
            bvh_hits,
            bvh_misses
        );
    }
    ctrlc::set_handler(|| CANCEL.store(true, Ordering::SeqCst))
        .map_err(|e| PrismError::internal(format!("cannot install the signal handler: {e}")))?;

    let window = settings.window();
    let total = window.width as u64 * window.height as u64 * settings.spp as u64;
    let bar = (mode == ProgressMode::Bar).then(|| {
        let b = indicatif::ProgressBar::new(total);
        b.set_style(
            indicatif::ProgressStyle::with_template(
                "{spinner} [{elapsed_precise}] {wide_bar} {percent}% (eta {eta})",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        b
    });
    let on_progress = |p: &Progress| match mode {
        ProgressMode::Json => {
            let mut err = std::io::stderr().lock();
            let _ = writeln!(
                err,
                "{{\"event\":\"progress\",\"fraction\":{:.6},\"samples_done\":{},\"elapsed_s\":{:.3}{}{}}}",
                p.fraction,
                p.samples_done,
                p.elapsed.as_secs_f64(),
                p.pass_spp.map(|s| format!(",\"pass_spp\":{s}")).unwrap_or_default(),
                p.active_fraction
                    .map(|a| format!(",\"active\":{a:.4}"))
                    .unwrap_or_default()
            );
        }
        ProgressMode::Bar => {
            if let Some(b) = &bar {
                b.set_position((p.fraction * total as f64) as u64);
            }
        }
        ProgressMode::None => {}
    };
    let mut preview_error = None;
    let mut on_pass = |film: &prism::film::Film, spp: u32| {
        if let Some(path) = &preview {
            if spp < settings.spp {
                let denoised = oidn
                    .as_ref()
                    .filter(|_| denoise_previews)
                    .and_then(|o| denoise_film(o, film, &denoise_options.for_previews()).ok());
                let write =
                    |tmp: &Path| film.write_exr_denoised(tmp, compression, denoised.as_deref());
                match write_atomically(path, write) {
                    Ok(()) if mode == ProgressMode::Json => {
                        eprintln!(
                            "{{\"event\":\"preview\",\"path\":{},\"spp\":{spp}}}",
                            json_escape(&path.to_string_lossy())
                        )
                    }
                    Ok(()) => {}
                    Err(e) => preview_error = Some(e),
                }
            }
        }
    };
    let (mut film, stats) =
        pool.install(|| render(&scene, &settings, &CANCEL, &on_progress, &mut on_pass));
    if let Some(b) = bar {
        b.finish_and_clear();
    }
    if let Some(e) = preview_error {
        return Err(e);
    }
    film.write_guides = guides;
    // A cancelled render is written at once, noisy: the user asked it to stop.
    let mut denoise_seconds = None;
    if let Some(oidn) = oidn.as_ref().filter(|_| !stats.cancelled) {
        let start = Instant::now();
        match denoise_film(oidn, &film, &denoise_options) {
            Ok(d) => film.denoised = Some(d),
            Err(e) => warn(&format!("{e}; the image is not denoised")),
        }
        denoise_seconds = Some(start.elapsed().as_secs_f64());
    }
    write_atomically(&output, |tmp| film.write_exr_with(tmp, compression))?;
    report_done(
        mode,
        &stats,
        &output,
        denoise_seconds,
        film.denoised.is_some(),
    );
    Ok(())
}

/// Loads Open Image Denoise from `explicit` (a file or folder), else `$PRISM_OIDN`, else the
/// system's library. A path that does not exist is bad input; a library that cannot be loaded
/// is the inner error (for a warning: the render goes on, noisy).
fn load_oidn(explicit: Option<&Path>) -> Result<std::result::Result<Oidn, String>> {
    let from_env = std::env::var_os("PRISM_OIDN")
        .filter(|v| !v.is_empty())
        .map(PathBuf::from);
    let (location, source) = match (explicit, from_env) {
        (Some(p), _) => (OidnLocation::Path(p.to_path_buf()), "--oidn"),
        (None, Some(p)) => (OidnLocation::Path(p), "PRISM_OIDN"),
        (None, None) => (OidnLocation::System, ""),
    };
    if let OidnLocation::Path(p) = &location {
        if !p.exists() {
            return Err(PrismError::input(format!(
                "{source} {}: no such file or folder",
                p.display()
            )));
        }
    }
    Ok(Oidn::load(&location))
}

/// The film's colour denoised with its albedo and normal guides.
fn denoise_film(
    oidn: &Oidn,
    film: &prism::film::Film,
    options: &DenoiseOptions,
) -> std::result::Result<Vec<glam::Vec3>, String> {
    oidn.denoise(
        film.width as usize,
        film.height as usize,
        &film.color(),
        Some(&film.albedo_guide()),
        Some(&film.normal_guide()),
        options,
        &CANCEL,
    )
}

/// Creates the folder an output file goes into, as Blender does for its render output path
/// (`prism render scene.gltf -o renders/scene.exr` in a fresh folder).
fn create_parent_folder(path: &Path) -> Result<()> {
    match path.parent() {
        Some(folder) if !folder.as_os_str().is_empty() && !folder.is_dir() => {
            std::fs::create_dir_all(folder).map_err(|e| {
                PrismError::input(format!(
                    "{}: cannot create the folder for this output: {e}",
                    folder.display()
                ))
            })
        }
        _ => Ok(()),
    }
}

/// Writes to a temporary sibling and renames, so readers never see a half-written EXR.
fn write_atomically(path: &Path, write: impl FnOnce(&Path) -> Result<()>) -> Result<()> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = path.with_file_name(format!(".{name}.partial.exr"));
    write(&tmp)?;
    std::fs::rename(&tmp, path)
        .map_err(|e| PrismError::internal(format!("{}: cannot write: {e}", path.display())))
}

fn report_done(
    mode: ProgressMode,
    stats: &RenderStats,
    output: &Path,
    denoise_seconds: Option<f64>,
    denoised: bool,
) {
    match mode {
        ProgressMode::Json => eprintln!(
            "{{\"event\":\"done\",\"seconds\":{:.4},\"rays\":{},\"samples\":{},\"discarded\":{},\"cancelled\":{},\"caustic_photons\":{},\"caustic_guided\":{},\"denoised\":{denoised}{},\"output\":{}}}",
            stats.seconds,
            stats.rays,
            stats.samples,
            stats.discarded,
            stats.cancelled,
            stats.caustic_photons,
            stats.caustic_guided,
            denoise_seconds
                .map(|s| format!(",\"denoise_s\":{s:.4}"))
                .unwrap_or_default(),
            json_escape(&output.to_string_lossy())
        ),
        _ => eprintln!(
            "prism: {} {:.2} s: {} samples, {:.2} Mrays/s, {} non-finite samples discarded -> {}",
            if stats.cancelled {
                "interrupted after"
            } else {
                "rendered in"
            },
            stats.seconds,
            stats.samples,
            stats.rays as f64 / stats.seconds.max(1e-9) / 1e6,
            stats.discarded,
            output.display()
        ),
    }
    if mode != ProgressMode::Json {
        if let (Some(s), true) = (denoise_seconds, denoised) {
            eprintln!("prism: denoised in {s:.2} s");
        }
    }
}

fn run_bench(bench: &BenchArgs) -> Result<()> {
    let (scene_path, width, height, spp) = (&bench.scene, bench.width, bench.height, bench.spp);
    let (threads, repeat) = (&bench.threads, bench.repeat);
    let args = SceneArgs {
        scene: bench.scene.clone(),
        materials: None,
        spp: Some(bench.spp),
        width: Some(bench.width),
        height: Some(bench.height),
        max_depth: Some(bench.max_depth),
        seed: 0,
        camera: None,
        wavelengths: bench.wavelengths,
        wavelength_pdf: None,
        lambda: None,
        filter: None,
        filter_width: None,
        bvh_cache: None,
        sampler: None,
        light_sampler: None,
        full_indirect_subsurface: false,
        splits: None,
        caustic_guiding: None,
        noise_threshold: None,
        min_samples: None,
        time_limit: None,
        clamp_direct: None,
        clamp_indirect: None,
        film_transparent: false,
        crop: None,
    };
    let Loaded {
        scene, settings, ..
    } = load(&args)?;
    for &t in threads {
        let pool = thread_pool(Some(t))?;
        let mut runs: Vec<RenderStats> = (0..repeat.max(1))
            .map(|_| pool.install(|| render(&scene, &settings, &CANCEL, &|_| {}, &mut |_, _| {}).1))
            .collect();
        runs.sort_by(|a, b| a.seconds.total_cmp(&b.seconds));
        let median = &runs[runs.len() / 2];
        let samples_per_s = median.samples as f64 / median.seconds;
        let rays_per_s = median.rays as f64 / median.seconds;
        println!(
            "{{\"engine\":\"prism\",\"scene\":{},\"width\":{width},\"height\":{height},\"spp\":{spp},\"threads\":{t},\"seconds_median\":{:.4},\"samples_per_second\":{:.0},\"rays_per_second\":{:.0},\"rays_per_second_per_thread\":{:.0}}}",
            json_escape(&scene_path.to_string_lossy()),
            median.seconds,
            samples_per_s,
            rays_per_s,
            rays_per_s / t as f64
        );
    }
    Ok(())
}

fn to_png(input: &Path, output: &Path, exposure: f32) -> Result<()> {
    let (w, h, px) = prism::film::read_exr_rgba(input)?;
    let scale = 2f32.powf(exposure);
    let bytes: Vec<u8> = px
        .iter()
        .flat_map(|p| {
            (0..3).map(move |c| {
                let v = prism::spectrum::rgb::linear_to_srgb((p[c] * scale).clamp(0.0, 1.0));
                (v * 255.0 + 0.5) as u8
            })
        })
        .collect();
    image::save_buffer(output, &bytes, w, h, image::ColorType::Rgb8)
        .map_err(|e| PrismError::internal(format!("{}: cannot write PNG: {e}", output.display())))
}

fn compare(test: &Path, reference: &Path, block: usize, clamp: Option<f32>) -> Result<()> {
    use prism::film::metrics::{box_downsample, channel_means, clamp_pixels, rel_mse};
    let (w, h, mut a) = prism::film::read_exr_rgba(test)?;
    let (rw, rh, mut b) = prism::film::read_exr_rgba(reference)?;
    if let Some(m) = clamp {
        a = clamp_pixels(&a, m);
        b = clamp_pixels(&b, m);
    }
    if (w, h) != (rw, rh) {
        return Err(PrismError::input(format!(
            "image sizes differ: {w}x{h} vs {rw}x{rh}"
        )));
    }
    let k = block.max(1);
    let (_, _, da) = box_downsample(&a, w as usize, h as usize, k);
    let (_, _, db) = box_downsample(&b, w as usize, h as usize, k);
    let (ma, mb) = (channel_means(&a), channel_means(&b));
    let rel: Vec<String> = (0..3)
        .map(|c| format!("{:.4}", (ma[c] - mb[c]) / mb[c]))
        .collect();
    println!(
        "{{\"means\":[{:.6},{:.6},{:.6}],\"reference_means\":[{:.6},{:.6},{:.6}],\"relative_mean_difference\":[{}],\"block\":{k},\"rel_mse\":{:.6}}}",
        ma[0], ma[1], ma[2], mb[0], mb[1], mb[2], rel.join(","), rel_mse(&da, &db)
    );
    Ok(())
}
