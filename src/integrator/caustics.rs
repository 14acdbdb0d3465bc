//! Caustic guiding: photons traced from the lights through the surfaces that focus light
//! (metals and glass with sharp microfacets, `Bsdf::focuses_light`) tell a diffuse or rough
//! surface where its caustics come from, and the path tracer sends a share of its
//! continuations there (Jensen 1995, "Importance Driven Path Tracing using the Photon Map").
//!
//! A path tracer finds a caustic (light -> sharp metal or glass -> diffuse surface -> camera)
//! only when the diffuse surface's BSDF sample happens to hit the small part of the focusing
//! object that reflects or refracts the light towards it (the sun's glint in a gold ball seen
//! from the floor): those rare, bright samples are the floor's sparkle. Light paths find that
//! part directly. Each stored photon keeps where it landed and the last focusing vertex it
//! came from; at a shading point `x`, the photons that landed within `radius` of it point,
//! each through a narrow cone around the direction from `x` to its focusing vertex, at the
//! part of the focusing object that lights `x`. A near-mirror's glint is far narrower than
//! those cones: a photon that left a single reflection keeps the surface around it
//! (`GlintPatch`), from which Newton's method solves the glint that lights `x`, and a lobe
//! of GGX slopes points there (`GlintLobe`).
//!
//! The guide only shapes a sampling density: the continuation's direction comes from the
//! BSDF with probability `1 - GUIDE_SHARE` (`1 - GLINT_SHARE` for glint lobes alone) and
//! from the guide otherwise, weighted by
//! the one-sample mixture density `(1 - s) p_bsdf + s p_guide` (Veach 1997, 9.2.4), which
//! next-event estimation's MIS weights use too. The guide is a function of the shading
//! point alone (the photons are fixed before the render, from the render's seed), so the
//! estimator stays unbiased whatever the photons missed: where they found nothing the BSDF
//! samples alone, and every direction the BSDF can sample keeps a positive density.
//!
//! Only glints that BSDF samples miss and photons can point at are guided: in metals and
//! glass that are sharp but not mirrors (`Bsdf::focusing_alpha`), of lights small enough
//! (`MAX_GLINT_BLUR`). Where no such glint exists the photons are not kept, and the image is
//! the one without guiding. Where one does, the splitting pilot, itself guided, estimates
//! from its continuations how much noise guiding removes and turns it off for the rest of
//! the render where that is less than what it costs (`splitting::SplitPlanner::plan`).

use crate::bsdf::microfacet::TrowbridgeReitz;
use crate::bsdf::Bsdf;
use crate::geometry::{offset_ray_origin, Hit, Ray, SurfacePoint};
use crate::lights::{LightSelection, ShadingContext};
use crate::math::sampling::{
    sample_uniform_cone_one_minus_cos, sample_uniform_triangle, uniform_cone_pdf_one_minus_cos,
};
use crate::math::{DiscreteDistribution, Frame};
use crate::sampler::Pcg32;
use crate::scene::Scene;
use crate::spectrum::{SampledWavelengths, WavelengthPdf};
use glam::{Vec2, Vec3};
use rayon::prelude::*;

/// Probability that a guided vertex samples its continuation from the guide rather than the
/// BSDF (0.5 and 0.25 removed less noise from everyday2's floor, bench/README.md).
pub const GUIDE_SHARE: f32 = 0.35;

/// The last vertex whose continuations are guided, counting only the vertices that did not
/// reflect like a mirror or near-mirror (`Bsdf::is_sharp`; 0: the first such): caustics seen
/// directly and after one bounce, also in a mirror or a chrome ball (a floor seen in one is
/// guided as the floor seen directly). Guiding every bounce cost 10% more time on everyday2
/// for no less noise (efficiency 3.2 / 2.8 against 3.4 / 2.9, full / bulk).
pub const MAX_GUIDED_DEPTH: u32 = 1;

/// Photons gathered into one guide at most (the first found within the radius).
pub const MAX_GUIDE_CONES: usize = 8;

/// Photon paths started on the focusing surfaces per render.
const PHOTON_PATHS: u32 = 1 << 16;

/// The largest blur (radians: the light's angular radius plus 2 alpha per focusing vertex) of
/// the glints photons guide to, where the splitting pilot then tells whether guiding pays
/// (`splitting::SplitPlanner::plan`): the sun's in a metal ball of roughness 0.3 (blur 0.19)
/// it does, 1.8-2.5x the efficiency; an area light's in a rough metal ball under the Cornell
/// box's ceiling light (0.2-0.3) it does not, and the pilot turns guiding off. A broader glint
/// is found by BSDF samples often enough.
pub const MAX_GLINT_BLUR: f32 = 0.3;

/// The largest blur when no pilot decides (renders of fewer than `splitting::MIN_SPP`
/// samples per pixel, fixed splitting): the sun's or a small lamp's in sharp metal or glass,
/// where guiding always paid. Guiding towards broader glints unconditionally cost a third
/// more time for the same noise on the Cornell box and the rough glass scene (efficiency 0.56
/// and 0.68, 64 spp, 2 pairs), and on the studio scene everyday3 0.67 / 0.73 (0.2 rad).
pub const MAX_UNPLANNED_GLINT_BLUR: f32 = 0.12;

/// Focusing vertices a photon passes at most before it lands (glass takes two per object).
const MAX_FOCUSING_BOUNCES: u32 = 6;

/// The guide's cones: as wide as the gathering radius seen from the shading point, but at
/// least this (sin of the half-angle, about 1.1 degrees) and at most this (about 17 degrees).
/// Cones as narrow as the photons' spread of directions removed no more noise.
const MIN_CONE_SIN: f32 = 0.02;
const MAX_CONE_SIN: f32 = 0.3;

