//! Unidirectional path tracing with next-event estimation and multiple importance sampling
//! (Veach 1997, ch. 9; power heuristic), Russian roulette, spectral throughout, with
//! hero-wavelength MIS over the path's wavelengths (`spectral_mis`).

use super::caustics::{CausticGuide, CausticPhotons, MAX_GUIDED_DEPTH};
use super::spectral_mis::SpectralMis;
use super::splitting::Branches;
use crate::bsdf::{BsdfSample, LobeFlags};
use crate::bssrdf::{
    active_wavelengths, random_walk, ExitLobe, SubsurfaceAt, SubsurfaceMethod, WalkBoundary,
};
use crate::geometry::{bump_terminator_shadowing, offset_ray_origin, Hit, Ray};
use crate::lights::{LightSelection, ShadingContext};
use crate::math::{power_heuristic, Frame};
use crate::media::{
    transmittance, FieldPoint, MediumEntry, MediumStack, PhaseMixture, SegmentMedium,
    MAX_TRACKING_STEPS,
};
use crate::sampler::Sampler;
use crate::scene::camera::PixelFootprint;
use crate::scene::Scene;
use crate::spectrum::{spectrum_to_xyz, RgbAlbedoSpectrum, SampledSpectrum, SampledWavelengths};

/// Scattering events after which Russian roulette may end a path: the first four always
/// continue (Mitsuba 3's default `rr_depth` is 5), and refractions through glass do not count
/// (`PathState::roulette_vertices`). Roulette multiplies the variance of what a path would
/// still gather by 1 / p, and the paths it ends early are often the ones that carry the most
/// variance: light reaching a diffuse surface through a glass object takes two
/// refractions after the bounce that found it. Against roulette from the third vertex (64 spp,
/// 2 threads, 3 pairs, noise x time): rough glass 1.19x better (bulk 1.23x), everyday bulk
/// 1.09x, SSS Cornell box and many lights equal. From the seventh: rough glass another 5-7%,
/// the SSS box 6% worse; never: rough glass 1.39x, the SSS box 0.76x (62% more time). Not
/// counting refractions then gained rough glass 1.07-1.11x more (noise -11%, time +2-5%) and
/// left the other three scenes as they were.
const RR_MIN_DEPTH: u32 = 5;

/// `PathState::shared_rays` of a path that has not split.
const NOT_SPLIT: u32 = u32::MAX;

/// q / p for a continuation sampled from the guide's mixture density q, with p the density
/// it would have had without the guide, given the BSDF's and the guide's densities at its
/// direction (`PathSample::guide_gain`); 1 where the vertex had no guide.
fn unguided_ratio(guide: Option<&CausticGuide>, densities: Option<(f32, f32)>) -> f32 {
    let (Some(g), Some((bsdf_pdf, guide_pdf))) = (guide, densities) else {
        return 1.0;
    };
    if bsdf_pdf.is_infinite() {
        // A Dirac lobe's sample: only its discrete probability differs.
        return 1.0 - g.share;
    }
    if !(bsdf_pdf > 0.0) {
        // A direction only the guide samples (the BSDF's density vanishes where f does).
        return 0.0;
    }
    g.mixture_pdf(bsdf_pdf, guide_pdf) / bsdf_pdf
}

pub struct PathTracer<'a> {
    scene: &'a Scene,
    /// Maximum number of scattering events (bounces); emission seen after the last one counts.
    max_depth: u32,
    /// How next-event estimation chooses lights.
    selection: LightSelection,
    /// Some material is partly transparent (alpha): rays and shadow rays may pass surfaces.
    alpha: bool,
    /// Some material is a volume boundary without a surface: rays pass its surfaces.
    null_surfaces: bool,
    /// Some instance is a light standing as a mesh (`Instance::light_only`): rays pass it.
    light_meshes: bool,
    /// The volumes enclosing the camera (a camera inside a fog box).
    camera_media: MediumStack,
    /// Blender's Film > Transparent: camera rays that escape (directly or through transparent
    /// surfaces) see no world, and leave the pixel transparent.
    transparent_background: bool,
    /// A pixel's footprint along the path (Bump nodes' offsets, `with_pixel_footprint`).
    footprint: PixelFootprint,
    /// Subsurface scattering keeps its full spatial spread after a diffuse bounce too
    /// (`with_full_indirect_subsurface`); by default it is collapsed to its entry point there.
    full_indirect_subsurface: bool,
    /// Photons from the lights through surfaces that focus light, which guide continuations
    /// towards caustics (`caustics`, `with_caustic_photons`).
    caustics: Option<&'a CausticPhotons>,
}

/// Where a camera ray goes first (`PathTracer::camera_ray`).
#[derive(Clone, Copy, Debug)]
pub enum CameraRay {
    /// It escapes to a background the film takes exactly, so there is nothing to trace and no
    /// wavelengths to sample: `xyz` is its colour (all of it direct light), `alpha` its
    /// coverage. What a path would give: the same film value, bit for bit.
    Background { xyz: glam::Vec3, alpha: f32 },
    /// A path follows, from the ray's closest hit when it has been found (`Some(None)`: the ray
    /// escapes to lights at infinity whose spectra are sampled).
    Path { first_hit: Option<Option<Hit>> },
}

/// What one camera path returns.
pub struct PathSample {
    pub radiance: SampledSpectrum,
    /// The part of `radiance` that reached the camera after at most one scattering event
    /// (emission seen directly or through one bounce, and next-event estimation at the first
    /// vertex): Cycles' "direct" light, the part Clamp Direct limits (`film::SampleClamp`).
    pub direct: SampledSpectrum,
    /// Rays traced (closest-hit and shadow), for throughput statistics.
    pub rays: u32,
    /// The path split at its first vertex (`PathTracer::radiance_split`), after
    /// `shared_rays` of its `rays`; `light_rays` of the rest were its light samples' there.
    pub split: bool,
    pub shared_rays: u32,
    pub light_rays: u32,
    /// Split paths (`PathTracer::radiance_split`): the luminance (CIE Y) of what the first
    /// vertex's first light sample gathered minus the second's, and the same for its first two
    /// continuations, whose spreads estimate the variance each kind of branch removes.
    pub branch_differences: [f32; 2],
    /// The splitting pilot's: the sum over the first vertex's first two continuations of
    /// Y^2 (q / p - 1), with Y a continuation's luminance, q the density it was sampled from
    /// (the caustic guide's mixture) and p the BSDF's alone. Y^2 q / p has the expectation of
    /// the continuation's second moment without the guide (importance reweighting:
    /// E_q[(f / p)^2 p / q] = E_q[Y^2 q / p] with Y = f / q), so this estimates how much
    /// variance guiding removes there, without rendering unguided samples (`SplitPlanner::plan`).
    pub guide_gain: f32,
    pub guides: DenoiseGuides,
    /// Coverage: 0 where the camera ray escaped (only counted as transparent with
    /// `transparent_background`) or reached a holdout, else 1 (Blender's alpha).
    pub alpha: f32,
    /// Where the camera ray escaped straight to a uniform world: the world's share of
    /// `radiance` (and of `direct`) and the exact XYZ it estimates. The film counts the exact
    /// value instead, as an RGB renderer does: the background then has no colour noise from
    /// sampling wavelengths (the spectral estimate of a grey world varies per sample unless
    /// the wavelength density were proportional to all three matching functions at once).
    pub world_exact: Option<(SampledSpectrum, glam::Vec3)>,
}

/// The state of one camera path between bounces: what `PathTracer::trace` carries from one
/// vertex to the next.
#[derive(Clone, Copy, Debug)]
struct PathState<'a> {
    /// The ray leaving the last vertex (or the camera).
    ray: Ray,
    /// Radiance gathered so far, already divided by the spectral MIS denominator.
    l: SampledSpectrum,
    /// The direct share of `l` (`PathSample::direct`).
    l_direct: SampledSpectrum,
    /// Throughput.
    beta: SampledSpectrum,
    rays: u32,
    mis: SpectralMis,
    /// The wavelengths the path evaluates materials and lights at (see `radiance`).
    alive: SampledWavelengths,
    /// Aggregated density of the BSDF sample that produced `ray` and the MIS denominator
    /// before it (for MIS against light sampling when `ray` hits a light).
    prev_bsdf_density: f32,
    prev_denominator: f32,
    specular_bounce: bool,
    /// The lobe of the last scattering (`LobeFlags::VOLUME` in a volume), for lights that
    /// some kinds of scattering do not see (Blender's light Ray Visibility); None after the
    /// camera or a subsurface exit, which see every light.
    last_lobe: Option<LobeFlags>,
    /// Where the BSDF sample that produced `ray` was taken (light-selection probabilities
    /// for MIS depend on the shading point).
    prev_ctx: ShadingContext,
    /// The volumes the ray travels inside (also coloured glass), entered at the camera.
    media: MediumStack,
    /// Product of eta^2 over refractions: undoes radiance scaling for Russian roulette.
    eta_scale: f32,
    /// The random-walk subsurface medium the ray travels inside, if any (as at its entry
    /// point: a textured colour gives each entry its own coefficients).
    walk_medium: Option<SubsurfaceAt<'a>>,
    /// The outward geometric normal where the random walk entered (its guide).
    walk_entry_normal: Option<glam::Vec3>,
    guides: DenoiseGuides,
    guides_done: bool,
    /// Tint of the specular chain from the camera, for the albedo guide.
    guide_tint: SampledSpectrum,
    alpha: f32,
    /// Some earlier scattering was diffuse (a diffuse lobe or a subsurface exit): subsurface
    /// entered from here on is collapsed to its entry point (`with_full_indirect_subsurface`).
    diffuse_ancestor: bool,
    /// `PathSample::world_exact`.
    world_exact: Option<(SampledSpectrum, glam::Vec3)>,
    /// The closest hit of `ray`, when it has already been found (`PathTracer::camera_ray`):
    /// taken instead of the next intersection.
    first_hit: Option<Option<Hit>>,
    /// Scattering events so far that count towards Russian roulette's start
    /// (`RR_MIN_DEPTH`): every one but a transmission through a non-diffuse interface that
    /// neither enters nor leaves a subsurface medium (see `scatter`).
    roulette_vertices: u32,
    /// Vertices so far that did not reflect like a mirror or near-mirror (`Bsdf::is_sharp`;
    /// volume scattering counts). Caustic guiding counts these, not the depth: a floor seen
    /// in a near-mirror is as much in view as the floor seen directly, and a glint on it is
    /// as bright (most of everyday4's fireflies were that floor's unguided bounces into the
    /// chrome ball's glint).
    rough_vertices: u32,
    /// Branches at the first vertex (`PathTracer::radiance_split`) and what they report.
    splits: Branches,
    light_difference: SampledSpectrum,
    path_difference: SampledSpectrum,
    shared_rays: u32,
    light_rays: u32,
    /// Densities of the BSDF (infinite for a Dirac lobe) and the guide at the direction the
    /// first vertex's continuation took, where it was guided (`PathSample::guide_gain`).
    first_densities: Option<(f32, f32)>,
    /// The pilot's first two continuations: what each gathered, and q / p (`unguided_ratio`).
    continuations: [(SampledSpectrum, f32); 2],
}