/// A photon that landed on a surface that does not focus light.
#[derive(Clone, Copy, Debug)]
struct Photon {
    /// Where it landed.
    p: Vec3,
    /// The last focusing vertex it left before landing.
    from: Vec3,
    /// Its flux (mean over its wavelengths), on a common scale over all photons.
    power: f32,
    /// The surface around its focusing vertex, where that was its only one and reflected
    /// it: finds the glint that lights a shading point near where it landed.
    glint: Option<GlintPatch>,
}

/// A glint gets a lobe of its own (`GlintLobe`) where its angular radius seen from the
/// shading point is under this fraction of the photons' cones there. Broader glints are
/// drawn better by the photons' spread: gold balls of roughness 0.2-0.3 (alpha 0.04-0.09,
/// everyday2 and gold3) lost 10-20% where glints up to the cones' width had lobes; chrome
/// balls of roughness 0.1 gain 1.5-1.7x (full) and 5-8x (bulk) (bench/README.md).
const GLINT_NARROWNESS: f32 = 0.2;

/// Probability that a vertex whose guide holds glint lobes alone samples its continuation
/// from them (0.35 is `GUIDE_SHARE`, for cones): a lobe finds its glint so often that a
/// smaller share leaves more continuations to the BSDF, 1.13x / 1.20x the efficiency (full
/// / bulk) on everyday4 at 64 spp (bench/README.md).
pub const GLINT_SHARE: f32 = 0.15;

/// Glint lobes in one guide at most (further photons get cones).
const MAX_GUIDE_GLINTS: usize = 2;

/// Newton iterations of the glint solve at most.
const GLINT_ITERATIONS: u32 = 8;

/// The surface of a focusing object around a photon's reflection, to second order: its
/// point, shading normal and their derivatives along two triangle edges. At a shading point
/// `x` near where the photon landed, Newton's method on the half-vector constraint (the
/// normal bisects the directions to `x` and to the light; Hanika et al. 2015, "Manifold Next
/// Event Estimation", for a single reflection) finds the part of the object whose glint
/// lights `x`, far more precisely than the direction to the photon's own vertex: a
/// near-mirror's glint is a few milliradians wide, the photons' spread about a tenth of a
/// radian.
#[derive(Clone, Copy, Debug)]
struct GlintPatch {
    p: Vec3,
    dp: [Vec3; 2],
    /// Unit, on the side the light comes from.
    n: Vec3,
    dn: [Vec3; 2],
    /// Where the light is: its position, or the direction towards it if `at_infinity`.
    light: Vec3,
    at_infinity: bool,
    /// Which light (glints of one light from one patch coincide).
    light_index: u32,
    /// The angle between the half-vector and the normal within which the glint shines: half
    /// the photon's blur (the light's angular radius plus 2 alpha).
    tolerance: f32,
    /// The tangent frame of `n`, in which residuals are measured.
    frame: Frame,
    /// The residual's derivatives along the edges (and their inverse) for a shading point
    /// where the photon landed: Newton's method near there keeps them (the chord method),
    /// one residual per step instead of three.
    jacobian: glam::Mat2,
    inverse: glam::Mat2,
}

impl GlintPatch {
    /// The patch's point at edge coordinates `ab`, its unit normal, and the half-vector
    /// constraint's residual there for the shading point `x` (tangent components of h - n in
    /// the frame of the photon's normal).
    fn residual(&self, x: Vec3, ab: Vec2) -> (Vec3, Vec3, Vec2) {
        let frame = &self.frame;
        let d = self.dp[0] * ab.x + self.dp[1] * ab.y;
        let dn = self.dn[0] * ab.x + self.dn[1] * ab.y;
        // The surface leaves its tangent plane by -(d . dn) / 2 along the normal (a sphere
        // of radius R: |d|^2 / 2R).
        let p = self.p + d - 0.5 * d.dot(dn) * self.n;
        let n = (self.n + dn).normalize_or(self.n);
        let to_light = if self.at_infinity {
            self.light
        } else {
            (self.light - p).normalize_or(self.n)
        };
        let h = ((x - p).normalize_or(self.n) + to_light).normalize_or(n);
        let e = h - n;
        (p, n, Vec2::new(e.dot(frame.s), e.dot(frame.t)))
    }

    /// The glint that lights `x`: its lobe and angular radius seen from `x` (of the
    /// residuals within the tolerance); None where Newton's method does not converge within
    /// `max_offset` of the photon's vertex (a fold of the caustic, a shading point the patch
    /// cannot light).
    fn solve(&self, x: Vec3, max_offset: f32) -> Option<(GlintLobe, f32)> {
        let mut ab = Vec2::ZERO;
        for _ in 0..GLINT_ITERATIONS {
            let (p, n, r) = self.residual(x, ab);
            if r.length() <= 0.1 * self.tolerance {
                let to_x = x - p;
                let distance = to_x.length();
                let to_light = if self.at_infinity {
                    self.light
                } else {
                    self.light - p
                };
                if !(distance > 0.0) || n.dot(to_x) <= 0.0 || n.dot(to_light) <= 0.0 {
                    return None;
                }
                // The glint: edge offsets within the tolerance of the constraint, mapped to
                // the world by the patch's edges; its largest radius is the top singular
                // value of that 3x2 map.
                let inverse = self.inverse;
                let w0 = self.dp[0] * inverse.x_axis.x + self.dp[1] * inverse.x_axis.y;
                let w1 = self.dp[0] * inverse.y_axis.x + self.dp[1] * inverse.y_axis.y;
                let (g00, g01, g11) = (w0.dot(w0), w0.dot(w1), w1.dot(w1));
                let trace = g00 + g11;
                let disc = ((g00 - g11) * (g00 - g11) + 4.0 * g01 * g01)
                    .max(0.0)
                    .sqrt();
                let sigma = (0.5 * (trace + disc)).sqrt();
                let radius = sigma * self.tolerance / distance;
                let lobe = GlintLobe::new(p, self.dp, self.jacobian, self.tolerance)?;
                return radius.is_finite().then_some((lobe, radius));
            }
            ab -= self.inverse * r;
            let offset = self.dp[0] * ab.x + self.dp[1] * ab.y;
            if !(offset.length_squared() <= max_offset * max_offset) {
                return None;
            }
        }
        None
    }

    /// The patch with its residual's derivatives for a shading point at `x` (by finite
    /// differences); None where they are singular (`x` on a fold of the caustic).
    fn landed_at(mut self, x: Vec3) -> Option<GlintPatch> {
        const STEP: f32 = 1e-3;
        let (_, _, r) = self.residual(x, Vec2::ZERO);
        let (_, _, ra) = self.residual(x, Vec2::X * STEP);
        let (_, _, rb) = self.residual(x, Vec2::Y * STEP);
        self.jacobian = glam::Mat2::from_cols((ra - r) / STEP, (rb - r) / STEP);
        let det = self.jacobian.determinant();
        if !(det.abs() > 1e-20) || !det.is_finite() {
            return None;
        }
        self.inverse = self.jacobian.inverse();
        self.inverse.is_finite().then_some(self)
    }
}

/// The photons of a scene in a hashed grid of cells twice `radius` wide (Teschner et al. 2003,
/// "Optimized Spatial Hashing for Collision Detection of Deformable Objects"): the ball of
/// `radius` around a shading point overlaps at most eight cells. Guides from the photons near
/// each cell's centre (a lookup per vertex instead of a gather) were cheaper but removed a
/// third less noise: everyday2 bulk efficiency 2.3-2.5 against 3.1.
pub struct CausticPhotons {
    /// Sorted by hash bucket.
    photons: Vec<Photon>,
    /// Photons of hash bucket b: `photons[bucket_start[b]..bucket_start[b + 1]]`.
    bucket_start: Vec<u32>,
    radius: f32,
    /// Bounds of the photons' positions, grown by `radius`: a shading point outside gathers
    /// nothing.
    bounds: (Vec3, Vec3),
}

/// The directions a shading point's continuations are guided to: cones around the
/// directions towards the focusing vertices of the photons near it, and lobes towards the
/// narrow glints solved from their patches.
#[derive(Clone, Copy, Debug)]
pub struct CausticGuide {
    /// The shading point (the glint lobes' apex).
    origin: Vec3,
    axes: [Vec3; MAX_GUIDE_CONES],
    /// 1 - cos of each cone's half-angle.
    one_minus_cos: [f32; MAX_GUIDE_CONES],
    cones: usize,
    glints: [GlintLobe; MAX_GUIDE_GLINTS],
    glint_count: usize,
    /// Cumulative probabilities of choosing each cone, then each glint (the last is 1).
    cdf: [f32; MAX_GUIDE_CONES + MAX_GUIDE_GLINTS],
    /// Probability that a continuation is sampled from the guide rather than the BSDF.
    pub share: f32,
}

/// The directions from a shading point towards a glint (the part of a near-mirror that
/// reflects a light towards it), as a density over the glint's tangent plane: a point `c +
/// e0 a + e1 b` there has the half-vector residual `r = J (a, b)` (`GlintPatch::solve`),
/// which follows GGX's distribution of slopes (`TrowbridgeReitz::slope_pdf`) of the alpha
/// that blurs the glint. Sampling draws `r`, maps it to
/// the plane and points there; the density of a direction intersects the plane and maps
/// back, so the two agree exactly whatever the plane's error as a model of the surface.
#[derive(Clone, Copy, Debug)]
pub struct GlintLobe {
    center: Vec3,
    edges: [Vec3; 2],
    /// The plane's dual basis: `(q . dual[0], q . dual[1])` are the edge coordinates of an
    /// offset `q` within it.
    dual: [Vec3; 2],
    /// Unit normal of the plane.
    normal: Vec3,
    residual_per_edge: glam::Mat2,
    edge_per_residual: glam::Mat2,
    /// |det J| / |e0 x e1|: residual-plane area per tangent-plane area.
    area_scale: f32,
    slopes: TrowbridgeReitz,
}

impl GlintLobe {
    /// The lobe of a glint at `center` on the plane of `edges`, whose residual per edge
    /// coordinate is `jacobian`, blurred by GGX slopes of `alpha`; None where degenerate.
    pub fn new(
        center: Vec3,
        edges: [Vec3; 2],
        jacobian: glam::Mat2,
        alpha: f32,
    ) -> Option<GlintLobe> {
        let cross = edges[0].cross(edges[1]);
        let cross_len2 = cross.length_squared();
        let det = jacobian.determinant();
        if !(cross_len2 > 0.0) || !(det.abs() > 0.0) || !(alpha > 0.0) {
            return None;
        }
        let lobe = GlintLobe {
            center,
            edges,
            dual: [
                edges[1].cross(cross) / cross_len2,
                cross.cross(edges[0]) / cross_len2,
            ],
            normal: cross / cross_len2.sqrt(),
            residual_per_edge: jacobian,
            edge_per_residual: jacobian.inverse(),
            area_scale: det.abs() / cross_len2.sqrt(),
            slopes: TrowbridgeReitz::isotropic(alpha),
        };
        let finite = lobe.dual.iter().all(|d| d.is_finite())
            && lobe.edge_per_residual.is_finite()
            && lobe.area_scale.is_finite();
        finite.then_some(lobe)
    }