/// A surface vertex of the path once its BSDF is known: what continuing the path from it
/// needs (`PathTracer::scatter`).
#[derive(Clone, Copy)]
struct Vertex<'a> {
    sp: crate::geometry::SurfacePoint,
    instance: u32,
    material: &'a crate::scene::material::Material,
    bsdf: crate::bsdf::Bsdf,
    subsurface: Option<SubsurfaceAt<'a>>,
    /// The boundary of the random-walk medium the path travels in (see `trace`).
    walk_exit: Option<SubsurfaceAt<'a>>,
    frame: Frame,
    /// Outgoing direction in `frame` and in the world.
    wo: glam::Vec3,
    wo_world: glam::Vec3,
    /// Shading and geometric normals, turned towards the viewer for reflective models.
    ns: glam::Vec3,
    ng: glam::Vec3,
    /// A bump or normal map moved the shading normal of a reflective surface.
    bumped: bool,
    ctx: ShadingContext,
}

impl Vertex<'_> {
    /// The diffuse part of a normal-mapped surface is masked near the smooth normal's horizon
    /// (Conty Estevez et al. 2019), as Cycles does for its diffuse closures: f loses
    /// (1 - G(wi)) of its diffuse part, for light and BSDF samples alike. This is that loss.
    fn bump_loss(&self, wi: glam::Vec3, wi_world: glam::Vec3) -> SampledSpectrum {
        let n_smooth = if self.ns.dot(self.sp.ns) < 0.0 {
            -self.sp.ns_smooth
        } else {
            self.sp.ns_smooth
        };
        let g = bump_terminator_shadowing(n_smooth, self.ns, wi_world);
        self.bsdf.diffuse_part(self.wo, wi) * (1.0 - g)
    }
}

/// Feature buffers for denoisers (and Blender's Depth/Normal passes), recorded like Cycles'
/// denoising data: at the first vertex that is not a perfect mirror or glass (Dirac BSDF),
/// following specular bounces from the camera, so a glass pane shows what is behind it.
#[derive(Clone, Copy, Debug)]
pub struct DenoiseGuides {
    /// Reflectance spectrum there (times the tint of the specular chain before it); 0 when
    /// the path escapes.
    pub albedo: SampledSpectrum,
    /// World-space shading normal there (facing the incoming ray); 0 when the path escapes.
    pub normal: glam::Vec3,
    /// Distance along the camera ray to the first surface (INFINITY when it escapes).
    pub first_distance: f32,
}

impl Default for DenoiseGuides {
    fn default() -> Self {
        DenoiseGuides {
            albedo: SampledSpectrum::ZERO,
            normal: glam::Vec3::ZERO,
            first_distance: f32::INFINITY,
        }
    }
}

/// Specular bounces followed before the guides give up (and record the last hit).
const GUIDE_MAX_SPECULAR: u32 = 8;

impl<'a> PathTracer<'a> {
    pub fn new(scene: &'a Scene, max_depth: u32, selection: LightSelection) -> Self {
        PathTracer {
            scene,
            max_depth,
            selection,
            alpha: scene.materials.iter().any(|m| m.has_alpha()),
            null_surfaces: scene.materials.iter().any(|m| m.is_null_surface()),
            light_meshes: scene.geometry.instances.iter().any(|i| i.light_only),
            camera_media: enclosing_media(scene, scene.camera.camera_to_world.w_axis.truncate()),
            transparent_background: false,
            // About a 100-pixel-high image at a 60-degree field of view, until the render
            // gives its camera's.
            footprint: PixelFootprint {
                per_distance: 1e-2,
                constant: 0.0,
            },
            full_indirect_subsurface: false,
            caustics: None,
        }
    }

    /// After a diffuse bounce, a path that enters a subsurface object leaves it where it
    /// entered (the BSSRDF collapsed to its entry point: the medium's total diffuse
    /// reflectance, `SubsurfaceAt::collapsed_albedo`, then its exit lobe), unless `full` keeps
    /// the probe or the walk there too. Cycles does the same (its closures drop subsurface for
    /// paths with a diffuse ancestor): light that already bounced off a diffuse surface is too
    /// blurred for the millimetres the exit point moves to show, while the probe's or walk's
    /// variance reaches everything lit by the object. Energy is the same in expectation on a
    /// flat surface: the probe's weight averages to rho_eff there, a walk's to its reflectance
    /// (up to diffusion's error for a dielectric boundary). Measured on the SSS Cornell box
    /// (64 spp, 2 threads, luminance noise between two renders): with the full BSSRDF after
    /// diffuse bounces the ceiling was 1.7x noisier than with these objects made plain
    /// diffuse, in Cycles 1.02x.
    pub fn with_full_indirect_subsurface(mut self, full: bool) -> Self {
        self.full_indirect_subsurface = full;
        self
    }

    /// Guides continuations at diffuse and rough surfaces towards the caustics `photons`
    /// found (`caustics`); None: BSDF sampling alone.
    pub fn with_caustic_photons(mut self, photons: Option<&'a CausticPhotons>) -> Self {
        self.caustics = photons;
        self
    }

    /// The camera's pixel footprint (`Camera::pixel_footprint`), which Bump nodes' filter
    /// widths are counted in.
    pub fn with_pixel_footprint(mut self, footprint: PixelFootprint) -> Self {
        self.footprint = footprint;
        self
    }