    /// A direction from `origin` towards the glint.
    fn sample(&self, origin: Vec3, u: Vec2) -> Vec3 {
        let ab = self.edge_per_residual * self.slopes.sample_slope(u);
        let point = self.center + self.edges[0] * ab.x + self.edges[1] * ab.y;
        (point - origin).normalize_or(self.normal)
    }

    /// The solid-angle density of `sample` at the unit direction `wi` from `origin`.
    fn pdf(&self, origin: Vec3, wi: Vec3) -> f32 {
        let cos = wi.dot(self.normal);
        let t = (self.center - origin).dot(self.normal) / cos;
        if !(t > 0.0) || !t.is_finite() {
            return 0.0;
        }
        let q = origin + wi * t - self.center;
        let ab = Vec2::new(q.dot(self.dual[0]), q.dot(self.dual[1]));
        let slope_density = self.slopes.slope_pdf(self.residual_per_edge * ab);
        // Residual plane -> tangent plane -> solid angle (dA = t^2 dw / |cos|).
        let density = slope_density * self.area_scale * t * t / cos.abs();
        if density.is_finite() {
            density
        } else {
            0.0
        }
    }
}

impl CausticGuide {
    /// A guide of the given cones: (axis, sine of the half-angle, weight), at most
    /// `MAX_GUIDE_CONES` (the rest are ignored); None without a cone of positive weight.
    pub fn from_cones(cones: &[(Vec3, f32, f32)], share: f32) -> Option<CausticGuide> {
        Self::from_parts(Vec3::ZERO, cones, &[], share)
    }

    /// A guide at `origin` of the given cones and glint lobes (each with its weight), at most
    /// `MAX_GUIDE_CONES` and `MAX_GUIDE_GLINTS` (the rest are ignored); None without any
    /// weight.
    pub fn from_parts(
        origin: Vec3,
        cones: &[(Vec3, f32, f32)],
        glints: &[(GlintLobe, f32)],
        share: f32,
    ) -> Option<CausticGuide> {
        let mut guide = CausticGuide::empty(origin, share);
        let mut total = 0.0;
        for &(axis, sin, weight) in cones.iter().take(MAX_GUIDE_CONES) {
            total += guide.push(axis.normalize(), sin, weight, total);
        }
        for &(lobe, weight) in glints.iter().take(MAX_GUIDE_GLINTS) {
            total += guide.push_glint(lobe, weight, total);
        }
        guide.finish(total)
    }

    fn empty(origin: Vec3, share: f32) -> CausticGuide {
        let none = GlintLobe {
            center: Vec3::ZERO,
            edges: [Vec3::ZERO; 2],
            dual: [Vec3::ZERO; 2],
            normal: Vec3::Z,
            residual_per_edge: glam::Mat2::IDENTITY,
            edge_per_residual: glam::Mat2::IDENTITY,
            area_scale: 0.0,
            slopes: TrowbridgeReitz::isotropic(1.0),
        };
        CausticGuide {
            origin,
            axes: [Vec3::Z; MAX_GUIDE_CONES],
            one_minus_cos: [0.0; MAX_GUIDE_CONES],
            cones: 0,
            glints: [none; MAX_GUIDE_GLINTS],
            glint_count: 0,
            cdf: [0.0; MAX_GUIDE_CONES + MAX_GUIDE_GLINTS],
            share,
        }
    }

    /// Components so far (cones, then glints).
    fn components(&self) -> usize {
        self.cones + self.glint_count
    }

    /// Appends a cone (before any glint); returns its weight (for the running `total`
    /// before it).
    fn push(&mut self, axis: Vec3, sin: f32, weight: f32, total: f32) -> f32 {
        debug_assert_eq!(self.glint_count, 0);
        let k = self.cones;
        self.axes[k] = axis;
        // 1 - cos = sin^2 / (1 + cos).
        self.one_minus_cos[k] = sin * sin / (1.0 + (1.0 - sin * sin).max(0.0).sqrt());
        self.cdf[k] = total + weight;
        self.cones += 1;
        weight
    }

    /// Appends a glint lobe; returns its weight.
    fn push_glint(&mut self, lobe: GlintLobe, weight: f32, total: f32) -> f32 {
        self.glints[self.glint_count] = lobe;
        self.cdf[self.components()] = total + weight;
        self.glint_count += 1;
        weight
    }

    /// Normalises the component probabilities: None without any weight.
    fn finish(mut self, total: f32) -> Option<CausticGuide> {
        let n = self.components();
        if n == 0 || !(total > 0.0) {
            return None;
        }
        for c in &mut self.cdf[..n] {
            *c /= total;
        }
        self.cdf[n - 1] = 1.0;
        Some(self)
    }

    /// Samples a direction (world space) from the guide: a component chosen by `uc`, a
    /// direction within it from `u`.
    pub fn sample(&self, uc: f32, u: Vec2) -> Vec3 {
        let n = self.components();
        let i = self.cdf[..n].iter().position(|&c| uc < c).unwrap_or(n - 1);
        if i >= self.cones {
            return self.glints[i - self.cones].sample(self.origin, u);
        }
        let local = sample_uniform_cone_one_minus_cos(u, self.one_minus_cos[i]);
        Frame::from_normal(self.axes[i]).to_world(local)
    }

    /// The one-sample mixture's density (Veach 1997, 9.2.4) of a direction whose density is
    /// `bsdf_pdf` under the BSDF (one value, or one per wavelength) and `guide_pdf` under the
    /// guide (`pdf`).
    #[inline]
    pub fn mixture_pdf<P>(&self, bsdf_pdf: P, guide_pdf: f32) -> P
    where
        P: std::ops::Mul<f32, Output = P> + std::ops::Add<f32, Output = P>,
    {
        bsdf_pdf * (1.0 - self.share) + self.share * guide_pdf
    }

    /// The solid-angle density with which `sample` produces the unit world direction `wi`.
    pub fn pdf(&self, wi: Vec3) -> f32 {
        let mut previous = 0.0;
        let mut density = 0.0;
        for i in 0..self.components() {
            let p = self.cdf[i] - previous;
            previous = self.cdf[i];
            if i >= self.cones {
                density += p * self.glints[i - self.cones].pdf(self.origin, wi);
                continue;
            }
            // 1 - cos of the angle to the axis, as |wi - axis|^2 / 2 (exact for thin cones).
            if (wi - self.axes[i]).length_squared() * 0.5 <= self.one_minus_cos[i] {
                density += p * uniform_cone_pdf_one_minus_cos(self.one_minus_cos[i]);
            }
        }
        density
    }
}

impl CausticPhotons {
    /// Traces the scene's caustic photons for glints of at most `max_blur` (radians,
    /// `MAX_GLINT_BLUR` or `MAX_UNPLANNED_GLINT_BLUR`), or None when nothing in it focuses
    /// light or no photon lands. Deterministic for a seed, whatever the thread count.
    pub fn trace(scene: &Scene, seed: u64, max_blur: f32) -> Option<CausticPhotons> {
        let focusing = FocusingSurfaces::find(scene)?;
        let batch = |b: u32| {
            let mut out = Vec::new();
            for i in b * 1024..((b + 1) * 1024).min(PHOTON_PATHS) {
                let mut rng = Pcg32::new(i as u64, 0xca05_71c5, seed);
                trace_photon(scene, &focusing, max_blur, &mut rng, &mut out);
            }
            out
        };
        // The first batches tell whether any light makes a glint photons can guide to (where
        // none does, as in scenes lit by area lights alone, the rest is not traced).
        let first = 4.min(PHOTON_PATHS.div_ceil(1024));
        let mut photons: Vec<Photon> = (0..first).into_par_iter().flat_map_iter(batch).collect();
        if photons.is_empty() {
            return None;
        }
        photons.par_extend(
            (first..PHOTON_PATHS.div_ceil(1024))
                .into_par_iter()
                .flat_map_iter(batch),
        );
        Some(Self::from_photons(photons, focusing.radius))
    }

    fn from_photons(mut photons: Vec<Photon>, radius: f32) -> CausticPhotons {
        let buckets = photons.len().next_power_of_two();
        let cell = |p: Vec3| (p / (2.0 * radius)).floor().as_ivec3();
        let bucket = |c: glam::IVec3| bucket_of(c, buckets);
        // A stable sort: photons keep their (deterministic) order within a bucket.
        photons.sort_by_key(|ph| bucket(cell(ph.p)));
        let mut bucket_start = vec![0u32; buckets + 1];
        for ph in &photons {
            bucket_start[bucket(cell(ph.p)) + 1] += 1;
        }
        for b in 0..buckets {
            bucket_start[b + 1] += bucket_start[b];
        }
        let (lo, hi) = photons.iter().fold(
            (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
            |(lo, hi), ph| (lo.min(ph.p), hi.max(ph.p)),
        );
        CausticPhotons {
            photons,
            bucket_start,
            radius,
            bounds: (lo - radius, hi + radius),
        }
    }

    /// Photons stored that carry a glint patch (`GlintPatch`).
    pub fn glint_photons(&self) -> usize {
        self.photons.iter().filter(|ph| ph.glint.is_some()).count()
    }

    /// Photons stored.
    pub fn len(&self) -> usize {
        self.photons.len()
    }

    pub fn is_empty(&self) -> bool {
        self.photons.is_empty()
    }

    /// The guide at a shading point `p` that receives light on the side of `n` (unit): cones
    /// towards the focusing vertices of the first `MAX_GUIDE_CONES` photons found within
    /// `radius` of it whose focusing vertex lies on that side, each as wide as `radius` seen
    /// from `p`; None without any.
    pub fn guide(&self, p: Vec3, n: Vec3) -> Option<CausticGuide> {
        let (lo, hi) = self.bounds;
        if p.cmplt(lo).any() || p.cmpgt(hi).any() {
            return None;
        }
        // The photons found.
        let mut found = [None; MAX_GUIDE_CONES];
        let mut count = 0;
        let r2 = self.radius * self.radius;
        let buckets = self.bucket_start.len() - 1;
        let cell_size = 2.0 * self.radius;
        let lo = ((p - self.radius) / cell_size).floor().as_ivec3();
        // At most two cells per axis (rounding could make it three).
        let hi = ((p + self.radius) / cell_size)
            .floor()
            .as_ivec3()
            .min(lo.saturating_add(glam::IVec3::ONE));
        let mut seen = [usize::MAX; 8];
        let mut cells = 0;
        'cells: for z in lo.z..=hi.z {
            for y in lo.y..=hi.y {
                for x in lo.x..=hi.x {
                    let b = bucket_of(glam::IVec3::new(x, y, z), buckets);
                    // Two cells in one bucket: gather it once.
                    if seen[..cells].contains(&b) {
                        continue;
                    }
                    seen[cells] = b;
                    cells += 1;
                    let range = self.bucket_start[b] as usize..self.bucket_start[b + 1] as usize;
                    for ph in &self.photons[range] {
                        if (ph.p - p).length_squared() > r2 {
                            continue;
                        }
                        if (ph.from - p).dot(n) <= 0.0 {
                            continue;
                        }
                        found[count] = Some(ph);
                        count += 1;
                        if count == MAX_GUIDE_CONES {
                            break 'cells;
                        }
                    }
                }
            }
        }
        // Cones towards the photons' vertices, as wide as the gathering radius seen from `p`:
        // the photons' spread draws a broad glint's shape. A glint much narrower than that (a
        // near-mirror's) is solved from a photon's patch and gets a lobe of its own, which
        // the other photons near it for the same light add their power to.
        let mut cones = [(Vec3::Z, 0.0f32, 0.0f32); MAX_GUIDE_CONES];
        let mut cone_count = 0;
        let mut lobes = [None; MAX_GUIDE_GLINTS];
        let mut lobe_count = 0;
        // Glints solved: where, for which light, and their lobe (None: broad, or failed).
        let mut glints = [(Vec3::ZERO, u32::MAX, None); MAX_GUIDE_CONES];
        let mut glint_count = 0;
        for ph in found[..count].iter().flatten() {
            let to = ph.from - p;
            let d = to.length();
            if !(d > 0.0) {
                continue;
            }
            let photon_sin = (self.radius / d).clamp(MIN_CONE_SIN, MAX_CONE_SIN);
            if let Some(patch) = &ph.glint {
                let known = glints[..glint_count].iter().find(|(at, light, _)| {
                    *light == patch.light_index && (*at - ph.from).length_squared() <= r2
                });
                let lobe = match known {
                    Some(&(_, _, lobe)) => lobe,
                    None => {
                        let glint = patch.solve(p, 2.0 * self.radius);
                        let lobe = glint.and_then(|(lobe, angle)| {
                            (angle < GLINT_NARROWNESS * photon_sin && lobe_count < MAX_GUIDE_GLINTS)
                                .then(|| {
                                    lobes[lobe_count] = Some((lobe, 0.0));
                                    lobe_count += 1;
                                    lobe_count - 1
                                })
                        });
                        // (Where the solve failed, the photons near this one need not try.)
                        let at = glint.map_or(ph.from, |(lobe, _)| lobe.center);
                        glints[glint_count] = (at, patch.light_index, lobe);
                        glint_count += 1;
                        lobe
                    }
                };
                if let Some(Some((_, weight))) = lobe.map(|k| lobes[k].as_mut()) {
                    *weight += ph.power;
                    continue;
                }
            }
            cones[cone_count] = (to / d, photon_sin, ph.power);
            cone_count += 1;
        }
        // A glint lobe points at its glint precisely: a smaller share finds it as often.
        let share = if cone_count == 0 {
            GLINT_SHARE
        } else {
            GUIDE_SHARE
        };
        let mut guide = CausticGuide::empty(p, share);
        let mut total = 0.0f32;
        for &(axis, sin, power) in &cones[..cone_count] {
            total += guide.push(axis, sin, power, total);
        }
        for &(lobe, power) in lobes.iter().flatten() {
            total += guide.push_glint(lobe, power, total);
        }
        guide.finish(total)
    }
}