    /// The summed coefficients of the volumes on `media` at the path's wavelengths.
    #[inline]
    fn segment_medium(
        &self,
        media: &MediumStack,
        w: &SampledWavelengths,
    ) -> Option<SegmentMedium<'a>> {
        if media.is_empty() {
            return None;
        }
        let scene = self.scene;
        SegmentMedium::collect(
            media,
            |m| scene.materials.get(m as usize).and_then(|x| x.interior()),
            |i| {
                scene.geometry.instances[i as usize]
                    .placement
                    .world_to_object
            },
            w,
        )
    }

    /// `media` after crossing the surface of `instance` (drawn with `material`, outward
    /// geometric normal `ng`) in direction `dir`.
    fn media_across(
        &self,
        media: &MediumStack,
        instance: u32,
        material: u32,
        dir: glam::Vec3,
        ng: glam::Vec3,
    ) -> MediumStack {
        let mut out = *media;
        if self.scene.materials[material as usize].interior().is_some() {
            out.cross(MediumEntry { instance, material }, dir.dot(ng) < 0.0);
        }
        out
    }

    /// Russian roulette after a scattering event of the path in `st` (`counts`: the event
    /// counts towards `RR_MIN_DEPTH`, see `PathState::roulette_vertices`): continues with
    /// probability sqrt of the path's film-counted throughput (`SpectralMis::max_weight`), as
    /// Cycles does with its throughput: the square root terminates later than the throughput
    /// itself would. Measured at 64 spp, 2 threads (bulk noise x time against the throughput
    /// itself): -13% on the SSS Cornell box, -38% on spheres and a floor under a grey world.
    /// False: the path ends.
    #[inline]
    fn russian_roulette(
        &self,
        st: &mut PathState<'a>,
        counts: bool,
        sampler: &mut Sampler,
    ) -> bool {
        if counts {
            st.roulette_vertices += 1;
        }
        if st.roulette_vertices >= RR_MIN_DEPTH {
            let rr = (st.mis.max_weight(st.beta) * st.eta_scale).sqrt();
            if rr < 1.0 {
                let q = (1.0 - rr).clamp(0.0, 0.95);
                if sampler.russian_roulette() < q {
                    return false;
                }
                st.beta /= 1.0 - q;
            }
        }
        true
    }

    /// Film > Transparent (see `PathTracer::transparent_background`).
    pub fn with_transparent_background(mut self, on: bool) -> Self {
        self.transparent_background = on;
        self
    }

    /// The fraction of light that reaches `distance` along `ray`, per wavelength (0 =
    /// blocked), for a ray starting inside the volumes `media`: the product of the
    /// transparency (1 - alpha) of the surfaces in between, as Cycles' transparent shadows,
    /// and of the transmittance of the volumes it crosses (passing volume boundaries without a
    /// surface). Without alpha materials and such boundaries, a plain occlusion test.
    #[inline]
    fn transmittance(
        &self,
        ray: Ray,
        distance: f32,
        media: &MediumStack,
        w: &SampledWavelengths,
        sampler: &mut Sampler,
    ) -> SampledSpectrum {
        if !self.alpha && !self.null_surfaces {
            if self.scene.geometry.occluded(&ray, distance) {
                return SampledSpectrum::ZERO;
            }
            return match self.segment_medium(media, w) {
                Some(seg) => self.segment_transmittance(&seg, &ray, distance, w, sampler),
                None => SampledSpectrum::ONE,
            };
        }
        self.transmittance_through(ray, distance, media, w, sampler)
    }

    /// The transmittance of `seg` over [0, `d`] along `ray`: Beer-Lambert, or a ratio-tracking
    /// estimate through heterogeneous volumes.
    fn segment_transmittance(
        &self,
        seg: &SegmentMedium,
        ray: &Ray,
        d: f32,
        w: &SampledWavelengths,
        sampler: &mut Sampler,
    ) -> SampledSpectrum {
        if !seg.is_heterogeneous() {
            return seg.transmittance(d);
        }
        seg.ratio_tracking(
            ray.origin,
            ray.dir,
            d,
            || sampler.next_1d(),
            |e, t| self.field_at(e, ray.at(t), w),
        )
    }

    /// Delta tracking (Woodcock et al. 1965) through a segment with heterogeneous volumes, with
    /// the spectral MIS of pbrt-v4's volumetric path tracer: tentative collisions at the hero's
    /// majorant rate; at each, the volumes' emission is counted (sigma_e / sigma_maj per point
    /// integrates T sigma_e), then the hero chooses a real collision with probability
    /// sigma_t,0 / sigma_maj,0, else a null one; every wavelength multiplies its throughput by
    /// its own outcome's value over the hero's density and its MIS ratio by its own density.
    /// Returns where the flight ended (`segment_end` when it passed), the emission seen (MIS
    /// weighted, to add to the path's radiance) and, at a scattering collision, its phase
    /// function and albedo. An absorbed flight leaves `beta` at 0.
    #[allow(clippy::too_many_arguments)]
    fn delta_track(
        &self,
        seg: &SegmentMedium,
        ray: &Ray,
        segment_end: f32,
        beta: &mut SampledSpectrum,
        mis: &mut SpectralMis,
        w: &SampledWavelengths,
        sampler: &mut Sampler,
    ) -> (
        f32,
        SampledSpectrum,
        Option<(PhaseMixture, SampledSpectrum)>,
    ) {
        let mut emitted = SampledSpectrum::ZERO;
        let mut steps = 0;
        for (t0, t1, sigma_maj, cap) in seg.majorant_runs(ray.origin, ray.dir, segment_end) {
            let m0 = sigma_maj[0];
            let mut t = t0;
            loop {
                if !(m0 > 0.0) {
                    // The hero sees no extinction here: the flight passes the run; the other
                    // wavelengths carry their majorant transmittance (their densities' ratio).
                    let tm = transmittance(sigma_maj, t1 - t);
                    *beta *= tm;
                    mis.scatter(1.0, tm);
                    break;
                }
                let step = -(1.0 - sampler.next_1d()).ln() / m0;
                if t + step >= t1 {
                    let tm = transmittance(sigma_maj, t1 - t);
                    *beta *= tm / tm[0];
                    mis.scatter(tm[0], tm);
                    break;
                }
                t += step;
                steps += 1;
                if steps > MAX_TRACKING_STEPS {
                    *beta = SampledSpectrum::ZERO;
                    return (t, emitted, None);
                }
                let tm = transmittance(sigma_maj, step);
                let p = seg.at(|e| self.field_at(e, ray.at(t), w).capped(cap));
                if !seg.emission.is_black() {
                    let pdf = tm[0] * m0;
                    let mut m = *mis;
                    m.scatter(pdf, tm * sigma_maj);
                    emitted += *beta * tm * seg.emission / (pdf * m.denominator());
                }
                if sampler.next_1d() * m0 < p.sigma_t[0] {
                    let pdf = tm[0] * p.sigma_t[0];
                    *beta *= tm * p.sigma_s / pdf;
                    mis.scatter(pdf, tm * p.sigma_t);
                    let event = p.phase.map(|phase| (phase, p.sigma_s.safe_div(p.sigma_t)));
                    if event.is_none() {
                        *beta = SampledSpectrum::ZERO;
                    }
                    return (t, emitted, event);
                }
                let sigma_n = (sigma_maj - p.sigma_t).clamp_zero();
                let pdf = tm[0] * sigma_n[0];
                if !(pdf > 0.0) {
                    *beta = SampledSpectrum::ZERO;
                    return (t, emitted, None);
                }
                *beta *= tm * sigma_n / pdf;
                mis.scatter(pdf, tm * sigma_n);
            }
        }
        (segment_end, emitted, None)
    }

    /// Next-event estimation where light leaves a subsurface medium: at `p_exit` (outward
    /// geometric normal `ng`, shading frame `frame`) through the exit lobe, for a path of
    /// throughput `beta` there.
    #[allow(clippy::too_many_arguments)]
    fn exit_direct(
        &self,
        st: &mut PathState<'a>,
        depth: u32,
        beta: SampledSpectrum,
        p_exit: glam::Vec3,
        ng: glam::Vec3,
        frame: Frame,
        lobe: ExitLobe,
        u: (glam::Vec2, f32),
        sampler: &mut Sampler,
    ) {
        let ctx = ShadingContext {
            p: p_exit,
            n: Some(ng),
            time: st.ray.time,
        };
        let path_beta = std::mem::replace(&mut st.beta, beta);
        self.sample_direct(st, depth, &ctx, u, sampler, None, |wi| {
            let cos = frame.to_local(wi).z;
            let f = lobe.eval(cos);
            (f > 0.0 && wi.dot(ng) > 0.0)
                .then(|| (f * cos, lobe.pdf(cos), offset_ray_origin(p_exit, ng, wi)))
        });
        st.beta = path_beta;
    }

    /// Next-event estimation with a scattering function that is the same at every wavelength
    /// (a volume's phase function, a subsurface exit lobe): a light sampled from `ctx` with
    /// `u`, `scatter(wi)` giving (f times its cosine if any, the density with which the vertex
    /// samples wi, the shadow ray's origin) or `None` where it does not scatter, the shadow ray
    /// traced through `media`. Returns the contribution per unit throughput, MIS-weighted
    /// against sampling the scattering function, divided by the hero MIS denominator, times
    /// the path's throughput, is added to the path's radiance (and to its direct share at
    /// bounce 0).
    #[allow(clippy::too_many_arguments)]
    fn sample_direct(
        &self,
        st: &mut PathState<'a>,
        depth: u32,
        ctx: &ShadingContext,
        u: (glam::Vec2, f32),
        sampler: &mut Sampler,
        seen_by: Option<LobeFlags>,
        scatter: impl Fn(glam::Vec3) -> Option<(f32, f32, glam::Vec3)>,
    ) {
        let c = st.beta
            * self.direct_light(
                ctx,
                u,
                &st.alive,
                &st.media,
                &st.mis,
                sampler,
                &mut st.rays,
                seen_by,
                scatter,
            );
        st.l += c;
        if depth == 0 {
            st.l_direct += c;
        }
    }

    /// `sample_direct`'s contribution per unit throughput.
    #[allow(clippy::too_many_arguments)]
    fn direct_light(
        &self,
        ctx: &ShadingContext,
        (u_light2, u_light): (glam::Vec2, f32),
        w: &SampledWavelengths,
        media: &MediumStack,
        mis: &SpectralMis,
        sampler: &mut Sampler,
        rays: &mut u32,
        seen_by: Option<LobeFlags>,
        scatter: impl Fn(glam::Vec3) -> Option<(f32, f32, glam::Vec3)>,
    ) -> SampledSpectrum {
        let scene = self.scene;
        let mut total = SampledSpectrum::ZERO;
        for ls in scene
            .lights
            .sample(
                &scene.geometry,
                &scene.materials,
                ctx,
                u_light,
                u_light2,
                w,
                self.selection,
            )
            .into_iter()
            .flatten()
        {
            if seen_by.is_some_and(|fl| !ls.visibility.sees(fl)) {
                continue;
            }
            let Some((f, pdf, origin)) = scatter(ls.wi) else {
                continue;
            };
            *rays += 1;
            let shadow = self.transmittance(
                Ray::new_at(origin, ls.wi, ctx.time),
                ls.distance,
                media,
                w,
                sampler,
            );
            if shadow.is_black() {
                continue;
            }
            let weight = if ls.delta {
                1.0
            } else {
                mis.light_weight(ls.pdf, SampledSpectrum::splat(pdf))
            };
            total += ls.li * shadow * (f * weight / (ls.pdf * mis.denominator()));
        }
        total
    }

    /// The field of the heterogeneous volume `e` at the world point `p`: its density and
    /// colour (at the path's wavelengths `w`).
    fn field_at(&self, e: &MediumEntry, p: glam::Vec3, w: &SampledWavelengths) -> FieldPoint {
        let Some(field) = self.scene.materials[e.material as usize]
            .interior()
            .and_then(|m| m.density())
        else {
            return FieldPoint::UNIT;
        };
        let inputs = self.scene.geometry.volume_inputs(e.instance, p);
        let (density, color) = field.graph.volume_field(&inputs);
        FieldPoint {
            density: density.unwrap_or(1.0),
            color: color.map(|c| RgbAlbedoSpectrum::new(c).sample(w)),
        }
    }

    /// Adds to the path the radiance its ray brings back from the emitting surface it hit at
    /// `sp`, `distance` along the path's last segments from its last vertex (after `depth`
    /// scattering events): the emission times the path's throughput, weighted by MIS against
    /// that vertex's light sample (1 after a Dirac scattering or from the camera); nothing
    /// where the light is invisible to the last lobe.
    fn add_surface_emission(
        &self,
        st: &mut PathState<'_>,
        depth: u32,
        hit: &Hit,
        sp: &crate::geometry::SurfacePoint,
        inputs: Option<&crate::shading::ShadingInputs>,
        distance: f32,
    ) {
        let geometry = &self.scene.geometry;
        let material = &self.scene.materials[sp.material as usize];
        let cos_light = sp.ng.dot(-st.ray.dir);
        let le = material.emitted(inputs, cos_light, &st.alive);
        let seen = st.last_lobe.is_none_or(|fl| {
            geometry.instances[hit.instance as usize]
                .light_visibility
                .sees(fl)
        });
        if !seen || le.is_black() {
            return;
        }
        let weight = if st.specular_bounce {
            1.0
        } else {
            let light_pdf = self.scene.lights.triangle_pdf(
                geometry,
                &st.prev_ctx,
                hit.instance,
                hit.prim,
                sp.area,
                distance,
                cos_light,
                self.selection,
            );
            power_heuristic(st.prev_bsdf_density, light_pdf * st.prev_denominator)
        };
        let c = st.beta * le * (weight / st.mis.denominator());
        st.l += c;
        if depth <= 1 {
            st.l_direct += c;
        }
    }

    /// Stochastic transparency at `sp`: the ray passes with probability 1 - alpha (opaque
    /// materials: never), and the path's throughput is then multiplied by the returned weight,
    /// the transparent share's transmittance over that probability (1 unless a Transparent
    /// BSDF is tinted).
    #[inline(never)]
    fn passes_through(
        &self,
        sp: &crate::geometry::SurfacePoint,
        dir: glam::Vec3,
        camera_ray: bool,
        w: &SampledWavelengths,
        sampler: &mut Sampler,
    ) -> Option<SampledSpectrum> {
        let scene = self.scene;
        let m = &scene.materials[sp.material as usize];
        if m.is_null_surface() {
            return Some(SampledSpectrum::ONE);
        }
        if !m.has_alpha() {
            return None;
        }
        let inputs = m.graph_inputs(&scene.geometry, sp, -dir, camera_ray);
        if !m.has_tinted_transparency() {
            let alpha = m.alpha(inputs.as_ref());
            return (sampler.next_1d() >= alpha).then_some(SampledSpectrum::ONE);
        }
        let (alpha, pass) = m.transparency(inputs.as_ref(), w);
        // u >= alpha implies alpha < 1: the division is safe.
        (sampler.next_1d() >= alpha).then(|| pass / (1.0 - alpha))
    }

    /// [`PathTracer::transmittance`] in a scene with alpha materials or volume boundaries
    /// without a surface (kept out of line: the common opaque case stays small).
    #[inline(never)]
    fn transmittance_through(
        &self,
        ray: Ray,
        distance: f32,
        media: &MediumStack,
        w: &SampledWavelengths,
        sampler: &mut Sampler,
    ) -> SampledSpectrum {
        let geometry = &self.scene.geometry;
        let (mut ray, mut remaining) = (ray, distance);
        let mut media = *media;
        let mut t = SampledSpectrum::ONE;
        for _ in 0..64 {
            let hit = geometry.intersect(&ray, remaining);
            if let Some(seg) = self.segment_medium(&media, w) {
                t *= self.segment_transmittance(
                    &seg,
                    &ray,
                    hit.map_or(remaining, |h| h.t),
                    w,
                    sampler,
                );
            }
            let Some(h) = hit else {
                return t;
            };
            let sp = geometry.surface_point(&h);
            if geometry.instances[h.instance as usize].casts_shadows {
                let m = &self.scene.materials[sp.material as usize];
                if m.is_null_surface() {
                    let entry = MediumEntry {
                        instance: h.instance,
                        material: sp.material,
                    };
                    media.cross(entry, ray.dir.dot(sp.ng) < 0.0);
                } else if !m.has_alpha() {
                    return SampledSpectrum::ZERO;
                } else {
                    let inputs = m.graph_inputs(geometry, &sp, -ray.dir, false);
                    t *= m.transparency(inputs.as_ref(), w).1;
                }
                if t.is_black() {
                    return SampledSpectrum::ZERO;
                }
            }
            let origin = offset_ray_origin(sp.p, sp.ng, ray.dir);
            remaining -= (origin - ray.origin).dot(ray.dir);
            if !(remaining > 0.0) {
                return t;
            }
            ray = Ray::new_at(origin, ray.dir, ray.time);
        }
        SampledSpectrum::ZERO
    }

    /// Radiance arriving along `ray` for the path's wavelengths, already weighted by the
    /// hero-wavelength MIS (the film divides slot i by `w.pdf[i]`).
    pub fn radiance(&self, ray: Ray, w: &SampledWavelengths, sampler: &mut Sampler) -> PathSample {
        self.radiance_from(ray, None, w, sampler)
    }

    /// Where the camera ray `ray` goes first: a background the film takes exactly (black, a
    /// transparent film, or with `exact_world` a uniform world; see `PathSample::world_exact`)
    /// or a path, with the ray's closest hit. Most pixels of a product shot, or of a Cornell
    /// box seen from outside (65% of the SSS box's image), see only such a background; their
    /// samples then cost a camera ray and one traversal, without the four wavelengths and the
    /// path's set-up (a black sample took 158 ns of CPU time, 22% of it sampling wavelengths;
    /// now 90 ns). Rays that may meet volumes or round lights before any surface always get a
    /// path.
    pub fn camera_ray(&self, ray: &Ray, exact_world: bool) -> CameraRay {
        let lights = &self.scene.lights;
        if !self.camera_media.is_empty() || lights.has_round() {
            return CameraRay::Path { first_hit: None };
        }
        let geometry = &self.scene.geometry;
        let hit = if geometry.misses_bounds(ray) {
            None
        } else {
            geometry.intersect(ray, f32::INFINITY)
        };
        if hit.is_some() {
            return CameraRay::Path {
                first_hit: Some(hit),
            };
        }
        if self.transparent_background {
            return CameraRay::Background {
                xyz: glam::Vec3::ZERO,
                alpha: 0.0,
            };
        }
        match lights.exact_at_infinity(ray.dir, exact_world) {
            Some(xyz) => CameraRay::Background { xyz, alpha: 1.0 },
            None => CameraRay::Path {
                first_hit: Some(None),
            },
        }
    }

    /// `radiance` with the camera ray's closest hit already found (`camera_ray`).
    pub fn radiance_from(
        &self,
        ray: Ray,
        first_hit: Option<Option<Hit>>,
        w: &SampledWavelengths,
        sampler: &mut Sampler,
    ) -> PathSample {
        self.radiance_split(ray, first_hit, w, sampler, Branches::ONE)
    }

    /// `radiance_from` with the path branching at its first vertex that scatters diffusely or
    /// glossily (or enters a subsurface object) into `splits.lights` light samples and
    /// `splits.paths` continuations (BSDF sample and rest of the path; `Sampler::branch`), each
    /// kind averaged: the camera ray, what it passes and the vertex's shading are traced once.
    /// Splitting (Arvo and Kirk 1990; as in Cycles' former branched path tracing, and the
    /// splitting half of Rath et al. 2022, "EARS") pays where the variance comes after the
    /// camera ray and its share of the cost is large: `Branches::ONE` is plain path tracing.
    pub fn radiance_split(
        &self,
        ray: Ray,
        first_hit: Option<Option<Hit>>,
        w: &SampledWavelengths,
        sampler: &mut Sampler,
        splits: Branches,
    ) -> PathSample {
        let mis = SpectralMis::new(w);
        // The wavelengths the path evaluates materials and lights at. After a smooth
        // dispersive refraction only the hero carries light: the secondaries are collapsed onto
        // it (their throughput is 0), so later dispersive interfaces cost what a
        // single-wavelength path costs, and the BSSRDF samples one channel. The film keeps `w`.
        let mut alive = *w;
        if mis.hero_only() {
            alive.terminate_secondary();
        }
        let mut st = PathState {
            ray,
            l: SampledSpectrum::ZERO,
            l_direct: SampledSpectrum::ZERO,
            beta: SampledSpectrum::ONE,
            rays: 0,
            mis,
            alive,
            prev_bsdf_density: 0.0,
            prev_denominator: 1.0,
            specular_bounce: true,
            last_lobe: None,
            prev_ctx: ShadingContext {
                p: ray.origin,
                n: None,
                time: ray.time,
            },
            media: self.camera_media,
            eta_scale: 1.0,
            walk_medium: None,
            walk_entry_normal: None,
            guides: DenoiseGuides::default(),
            guides_done: false,
            guide_tint: SampledSpectrum::ONE,
            alpha: 1.0,
            diffuse_ancestor: false,
            world_exact: None,
            roulette_vertices: 0,
            rough_vertices: 0,
            first_hit,
            splits,
            light_difference: SampledSpectrum::ZERO,
            path_difference: SampledSpectrum::ZERO,
            shared_rays: NOT_SPLIT,
            light_rays: 0,
            first_densities: None,
            continuations: [(SampledSpectrum::ZERO, 1.0); 2],
        };
        self.trace(&mut st, 0, sampler);
        PathSample {
            radiance: st.l,
            direct: st.l_direct,
            rays: st.rays,
            split: st.shared_rays != NOT_SPLIT,
            shared_rays: if st.shared_rays != NOT_SPLIT {
                st.shared_rays
            } else {
                st.rays
            },
            light_rays: st.light_rays,
            // Only the splitting pilot's (independent branches) are read.
            branch_differences: if st.splits.independent && st.shared_rays != NOT_SPLIT {
                [st.light_difference, st.path_difference].map(|d| spectrum_to_xyz(&d, w).y)
            } else {
                [0.0; 2]
            },
            guide_gain: if st.splits.independent && st.shared_rays != NOT_SPLIT {
                st.continuations
                    .iter()
                    .map(|(gathered, ratio)| spectrum_to_xyz(gathered, w).y.powi(2) * (ratio - 1.0))
                    .sum()
            } else {
                0.0
            },
            guides: st.guides,
            alpha: st.alpha,
            world_exact: st.world_exact,
        }
    }

    /// Follows the path in `st` from bounce `first_depth` (its ray leaves the vertex of bounce
    /// `first_depth - 1`, or the camera) until it ends, adding what it gathers to `st.l`.
    fn trace(&self, st: &mut PathState<'a>, first_depth: u32, sampler: &mut Sampler) {
        let scene = self.scene;
        let geometry = &scene.geometry;
        let lights = &scene.lights;
        let selection = self.selection;
        let uniform_world = lights.uniform_world_xyz();

        for depth in first_depth..=self.max_depth {
            sampler.start_bounce(depth);
            st.rays += 1;
            let next_hit = match st.walk_medium {
                // Inside a random-walk medium: free flights until the walk reaches a surface,
                // which is then shaded from inside like any other hit.
                Some(ss) => {
                    let (sigma_a, sigma_s) = ss.walk_coefficients(&st.alive);
                    let n = active_wavelengths(&st.alive);
                    match random_walk::walk(
                        geometry,
                        st.ray,
                        sigma_a,
                        sigma_s,
                        ss.g,
                        n,
                        st.walk_entry_normal,
                        sampler,
                        &mut st.beta,
                    ) {
                        Some((hit, last)) => {
                            st.ray = last;
                            Some(hit)
                        }
                        None => break,
                    }
                }
                None => match st.first_hit.take() {
                    Some(hit) => hit,
                    None => geometry.intersect(&st.ray, f32::INFINITY),
                },
            };
            // Rays pass through surfaces they do not shade: camera rays through instances hidden
            // from the camera (meshes standing for Blender area lights), as Blender's ray
            // visibility does, every ray through the transparent share of alpha surfaces
            // (stochastic transparency: pass with probability 1 - alpha, as Cycles' transparent
            // bounces) and through volume boundaries without a surface shader (crossing into or
            // out of the volume). These do not count as bounces. Along each straight segment
            // between them the enclosing volumes emit, absorb and may end the flight in a
            // scattering event (`crate::media`).
            let mut next_hit = next_hit;
            // Distance from the current ray's origin to where the path left its last vertex.
            let mut camera_offset = 0.0f32;
            let mut skipped = 0;
            // Where the flight ended in a volume: distance along `ray`, and the phase function
            // and single-scattering albedo there.
            let mut medium_event: Option<(f32, PhaseMixture, SampledSpectrum)> = None;
            loop {
                let in_walk = st.walk_medium.is_some();
                let segment = if in_walk {
                    None
                } else {
                    self.segment_medium(&st.media, &st.alive)
                };
                let segment_end = next_hit.map_or(f32::INFINITY, |h| h.t);
                // The throughput and spectral MIS at the segment's start, and where the flight
                // along it ends.
                let (beta_start, mis_start) = (st.beta, st.mis);
                let mut flight_end = segment_end;
                // A scattering event ended the flight: its phase function and albedo.
                let mut scattered: Option<(PhaseMixture, SampledSpectrum)> = None;
                let heterogeneous = segment.as_ref().is_some_and(|s| s.is_heterogeneous());
                if let Some(seg) = &segment {
                    let emitted = if heterogeneous {
                        let (end, emitted, event) = self.delta_track(
                            seg,
                            &st.ray,
                            segment_end,
                            &mut st.beta,
                            &mut st.mis,
                            &st.alive,
                            sampler,
                        );
                        flight_end = end;
                        scattered = event;
                        emitted
                    } else {
                        // Volume emission seen along the segment, in closed form.
                        let emitted = st.beta * seg.emitted(segment_end) / st.mis.denominator();
                        if let Some(phase) = seg.phase {
                            let flight = seg.sample_distance(segment_end, sampler.next_1d());
                            flight_end = flight.t;
                            st.beta *= flight.weight;
                            st.mis.scatter(flight.pdf_hero, flight.pdf_wavelengths);
                            if flight.scattered {
                                scattered = Some((phase, seg.sigma_s.safe_div(seg.sigma_t)));
                            }
                        } else {
                            st.beta *= seg.transmittance(segment_end);
                        }
                        emitted
                    };
                    st.l += emitted;
                    if depth == 0 {
                        st.l_direct += emitted;
                    }
                }
                if lights.has_round() && !in_walk {
                    // Point and spot lights with a radius that the segment crosses before the
                    // flight ends: they do not block it, so the path goes on as before. In a
                    // volume, light from distance s arrives attenuated by T(s); with a sampled
                    // flight the hero passed s with probability T_0(s), and every wavelength
                    // carries its density ratio as above. Through heterogeneous volumes the
                    // lights along the whole segment count, times a ratio-tracking estimate
                    // of T(s).
                    let dir = st.ray.dir;
                    let t_max = if heterogeneous {
                        segment_end
                    } else {
                        flight_end
                    };
                    lights.for_each_round_hit(
                        st.ray.origin,
                        dir,
                        t_max,
                        depth == 0,
                        &st.alive,
                        |index, s, le| {
                            if st
                                .last_lobe
                                .is_some_and(|fl| !lights.visibility(index).sees(fl))
                            {
                                return;
                            }
                            let weight = if st.specular_bounce {
                                1.0
                            } else {
                                let light_pdf =
                                    lights.round_pdf(&st.prev_ctx, index, dir, selection);
                                power_heuristic(
                                    st.prev_bsdf_density,
                                    light_pdf * st.prev_denominator,
                                )
                            };
                            let (mut b, mut m) = (beta_start, mis_start);
                            if let Some(seg) = &segment {
                                if heterogeneous {
                                    b *= self
                                        .segment_transmittance(seg, &st.ray, s, &st.alive, sampler);
                                } else {
                                    let tr = seg.transmittance(s);
                                    if seg.phase.is_some() {
                                        b *= tr / tr[0];
                                        m.scatter(tr[0], tr);
                                    } else {
                                        b *= tr;
                                    }
                                }
                            }
                            let c = b * le * (weight / m.denominator());
                            if c.is_finite() {
                                st.l += c;
                                if depth <= 1 {
                                    st.l_direct += c;
                                }
                            }
                        },
                    );
                }
                if flight_end < segment_end {
                    if let Some((phase, albedo)) = scattered {
                        medium_event = Some((flight_end, phase, albedo));
                    }
                    // Else the flight was absorbed (beta is 0).
                    break;
                }
                let Some(h) = next_hit else {
                    break;
                };
                let hidden = depth == 0 && !geometry.camera_visible(h.instance);
                let light_only = self.light_meshes && geometry.light_only(h.instance);
                let may_pass = (self.alpha || self.null_surfaces) && !in_walk;
                if !(hidden || may_pass || light_only) {
                    break;
                }
                let sp = geometry.surface_point(&h);
                if light_only {
                    // A light (a Blender area light's mesh) is no geometry: the ray takes its
                    // emission, weighted against the light sample of the path's last vertex
                    // (whose shadow ray passed it too), and goes on from that vertex's state.
                    // As a surface it was a vertex of its own, whose smooth pass-through
                    // counted what lay behind it at full weight besides that vertex's light
                    // samples: a sun behind a softbox made fireflies 700 times the pixel.
                    let material = &scene.materials[sp.material as usize];
                    if !hidden && material.is_emissive() {
                        let inputs = material.graph_inputs(geometry, &sp, -st.ray.dir, depth == 0);
                        self.add_surface_emission(
                            st,
                            depth,
                            &h,
                            &sp,
                            inputs.as_ref(),
                            camera_offset + h.t,
                        );
                    }
                } else if !hidden {
                    match self.passes_through(&sp, st.ray.dir, depth == 0, &st.alive, sampler) {
                        Some(weight) => st.beta *= weight,
                        None => break,
                    }
                }
                let crossed = &scene.materials[sp.material as usize];
                if crossed.is_null_surface() {
                    let entry = MediumEntry {
                        instance: h.instance,
                        material: sp.material,
                    };
                    st.media.cross(entry, st.ray.dir.dot(sp.ng) < 0.0);
                }
                skipped += 1;
                if skipped > 64 {
                    // Degenerate stack of skipped surfaces: give up on this path.
                    next_hit = None;
                    st.beta = SampledSpectrum::ZERO;
                    break;
                }
                st.rays += 1;
                let origin = offset_ray_origin(sp.p, sp.ng, st.ray.dir);
                camera_offset += (origin - st.ray.origin).dot(st.ray.dir);
                st.ray = Ray::new_at(origin, st.ray.dir, st.ray.time);
                next_hit = geometry.intersect(&st.ray, f32::INFINITY);
            }
            if st.beta.is_black() {
                break;
            }
            if let Some((t, phase, albedo)) = medium_event {
                // A scattering event in a volume: next-event estimation with the phase
                // function, then a direction sampled from it (phase / pdf = 1).
                let p = st.ray.at(t);
                st.rough_vertices += 1;
                if depth == 0 {
                    st.guides.first_distance = camera_offset + t;
                }
                if !st.guides_done {
                    st.guides.albedo = st.guide_tint * albedo;
                    st.guides.normal = glam::Vec3::ZERO;
                    st.guides_done = true;
                }
                if depth == self.max_depth {
                    break;
                }
                let ctx = ShadingContext {
                    p,
                    n: None,
                    time: st.ray.time,
                };
                let u = sampler.light();
                let wo_dir = st.ray.dir;
                self.sample_direct(st, depth, &ctx, u, sampler, Some(LobeFlags::VOLUME), |wi| {
                    let f = phase.eval(wo_dir.dot(wi));
                    (f > 0.0).then_some((f, f, p))
                });
                let (u_lobe, u_dir) = sampler.bsdf();
                let wi = phase.sample(st.ray.dir, u_lobe, u_dir.x, u_dir.y);
                let pdf = phase.eval(st.ray.dir.dot(wi));
                st.specular_bounce = false;
                st.last_lobe = Some(LobeFlags::VOLUME);
                st.prev_denominator = st.mis.denominator();
                st.prev_bsdf_density = st.mis.bsdf_density(SampledSpectrum::splat(pdf));
                st.prev_ctx = ctx;
                if !self.russian_roulette(st, true, sampler) {
                    break;
                }
                st.ray = Ray::new_at(p, wi, st.ray.time);
                continue;
            }
            let Some(hit) = next_hit else {
                if depth == 0 && self.transparent_background {
                    // The background is transparent: no world where the camera sees it.
                    st.alpha = 0.0;
                    break;
                }
                // The world and any sun disc along the ray, each with its own MIS weight.
                lights.for_each_at_infinity(st.ray.dir, &st.alive, |index, le| {
                    if st
                        .last_lobe
                        .is_some_and(|fl| !lights.visibility(index).sees(fl))
                    {
                        return;
                    }
                    let weight = if st.specular_bounce {
                        1.0
                    } else {
                        let light_pdf =
                            lights.infinite_pdf(&st.prev_ctx, index, st.ray.dir, selection);
                        power_heuristic(st.prev_bsdf_density, light_pdf * st.prev_denominator)
                    };
                    let c = st.beta * le * (weight / st.mis.denominator());
                    st.l += c;
                    if depth <= 1 {
                        st.l_direct += c;
                    }
                    // The camera sees a uniform world directly, unweighted: the film takes its
                    // exact colour instead of this sample's estimate (`PathSample::world_exact`).
                    let unweighted = st.beta == SampledSpectrum::ONE
                        && st.mis.denominator() == 1.0
                        && weight == 1.0
                        && !st.alive.secondary_terminated();
                    if let Some((_, xyz)) = uniform_world.filter(|(i, _)| *i == index) {
                        if depth == 0 && unweighted {
                            st.world_exact = Some((c, xyz));
                        }
                    }
                });
                break;
            };
            if geometry.is_holdout(hit.instance) {
                // A holdout: a hole in the image for camera rays; every path ends here
                // (Cycles terminates paths at full holdouts).
                if depth == 0 {
                    st.alpha = 0.0;
                }
                break;
            }
            if depth == 0 {
                st.guides.first_distance = camera_offset + hit.t;
            }
            let mut sp = geometry.surface_point(&hit);
            let material = &scene.materials[sp.material as usize];
            if let Some(ss) = material
                .subsurface()
                .filter(|_| depth > 0 && st.walk_medium.is_none() && st.ray.dir.dot(sp.ng) > 0.0)
            {
                // The ray crossed the inside of a subsurface object without scattering, which
                // light in a scattering medium does not do. Only exits through shells inside
                // the object produce such rays (a probe hit or a walk ending on Suzanne's eyes,
                // inside her head): flying through the medium and refracting out where they met
                // the outer surface, they made most of the SSS Cornell box's fireflies (a rough
                // refraction out, then the light seen through it) and 13% too much light on
                // Suzanne (without them Cycles' mean there is matched within 2%).
                if ss.method == SubsurfaceMethod::RandomWalk {
                    // The segment lies in the medium: walk it instead (the light scatters on
                    // from the inner shell as if that were no boundary).
                    st.walk_medium = Some(ss.at(None));
                    continue;
                }
                // The table method has no medium to continue in; the light that leaves
                // through inner shells is lost (the union of two overlapping spheres in a
                // white furnace keeps the single sphere's mean within 0.1%). Not only right
                // after an exit: flights chain (exit, a reflection off an eye from outside, the
                // head from inside): ending only those right after an exit left the SSS Cornell
                // box's full noise at 0.0077 instead of 0.0044. An open subsurface surface seen
                // from its back by an indirect ray ends the path too; subsurface needs closed
                // meshes, as in Cycles.
                break;
            }
            let wo_world = -st.ray.dir;
            // The clear coat's own normal (glTF clearcoatNormalTexture, Blender's Coat Normal).
            let mut coat_normal = material.coat_normal_map(geometry, &scene.textures, &sp);
            material.apply_normal_map(geometry, &scene.textures, &mut sp, Some(wo_world));
            // What a shading graph reads here (only gathered for materials that have one).
            let mut graph_inputs = material.graph_inputs(geometry, &sp, wo_world, depth == 0);
            let graph_normals = material.has_graph_normal() || material.has_graph_coat_normal();
            if let Some(inputs) = graph_inputs.filter(|_| graph_normals) {
                // Bump offsets: the Bump node's filter width in pixels, times the pixel's
                // footprint at the distance travelled (Cycles scales its ray differentials;
                // the footprint's growth over bounces is not followed).
                let step = (self.footprint.at(camera_offset + hit.t)
                    * material.bump_filter_width())
                .max(1e-6);
                let directions = material.bump_directions(inputs.true_normal);
                let bump = geometry.bump_inputs(&sp, &inputs, step, directions);
                if material.has_graph_coat_normal() {
                    coat_normal = material.graph_coat_normal(&inputs, &bump).or(coat_normal);
                }
                if let Some(n) = material.graph_normal(&inputs, &bump) {
                    geometry.apply_world_normal(&mut sp, n, None);
                    graph_inputs = material.graph_inputs(geometry, &sp, wo_world, depth == 0);
                }
            }

            if material.is_emissive() {
                self.add_surface_emission(
                    st,
                    depth,
                    &hit,
                    &sp,
                    graph_inputs.as_ref(),
                    camera_offset + hit.t,
                );
            }
            if depth == self.max_depth {
                break;
            }

            let (bsdf, subsurface) = material.scattering(
                graph_inputs.as_ref(),
                &st.alive,
                sampler.material_component(),
                st.walk_medium.is_some(),
            );
            // The path reached the boundary of the random-walk medium it travels in: light
            // leaves through the exit lobe below (`bssrdf::WalkBoundary`), which gets its own
            // next-event estimation; internal reflection cannot reach a light outside.
            let walk_exit = subsurface.filter(|_| st.walk_medium.is_some());
            let transmissive = bsdf.has_transmission();
            // Reflective models shade both faces alike: turn the normals towards the viewer.
            // Dielectrics keep the outward normal so that inside/outside (eta) stays meaningful.
            let (ns, ng) = if !transmissive && sp.ng.dot(wo_world) < 0.0 {
                (-sp.ns, -sp.ng)
            } else {
                (sp.ns, sp.ng)
            };
            let frame = Frame::from_normal_tangent(ns, sp.dpdu);
            // A bump or normal map perturbs the base, not the clear coat over it, which keeps
            // the surface's own normal (Cycles' Coat Normal default; glTF's clearcoat without a
            // clearcoatNormalTexture) unless the graph gives it one.
            let bsdf = match coat_normal.or((sp.ns != sp.ns_smooth).then_some(sp.ns_smooth)) {
                Some(n) => {
                    let n = if ns.dot(sp.ns) < 0.0 { -n } else { n };
                    bsdf.with_coat_normal(frame.to_local(n))
                }
                None => bsdf,
            };
            let wo = frame.to_local(wo_world);
            // A normal-mapped surface with a diffuse base shades with the mapped normal even
            // where it faces away from the viewer, as Cycles' diffuse closures do (their value
            // does not depend on wo), instead of going black there (`Material::apply_normal_map`).
            let bumped_diffuse = sp.ns != sp.ns_smooth && bsdf.has_diffuse_reflection();
            let wo = if bumped_diffuse {
                glam::Vec3::new(wo.x, wo.y, wo.z.abs())
            } else {
                wo
            };
            // Every evaluation and sample below is from this `wo`: its terms once.
            let bsdf = bsdf.at_view(wo);
            // The diffuse part of a normal-mapped surface is masked near the smooth normal's
            // horizon (Conty Estevez et al. 2019), as Cycles does for its diffuse closures: f
            // loses (1 - G(wi)) of its diffuse part, for light and BSDF samples alike.
            let bumped = sp.ns != sp.ns_smooth && !transmissive;

            let guide_here =
                subsurface.is_some() || !bsdf.is_specular() || depth >= GUIDE_MAX_SPECULAR;
            if !st.guides_done && st.walk_medium.is_none() && guide_here {
                st.guides.albedo = st.guide_tint
                    * match subsurface {
                        Some(ss) => ss.effective_albedo(&st.alive),
                        None => bsdf.albedo(),
                    };
                st.guides.normal = if ns.dot(wo_world) < 0.0 { -ns } else { ns };
                st.guides_done = true;
            }

            // Next-event estimation. A surface that only reflects receives light on the side of
            // `ng` (turned towards the viewer above); light selection ignores lights behind it.
            let ctx = ShadingContext {
                p: sp.p,
                n: (!transmissive).then_some(ng),
                time: st.ray.time,
            };
            let vertex = Vertex {
                sp,
                instance: hit.instance,
                material,
                bsdf,
                subsurface,
                walk_exit,
                frame,
                wo,
                wo_world,
                ns,
                ng,
                bumped,
                ctx,
            };
            // Where photons found caustics, continuations are partly guided towards them.
            let guide = match self.caustics {
                Some(photons)
                    if st.rough_vertices <= MAX_GUIDED_DEPTH
                        && subsurface.is_none()
                        && walk_exit.is_none()
                        && !transmissive
                        && !bsdf.is_specular()
                        && !bsdf.is_dispersive()
                        && !bsdf.focuses_light() =>
                {
                    if st.splits.caustic_guiding {
                        photons.guide(sp.p, ng)
                    } else {
                        None
                    }
                }
                _ => None,
            };
            let guide = guide.as_ref();
            if !bsdf.is_sharp() {
                st.rough_vertices += 1;
            }
            // A camera path splits at its first vertex that scatters diffusely or glossily
            // (`radiance_split`): into its light samples and continuations there.
            let split = depth == 0
                && st.splits.split()
                && (subsurface.is_some() || !bsdf.is_specular())
                && walk_exit.is_none();
            if split {
                self.split_continuations(&vertex, st, sampler, guide);
                break;
            }
            self.vertex_direct(&vertex, st, depth, sampler, guide);

            if !self.scatter(&vertex, st, depth, sampler, guide) {
                break;
            }
        }
    }

    /// Next-event estimation at the surface vertex `v` of bounce `depth`. A surface that only
    /// reflects receives light on the side of `ng` (turned towards the viewer); light selection
    /// ignores lights behind it.
    #[inline(always)]
    fn vertex_direct(
        &self,
        v: &Vertex<'a>,
        st: &mut PathState<'a>,
        depth: u32,
        sampler: &mut Sampler,
        guide: Option<&CausticGuide>,
    ) {
        let scene = self.scene;
        let geometry = &scene.geometry;
        let lights = &scene.lights;
        let selection = self.selection;
        let transmissive = v.bsdf.has_transmission();
        let (u_light2, u_light) = sampler.light();
        if !v.bsdf.is_specular() && v.walk_exit.is_none() {
            for ls in lights
                .sample(
                    geometry,
                    &scene.materials,
                    &v.ctx,
                    u_light,
                    u_light2,
                    &st.alive,
                    selection,
                )
                .into_iter()
                .flatten()
            {
                let wi = v.frame.to_local(ls.wi);
                // A dispersive BSDF costs one evaluation per wavelength, often more than
                // the shadow ray that makes it moot (light seen through glass is mostly
                // blocked by the glass itself): when the hero's own value is non-zero, test
                // visibility first and evaluate every wavelength only for visible lights.
                // Otherwise the full evaluation goes first and saves shadow rays where f is 0.
                let eval_after_shadow = v.bsdf.is_dispersive() && v.bsdf.hero_value(v.wo, wi) > 0.0;
                let (mut f, mut bsdf_pdfs) = if eval_after_shadow {
                    (SampledSpectrum::ONE, SampledSpectrum::ZERO)
                } else {
                    v.bsdf.eval_pdf_wavelengths(v.wo, wi)
                };
                // A direction on the wrong geometric side would leak light through the surface.
                let same_side = ls.wi.dot(v.ng) * v.wo_world.dot(v.ng) > 0.0;
                let side_ok = if transmissive { true } else { same_side };
                if side_ok && !f.is_black() {
                    st.rays += 1;
                    let origin = offset_ray_origin(v.sp.p, v.ng, ls.wi);
                    // The shadow ray travels in the medium on its side of the surface.
                    let shadow_media = if ls.wi.dot(v.sp.ng) * v.wo_world.dot(v.sp.ng) > 0.0 {
                        st.media
                    } else {
                        self.media_across(&st.media, v.instance, v.sp.material, ls.wi, v.sp.ng)
                    };
                    let shadow = self.transmittance(
                        Ray::new_at(origin, ls.wi, v.ctx.time),
                        ls.distance,
                        &shadow_media,
                        &st.alive,
                        sampler,
                    );
                    let visible = !shadow.is_black();
                    if visible && eval_after_shadow {
                        (f, bsdf_pdfs) = v.bsdf.eval_pdf_wavelengths(v.wo, wi);
                    }
                    if visible && !ls.visibility.is_all() {
                        f = v.bsdf.visible_part(v.wo, wi, f, ls.visibility);
                    }
                    if visible && v.bumped && ls.visibility.diffuse {
                        f = (f - v.bump_loss(wi, ls.wi)).clamp_zero();
                    }
                    f *= wi.z.abs();
                    if visible && !f.is_black() {
                        let weight = if ls.delta {
                            1.0
                        } else {
                            // Continuations sample the mixture of BSDF and guide.
                            let bsdf_pdfs = match guide {
                                Some(g) => g.mixture_pdf(bsdf_pdfs, g.pdf(ls.wi)),
                                None => bsdf_pdfs,
                            };
                            st.mis.light_weight(ls.pdf, bsdf_pdfs)
                        };
                        let contrib = st.beta
                            * f
                            * ls.li
                            * shadow
                            * (weight / (ls.pdf * st.mis.denominator()));
                        st.l += contrib;
                        if depth == 0 {
                            st.l_direct += contrib;
                        }
                    }
                }
            }
        }
    }

    /// Continues the path `st` from its first vertex `v` in the branches of `st.splits`:
    /// `lights` light samples and `paths` continuations (BSDF sample and rest of the path),
    /// branch j taking its values from `Sampler::branch(j)` (the pilot's from
    /// `Sampler::independent_branch(j)`), and keeps the mean of each: the camera ray and the
    /// vertex's set-up are shared. Given the vertex the two are independent,
    /// so the sample's variance is V_s + V_l / lights + V_p / paths (`splitting`). MIS between
    /// the light samples and the continuations' hits of lights keeps its weights, which still
    /// sum to one for every path (Veach 1997, section 9.2.2: unbiased for any sample counts).
    /// Records the differences between the first two of each (`PathSample::branch_differences`).
    #[inline(never)]
    fn split_continuations(
        &self,
        v: &Vertex<'a>,
        st: &mut PathState<'a>,
        sampler: &mut Sampler,
        guide: Option<&CausticGuide>,
    ) {
        let base = *st;
        let Branches {
            lights,
            paths,
            independent,
            ..
        } = st.splits;
        let (light_weight, path_weight) = (1.0 / lights as f32, 1.0 / paths as f32);
        let mut sum_l = SampledSpectrum::ZERO;
        let mut sum_direct = SampledSpectrum::ZERO;
        let mut first_light = SampledSpectrum::ZERO;
        let mut first_path = SampledSpectrum::ZERO;
        let (mut light_rays, mut path_rays) = (0, 0);
        for j in 0..lights.max(paths) as u32 {
            let mut s = if independent {
                sampler.independent_branch(j)
            } else {
                sampler.branch(j)
            };
            if j < lights as u32 {
                let mut lit = base;
                self.vertex_direct(v, &mut lit, 0, &mut s, guide);
                let gathered = lit.l - base.l;
                match j {
                    0 => first_light = gathered,
                    1 => st.light_difference = first_light - gathered,
                    _ => {}
                }
                sum_l += gathered * light_weight;
                sum_direct += (lit.l_direct - base.l_direct) * light_weight;
                light_rays += lit.rays - base.rays;
            }
            if j < paths as u32 {
                let mut branch = base;
                if self.scatter(v, &mut branch, 0, &mut s, guide) {
                    self.trace(&mut branch, 1, &mut s);
                }
                let gathered = branch.l - base.l;
                if independent && j < 2 {
                    st.continuations[j as usize] =
                        (gathered, unguided_ratio(guide, branch.first_densities));
                }
                match j {
                    0 => {
                        first_path = gathered;
                        st.guides = branch.guides;
                        st.guides_done = branch.guides_done;
                        st.alpha = branch.alpha;
                    }
                    1 => st.path_difference = first_path - gathered,
                    _ => {}
                }
                sum_l += gathered * path_weight;
                sum_direct += (branch.l_direct - base.l_direct) * path_weight;
                path_rays += branch.rays - base.rays;
            }
        }
        st.l = base.l + sum_l;
        st.l_direct = base.l_direct + sum_direct;
        st.shared_rays = base.rays;
        st.light_rays = light_rays;
        st.rays = base.rays + light_rays + path_rays;
    }

    /// A continuation's direction at `v` from the one-sample mixture of its BSDF (probability
    /// `1 - g.share`) and the caustic guide `g`, with the mixture's density (Veach 1997,
    /// 9.2.4): `u_lobe` chooses between them and is reused within the choice. A Dirac lobe's
    /// sample keeps its discrete probability, times the BSDF's share. Only for BSDFs that are
    /// not dispersive (one density for every wavelength) and only reflect.
    /// Also returns the two densities at the direction (the BSDF's infinite for a Dirac lobe).
    fn sample_guided(
        &self,
        v: &Vertex<'a>,
        g: &CausticGuide,
        u_lobe: f32,
        u_dir: glam::Vec2,
    ) -> Option<(BsdfSample, (f32, f32))> {
        if u_lobe < g.share {
            let wi_world = g.sample(u_lobe / g.share, u_dir);
            let wi = v.frame.to_local(wi_world);
            let (f, bsdf_pdf) = v.bsdf.eval_pdf(v.wo, wi);
            let guide_pdf = g.pdf(wi_world);
            let pdf = g.mixture_pdf(bsdf_pdf, guide_pdf);
            if f.is_black() || !(pdf > 0.0) {
                return None;
            }
            // The lobe it stands for (Blender's light ray visibility): diffuse where the
            // BSDF has a diffuse part, else glossy.
            let kind = if v.bsdf.has_diffuse_reflection() {
                LobeFlags::DIFFUSE
            } else {
                LobeFlags::GLOSSY
            };
            let side = if wi.z * v.wo.z < 0.0 {
                LobeFlags::TRANSMISSION
            } else {
                LobeFlags::REFLECTION
            };
            let bs = BsdfSample {
                wi,
                f,
                pdf,
                flags: side.with(kind),
                eta: SampledSpectrum::ONE,
                pdf_wavelengths: SampledSpectrum::splat(pdf),
            };
            return Some((bs, (bsdf_pdf, guide_pdf)));
        }
        let u = (u_lobe - g.share) / (1.0 - g.share);
        let mut bs = v.bsdf.sample(v.wo, u.min(0.999_999_94), u_dir)?;
        let densities = if bs.is_specular() {
            bs.pdf *= 1.0 - g.share;
            (f32::INFINITY, 0.0)
        } else {
            let (bsdf_pdf, guide_pdf) = (bs.pdf, g.pdf(v.frame.to_world(bs.wi)));
            bs.pdf = g.mixture_pdf(bsdf_pdf, guide_pdf);
            (bsdf_pdf, guide_pdf)
        };
        bs.pdf_wavelengths = SampledSpectrum::splat(bs.pdf);
        Some((bs, densities))
    }

    /// Continues the path from the vertex `v` of bounce `depth`: samples the BSDF (and, for
    /// light entering a subsurface medium, its exit point, with next-event estimation there)
    /// and sets `st.ray` to the next ray. False when the path ends here. Inlined into `trace`
    /// (and `split_continuations`) as the loop body it was (CPU time against the loop before
    /// it, median of 5, 32 spp: SSS Cornell 3.80 / 3.73 s, everyday 2.18 / 2.19, rough glass
    /// 4.13 / 4.38; without the attribute SSS Cornell measured 3-6% slower).
    #[inline(always)]
    fn scatter(
        &self,
        v: &Vertex<'a>,
        st: &mut PathState<'a>,
        depth: u32,
        sampler: &mut Sampler,
        guide: Option<&CausticGuide>,
    ) -> bool {
        let scene = self.scene;
        let geometry = &scene.geometry;
        // Continue the path by sampling the BSDF.
        let bs = match v.walk_exit {
            // A Lambertian walk boundary lets every walk out (weight 1); the exit lobe
            // below picks the direction. Stands for a transmission along the normal.
            Some(ss) if ss.boundary == WalkBoundary::Lambertian => BsdfSample {
                wi: glam::Vec3::Z,
                f: SampledSpectrum::ONE,
                pdf: 1.0,
                flags: LobeFlags::sample(true, true),
                eta: SampledSpectrum::ONE,
                pdf_wavelengths: SampledSpectrum::ONE,
            },
            _ => {
                let (u_lobe, u_dir) = sampler.bsdf();
                match guide {
                    Some(g) => match self.sample_guided(v, g, u_lobe, u_dir) {
                        Some((bs, densities)) => {
                            if depth == 0 {
                                st.first_densities = Some(densities);
                            }
                            bs
                        }
                        None => return false,
                    },
                    None => match v.bsdf.sample(v.wo, u_lobe, u_dir) {
                        Some(bs) => bs,
                        None => return false,
                    },
                }
            }
        };
        if !(bs.pdf > 0.0) || bs.f.is_black() {
            return false;
        }
        let wi_world = v.frame.to_world(bs.wi);
        let crosses = wi_world.dot(v.ng) * v.wo_world.dot(v.ng) < 0.0;
        if crosses != bs.is_transmission() {
            // Shading normal disagrees with the geometry: the sample would leak light.
            return false;
        }
        let f = if v.bumped && !bs.is_specular() {
            (bs.f - v.bump_loss(bs.wi, wi_world)).clamp_zero()
        } else {
            bs.f
        };
        st.beta *= f * (bs.wi.z.abs() / bs.pdf);
        if !st.guides_done {
            // Only a Dirac BSDF gets here (see above): glass tint or mirror colour.
            st.guide_tint *= v.bsdf.albedo();
        }
        st.specular_bounce = bs.is_specular();
        st.last_lobe = Some(bs.flags);
        st.prev_denominator = st.mis.denominator();
        st.prev_bsdf_density = st.mis.bsdf_density(bs.pdf_wavelengths);
        st.prev_ctx = v.ctx;
        st.mis.scatter(bs.pdf, bs.pdf_wavelengths);
        if st.mis.hero_only() && !st.alive.secondary_terminated() {
            st.alive.terminate_secondary();
        }
        // Where the path continues: point, normal for the ray offset, direction.
        let mut next = (v.sp.p, v.ng, wi_world);
        let entering = wi_world.dot(v.sp.ng) < 0.0;
        let enters_subsurface =
            bs.is_transmission() && entering && st.walk_medium.is_none() && v.subsurface.is_some();
        let collapsed = enters_subsurface && st.diffuse_ancestor && !self.full_indirect_subsurface;
        let sss_table = enters_subsurface
            && !collapsed
            && v.subsurface
                .is_some_and(|s| s.method == SubsurfaceMethod::Table);
        // Where light leaves a subsurface medium, if it does here: point, outward geometric
        // normal, shading frame (outward normal), lobe.
        let mut exit = None;
        // Next-event estimation at the exit already done (the probe's exits).
        let mut exit_lit = false;
        if collapsed {
            // The BSSRDF collapsed to the entry point (`with_full_indirect_subsurface`):
            // as the table's exit below, with the medium's reflectance for the probe's or
            // walk's weight (its mean on a flat surface).
            let Some(ss) = v.subsurface else { return false };
            let cos_entry = -wi_world.dot(v.sp.ng);
            st.beta *= bs.eta * bs.eta * ss.collapsed_albedo(&st.alive, cos_entry);
            exit = Some((v.sp.p, v.sp.ng, exit_frame(&v.sp), ss.exit_lobe()));
        } else if sss_table {
            // Separable BSSRDF: the boundary's transmission sample stands for
            // (1 - Fr(cos theta_o)); undo the radiance 1/eta^2 it carries (light refracts
            // in at the exit point and out here), find the exit point and shade it with Sw.
            let Some(ss) = v.subsurface else { return false };
            // Per wavelength: the boundary may be dispersive.
            st.beta *= bs.eta * bs.eta;
            let bssrdf = ss.bssrdf(&st.alive);
            let (u_axis, u_disk, u_hit) = sampler.subsurface_probe();
            st.rays += 1;
            let Some(probe) = bssrdf.sample_probe(
                geometry,
                v.sp.material,
                v.sp.p,
                v.sp.time,
                &v.frame,
                u_axis,
                u_disk,
                u_hit,
            ) else {
                return false;
            };
            let beta_entry = st.beta;
            st.beta *= probe.weight;
            let mut pi = probe.point;
            let exit_material = &scene.materials[pi.material as usize];
            exit_material.apply_normal_map(geometry, &scene.textures, &mut pi, None);
            let lobe = ss.exit_lobe();
            let frame_pi = exit_frame(&pi);
            exit = Some((pi.p, pi.ng, frame_pi, lobe));
            // Next-event estimation at every exit point the probe found, each with its own
            // estimate (their sum is the probe's estimate); the path goes on from the chosen
            // one with the sum. Choosing one exit for the light as well made the light's
            // estimate swing between the lit and the dark side of thin parts (a probe through
            // an ear finds both): marble monkey of the SSS Cornell box -9% noise, no more time.
            let u = sampler.exit_light();
            for (i, found) in probe.hits.iter().enumerate() {
                let Some((hit, w)) = *found else { continue };
                // The chosen exit's point and frame are the path's own (above).
                let (p, ng, frame) = if i == probe.chosen {
                    (pi.p, pi.ng, frame_pi)
                } else {
                    let mut pe = geometry.surface_point(&hit);
                    let m = &scene.materials[pe.material as usize];
                    m.apply_normal_map(geometry, &scene.textures, &mut pe, None);
                    (pe.p, pe.ng, exit_frame(&pe))
                };
                let beta = beta_entry * w;
                self.exit_direct(st, depth, beta, p, ng, frame, lobe, u, sampler);
            }
            exit_lit = true;
        } else if let (true, Some(ss)) = (bs.is_transmission(), v.walk_exit) {
            // A random walk leaves its medium here. A dielectric boundary's transmission
            // sample kept its weight (transmittance for the walk's direction, times eta^2);
            // only its direction is replaced by the exit lobe's (`WalkBoundary`).
            if ss.boundary == WalkBoundary::Dielectric {
                st.eta_scale *= bs.eta[0] * bs.eta[0];
            }
            st.walk_medium = None;
            exit = Some((v.sp.p, v.sp.ng, v.frame, ss.exit_lobe()));
        } else if bs.is_transmission() {
            // Radiance scales by 1/eta^2 across a refraction; Russian roulette works on the
            // throughput without it (pbrt-v4's etaScale).
            st.eta_scale *= bs.eta[0] * bs.eta[0];
            if v.material.interior().is_some() {
                let entry = MediumEntry {
                    instance: v.instance,
                    material: v.sp.material,
                };
                st.media.cross(entry, entering);
            }
            st.walk_medium = match v.subsurface {
                Some(s) if entering && s.method == SubsurfaceMethod::RandomWalk => Some(s),
                _ => None,
            };
            if st.walk_medium.is_some() {
                // Outward geometric normal at the entry (the ray leaves against it).
                let ng = v.sp.ng;
                st.walk_entry_normal = Some(if wi_world.dot(ng) < 0.0 { ng } else { -ng });
            }
            if v.subsurface
                .is_some_and(|s| s.boundary == WalkBoundary::Lambertian)
                && st.walk_medium.is_some()
            {
                // Lambertian walk boundary: the light enters along the refracted direction
                // but without the refraction's 1/eta^2 radiance factor (the Lambertian exit
                // has no eta^2 either).
                st.beta *= bs.eta * bs.eta;
                st.eta_scale /= bs.eta[0] * bs.eta[0];
            }
        }
        if let Some((p_exit, ng_i, frame_i, lobe)) = exit {
            // Next-event estimation at the exit point with the exit lobe.
            let exit_ctx = ShadingContext {
                p: p_exit,
                n: Some(ng_i),
                time: st.ray.time,
            };
            if !exit_lit {
                let u = sampler.exit_light();
                let beta = st.beta;
                self.exit_direct(st, depth, beta, p_exit, ng_i, frame_i, lobe, u, sampler);
            }
            let wi = lobe.sample(sampler.exit_lobe());
            let pdf = lobe.pdf(wi.z);
            if !(pdf > 0.0) {
                return false;
            }
            let wi_world = frame_i.to_world(wi);
            if !(wi_world.dot(ng_i) > 0.0) {
                return false;
            }
            st.beta *= lobe.eval(wi.z) * wi.z / pdf;
            st.specular_bounce = false;
            st.last_lobe = None;
            st.prev_denominator = st.mis.denominator();
            st.prev_bsdf_density = pdf * st.prev_denominator;
            st.prev_ctx = exit_ctx;
            next = (p_exit, ng_i, wi_world);
            st.diffuse_ancestor = true;
        }
        st.diffuse_ancestor |= bs.flags.contains(LobeFlags::DIFFUSE) && !enters_subsurface;
        if !st.beta.is_finite() {
            return false;
        }
        // A refraction through glass (or a pass through a transparent sheet) neither darkens
        // the path nor ends the light's way through the object: light that reaches a diffuse
        // surface through a glass sphere needs two of them after the bounce that found it, so
        // they do not bring the roulette closer (`RR_MIN_DEPTH`). Entering or leaving a
        // subsurface medium does.
        let passes_interface = bs.is_transmission()
            && !bs.flags.contains(LobeFlags::DIFFUSE)
            && !enters_subsurface
            && v.walk_exit.is_none();
        if !self.russian_roulette(st, !passes_interface, sampler) {
            return false;
        }
        let (p, n, dir) = next;
        st.ray = Ray::new_at(offset_ray_origin(p, n, dir), dir, st.ray.time);
        true
    }
}