fn bucket_of(c: glam::IVec3, buckets: usize) -> usize {
    let h = (c.x as u32).wrapping_mul(73_856_093)
        ^ (c.y as u32).wrapping_mul(19_349_663)
        ^ (c.z as u32).wrapping_mul(83_492_791);
    (crate::sampler::hash32(h) as usize) & (buckets - 1)
}

/// The triangles of the instances whose material focuses light, by world area.
struct FocusingSurfaces {
    triangles: Vec<(u32, u32)>,
    by_area: DiscreteDistribution,
    area: f32,
    /// The gathering radius: a fifth of the focusing objects' size, the radius of a sphere of
    /// an object's area averaged over their area (a tenth removed less noise from everyday2's
    /// floor, 0.3 no more). Per object, so that many small objects do not gather as widely as
    /// one object of their total area would.
    radius: f32,
}

impl FocusingSurfaces {
    fn find(scene: &Scene) -> Option<FocusingSurfaces> {
        let geometry = &scene.geometry;
        let w = SampledWavelengths::sample_hero(0.5, WavelengthPdf::Visible);
        let mut triangles = Vec::new();
        let mut areas = Vec::new();
        // Sum over the focusing instances of area x the radius of a sphere of that area.
        let mut area_radius = 0.0f32;
        for (index, inst) in geometry.instances.iter().enumerate() {
            let index = index as u32;
            let mesh = &geometry.meshes[inst.mesh as usize];
            if inst.light_only || !inst.casts_shadows || mesh.triangle_count() == 0 {
                continue;
            }
            // The material at the first triangle's centre stands for the instance's (a
            // texture may vary it; each photon checks where it lands).
            let sp = geometry.surface_point_at(index, 0, 1.0 / 3.0, 1.0 / 3.0, 0.5);
            let Some(shaded) = shade(scene, &sp, sp.ns, &w) else {
                continue;
            };
            if !shaded.bsdf.focuses_light() {
                continue;
            }
            let mut instance_area = 0.0f32;
            for prim in 0..mesh.triangle_count() as u32 {
                let [a, b, c] = geometry.world_triangle(index, prim, 0.5);
                let area = 0.5 * (b - a).cross(c - a).length();
                if area > 0.0 && area.is_finite() {
                    triangles.push((index, prim));
                    areas.push(area);
                    instance_area += area;
                }
            }
            area_radius += instance_area * sphere_radius(instance_area);
        }
        let area: f32 = areas.iter().sum();
        if triangles.is_empty() || !(area > 0.0) {
            return None;
        }
        Some(FocusingSurfaces {
            triangles,
            by_area: DiscreteDistribution::new(&areas),
            area,
            radius: 0.2 * area_radius / area,
        })
    }
}

/// A surface point's BSDF for light arriving from `towards_light` (unit, world space).
struct Shaded {
    bsdf: Bsdf,
    frame: Frame,
    /// The geometric normal, turned to the light's side for surfaces that only reflect.
    ng: Vec3,
}

fn shade(
    scene: &Scene,
    sp: &SurfacePoint,
    towards_light: Vec3,
    w: &SampledWavelengths,
) -> Option<Shaded> {
    let geometry = &scene.geometry;
    let material = &scene.materials[sp.material as usize];
    let mut sp = *sp;
    material.apply_normal_map(geometry, &scene.textures, &mut sp, Some(towards_light));
    let inputs = material.graph_inputs(geometry, &sp, towards_light, false);
    let (bsdf, subsurface) = material.scattering(inputs.as_ref(), w, 0.5, false);
    if subsurface.is_some() {
        return None;
    }
    let (ns, ng) = if !bsdf.has_transmission() && sp.ng.dot(towards_light) < 0.0 {
        (-sp.ns, -sp.ng)
    } else {
        (sp.ns, sp.ng)
    };
    let frame = Frame::from_normal_tangent(ns, sp.dpdu);
    let bsdf = bsdf.at_view(frame.to_local(towards_light));
    Some(Shaded { bsdf, frame, ng })
}

/// One photon path: a point on the focusing surfaces by area, light to it by next-event
/// estimation (every light sample a photon of its own), then BSDF samples through focusing
/// surfaces until it lands on one that does not focus light, where it is stored.
fn trace_photon(
    scene: &Scene,
    focusing: &FocusingSurfaces,
    max_blur: f32,
    rng: &mut Pcg32,
    out: &mut Vec<Photon>,
) {
    let geometry = &scene.geometry;
    let (k, _, _) = focusing.by_area.sample(rng.next_1d());
    let (instance, prim) = focusing.triangles[k];
    // Uniform on the triangle.
    let (b0, b1) = sample_uniform_triangle(rng.next_2d());
    let b2 = 1.0 - b0 - b1;
    let time = 0.5;
    let start = geometry.surface_point_at(instance, prim, b1, b2, time);
    let w = SampledWavelengths::sample_hero(rng.next_1d(), WavelengthPdf::Visible);
    let ctx = ShadingContext {
        p: start.p,
        n: None,
        time,
    };
    let (u_select, u_light) = (rng.next_1d(), rng.next_2d());
    let samples = scene.lights.sample(
        geometry,
        &scene.materials,
        &ctx,
        u_select,
        u_light,
        &w,
        LightSelection::Tree,
    );
    for ls in samples.into_iter().flatten() {
        if !(ls.pdf > 0.0) || ls.li.is_black() {
            continue;
        }
        // The light's angular radius, which with each focusing vertex's spread (about 2
        // alpha) makes the blur of the glint the photon stands for.
        let Some(light_radius) =
            scene
                .lights
                .angular_radius(ls.light, &ctx, ls.pdf, LightSelection::Tree)
        else {
            continue;
        };
        let Some(shaded) = shade(scene, &start, ls.wi, &w) else {
            continue;
        };
        let Some(alpha) = shaded.bsdf.focusing_alpha() else {
            continue;
        };
        let mut blur = light_radius + 2.0 * alpha;
        let origin = offset_ray_origin(start.p, toward(start.ng, ls.wi), ls.wi);
        if geometry.occluded(&Ray::new_at(origin, ls.wi, time), ls.distance) {
            continue;
        }
        // Flux arriving at the point: Li |cos| / (p_light p_area).
        let cos = ls.wi.dot(start.ng).abs();
        let mut beta = ls.li * (cos * focusing.area / ls.pdf);
        let mut point = start;
        let mut shaded = shaded;
        let mut towards_light = ls.wi;
        // Whether the path so far is one reflection at `start`.
        let mut single_reflection = true;
        for bounce in 0..MAX_FOCUSING_BOUNCES {
            let wo = shaded.frame.to_local(towards_light);
            let Some(bs) = shaded.bsdf.sample(wo, rng.next_1d(), rng.next_2d()) else {
                break;
            };
            let dir = shaded.frame.to_world(bs.wi);
            let crosses = dir.dot(shaded.ng) * towards_light.dot(shaded.ng) < 0.0;
            if crosses != bs.is_transmission() {
                break;
            }
            single_reflection &= bounce == 0 && !crosses;
            beta *= bs.f * (bs.wi.z.abs() / bs.pdf);
            if !beta.is_finite() || beta.is_black() {
                break;
            }
            let ray = Ray::new_at(offset_ray_origin(point.p, shaded.ng, dir), dir, time);
            let Some(hit): Option<Hit> = geometry.intersect(&ray, f32::INFINITY) else {
                break;
            };
            let next = geometry.surface_point(&hit);
            let Some(next_shaded) = shade(scene, &next, -dir, &w) else {
                break;
            };
            let Some(alpha) = next_shaded.bsdf.focusing_alpha() else {
                if blur > max_blur {
                    break;
                }
                let glint = single_reflection.then(|| {
                    let at_infinity = !ls.distance.is_finite();
                    let light = if at_infinity {
                        ls.wi
                    } else {
                        start.p + ls.wi * ls.distance
                    };
                    let tolerance = 0.5 * blur;
                    glint_patch(geometry, &start, (light, at_infinity), ls.light, tolerance)
                });
                // A glint as broad as the photons' cones where this one landed is drawn by
                // the photons' spread: solving it at every shading point would buy nothing.
                let glint = glint.flatten().and_then(|patch| patch.landed_at(next.p));
                let glint = glint.filter(|patch| {
                    let d = (next.p - start.p).length();
                    let photon_sin = (focusing.radius / d).clamp(MIN_CONE_SIN, MAX_CONE_SIN);
                    patch
                        .solve(next.p, 2.0 * focusing.radius)
                        .is_some_and(|(_, angle)| angle < GLINT_NARROWNESS * photon_sin)
                });
                out.push(Photon {
                    p: next.p,
                    from: point.p,
                    power: beta.average() / PHOTON_PATHS as f32,
                    glint,
                });
                break;
            };
            blur += 2.0 * alpha;
            point = next;
            shaded = next_shaded;
            towards_light = -dir;
        }
    }
}