/// The shading frame where light leaves a subsurface medium at `sp`: around the shading normal
/// turned to the outward geometric normal's side.
fn exit_frame(sp: &crate::geometry::SurfacePoint) -> Frame {
    let ns = if sp.ns.dot(sp.ng) < 0.0 {
        -sp.ns
    } else {
        sp.ns
    };
    Frame::from_normal_tangent(ns, sp.dpdu)
}

/// The volumes enclosing the point `p`, found as Cycles initialises its camera volume stack: a
/// ray from `p` crosses every boundary; a volume left before being entered along it encloses
/// `p`. Assumes closed boundaries (as volumes need anyway).
pub fn enclosing_media(scene: &Scene, p: glam::Vec3) -> MediumStack {
    let mut inside = MediumStack::default();
    if !scene.materials.iter().any(|m| m.interior().is_some()) {
        return inside;
    }
    let geometry = &scene.geometry;
    // An arbitrary direction, unlikely to run along the edges of axis-aligned boxes.
    let dir = glam::Vec3::new(0.267_261_24, 0.534_522_5, 0.801_783_7);
    let mut entered = MediumStack::default();
    let mut ray = Ray::new(p, dir);
    for _ in 0..256 {
        let Some(h) = geometry.intersect(&ray, f32::INFINITY) else {
            break;
        };
        let sp = geometry.surface_point(&h);
        if scene.materials[sp.material as usize].interior().is_some() {
            let e = MediumEntry {
                instance: h.instance,
                material: sp.material,
            };
            if dir.dot(sp.ng) < 0.0 {
                entered.enter(e);
            } else if entered.entries().contains(&e) {
                entered.leave(e);
            } else {
                inside.enter(e);
            }
        }
        ray = Ray::new(offset_ray_origin(sp.p, sp.ng, dir), dir);
    }
    inside
}