/// The patch around `sp` (a focusing vertex lit by the light at `light`: a position, or a
/// unit direction for a light at infinity); None where its normal does not face the light.
fn glint_patch(
    geometry: &crate::geometry::Geometry,
    sp: &SurfacePoint,
    (light, at_infinity): (Vec3, bool),
    light_index: usize,
    tolerance: f32,
) -> Option<GlintPatch> {
    let to_light = if at_infinity { light } else { light - sp.p };
    // The interpolated normal is linear in the barycentrics before normalisation: the
    // derivatives over half an edge are those of the normalised normal to first order.
    const STEP: f32 = 0.5;
    let at = |b1: f32, b2: f32| geometry.surface_point_at(sp.instance, sp.prim, b1, b2, sp.time);
    let (a, b) = (at(sp.b1 + STEP, sp.b2), at(sp.b1, sp.b2 + STEP));
    let side = if sp.ns_smooth.dot(to_light) < 0.0 {
        -1.0
    } else {
        1.0
    };
    let patch = GlintPatch {
        p: sp.p,
        dp: [(a.p - sp.p) / STEP, (b.p - sp.p) / STEP],
        n: side * sp.ns_smooth,
        dn: [
            side * (a.ns_smooth - sp.ns_smooth) / STEP,
            side * (b.ns_smooth - sp.ns_smooth) / STEP,
        ],
        light,
        at_infinity,
        light_index: light_index as u32,
        tolerance,
        frame: Frame::from_normal(side * sp.ns_smooth),
        jacobian: glam::Mat2::IDENTITY,
        inverse: glam::Mat2::IDENTITY,
    };
    let finite = patch.dp.iter().chain(&patch.dn).all(|v| v.is_finite());
    (finite && patch.n.dot(to_light) > 0.0 && tolerance > 0.0).then_some(patch)
}

/// The radius of a sphere of surface area `area`.
fn sphere_radius(area: f32) -> f32 {
    (area / (4.0 * std::f32::consts::PI)).sqrt()
}

/// `n` or `-n`, whichever is on the side of `dir` (for offsetting a ray along it).
fn toward(n: Vec3, dir: Vec3) -> Vec3 {
    if n.dot(dir) < 0.0 {
        -n
    } else {
        n
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A patch of the sphere of `radius` about `center` at its point of unit normal `n`,
    /// with edges of 0.05 (a triangle of a finely tessellated sphere), lit from `light` (a
    /// direction) and landed at `x`.
    fn sphere_patch(center: Vec3, radius: f32, n: Vec3, light: Vec3, x: Vec3) -> GlintPatch {
        let frame = Frame::from_normal(n);
        // Edges that are not orthogonal, as a triangle's.
        let dp = [frame.s * 0.05, (frame.s * 0.4 + frame.t) * 0.05];
        GlintPatch {
            p: center + n * radius,
            dp,
            n,
            // A sphere's normal turns by the offset over the radius.
            dn: dp.map(|d| d / radius),
            light,
            at_infinity: true,
            light_index: 0,
            tolerance: 0.012,
            frame,
            jacobian: glam::Mat2::IDENTITY,
            inverse: glam::Mat2::IDENTITY,
        }
        .landed_at(x)
        .unwrap()
    }

    #[test]
    fn a_glint_solved_on_a_sphere_obeys_the_law_of_reflection() {
        let (center, radius) = (Vec3::new(0.0, 0.0, 0.5), 0.5);
        let light = Vec3::new(-1.0, -0.3, 0.8).normalize();
        // The point whose mirror reflection of the light leaves down and away from it.
        let n0 = (light + Vec3::new(0.8, 0.2, -0.4).normalize()).normalize();
        // Where the mirror reflection at n0 meets the floor z = 0.
        let out = (2.0 * light.dot(n0) * n0 - light).normalize();
        let y0 = center + n0 * radius;
        assert!(out.z < 0.0);
        let landed = y0 + out * (-y0.z / out.z);
        let patch = sphere_patch(center, radius, n0, light, landed);
        for offset in [
            Vec3::ZERO,
            Vec3::new(0.06, 0.03, 0.0),
            Vec3::new(-0.04, 0.07, 0.0),
        ] {
            let x = landed + offset;
            let (lobe, angle) = patch.solve(x, 0.2).expect("a glint");
            let y = lobe.center;
            // On the sphere (the second-order model's error is |offset|^3 / R^2).
            assert!(((y - center).length() - radius).abs() < 1e-4, "{y}");
            // The true normal there bisects the directions to x and to the light, within a
            // small fraction of the glint's tolerance.
            let normal = (y - center).normalize();
            let h = ((x - y).normalize() + light).normalize();
            let error = h.cross(normal).length();
            assert!(error < 0.1 * patch.tolerance, "{offset}: {error}");
            // The glint's angular radius: about the tolerance times the radius over the
            // distance (the normal turns by the offset over the radius).
            let expected = patch.tolerance * radius / (x - y).length();
            assert!(
                angle > 0.3 * expected && angle < 3.0 * expected,
                "{angle} against {expected}"
            );
        }
        // Under the sphere, where its reflection of the light cannot reach: no glint.
        assert!(patch.solve(Vec3::new(0.0, 0.0, -0.2), 0.2).is_none());
    }
}
