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
//! part of the focusing object that lights `x`.
//!
//! The guide only shapes a sampling density: the continuation's direction comes from the
//! BSDF with probability `1 - GUIDE_SHARE` and from the guide's cones otherwise, weighted by
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

/// The deepest vertex (0: the camera ray's hit) whose continuations are guided: caustics seen
/// directly and after one bounce. Guiding every bounce cost 10% more time on everyday2 for no
/// less noise (efficiency 3.2 / 2.8 against 3.4 / 2.9, full / bulk).
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
/// directions towards the focusing vertices of the photons near it.
#[derive(Clone, Copy, Debug)]
pub struct CausticGuide {
    axes: [Vec3; MAX_GUIDE_CONES],
    /// 1 - cos of each cone's half-angle.
    one_minus_cos: [f32; MAX_GUIDE_CONES],
    /// Cumulative probabilities of choosing each cone (the last is 1).
    cdf: [f32; MAX_GUIDE_CONES],
    count: usize,
    /// Probability that a continuation is sampled from the guide rather than the BSDF.
    pub share: f32,
}

impl CausticGuide {
    /// A guide of the given cones: (axis, sine of the half-angle, weight), at most
    /// `MAX_GUIDE_CONES` (the rest are ignored); None without a cone of positive weight.
    pub fn from_cones(cones: &[(Vec3, f32, f32)], share: f32) -> Option<CausticGuide> {
        let mut guide = CausticGuide::empty(share);
        let mut total = 0.0;
        for &(axis, sin, weight) in cones.iter().take(MAX_GUIDE_CONES) {
            total += guide.push(axis.normalize(), sin, weight, total);
        }
        guide.finish(total)
    }

    fn empty(share: f32) -> CausticGuide {
        CausticGuide {
            axes: [Vec3::Z; MAX_GUIDE_CONES],
            one_minus_cos: [0.0; MAX_GUIDE_CONES],
            cdf: [0.0; MAX_GUIDE_CONES],
            count: 0,
            share,
        }
    }

    /// Appends a cone; returns its weight (for the running `total` before it).
    fn push(&mut self, axis: Vec3, sin: f32, weight: f32, total: f32) -> f32 {
        let k = self.count;
        self.axes[k] = axis;
        // 1 - cos = sin^2 / (1 + cos).
        self.one_minus_cos[k] = sin * sin / (1.0 + (1.0 - sin * sin).max(0.0).sqrt());
        self.cdf[k] = total + weight;
        self.count += 1;
        weight
    }

    /// Normalises the cone probabilities: None without any weight.
    fn finish(mut self, total: f32) -> Option<CausticGuide> {
        if self.count == 0 || !(total > 0.0) {
            return None;
        }
        for c in &mut self.cdf[..self.count] {
            *c /= total;
        }
        self.cdf[self.count - 1] = 1.0;
        Some(self)
    }

    /// Samples a direction (world space) from the guide: a cone chosen by `uc`, a uniform
    /// direction within it from `u`.
    pub fn sample(&self, uc: f32, u: Vec2) -> Vec3 {
        let i = self.cdf[..self.count]
            .iter()
            .position(|&c| uc < c)
            .unwrap_or(self.count - 1);
        let local = sample_uniform_cone_one_minus_cos(u, self.one_minus_cos[i]);
        Frame::from_normal(self.axes[i]).to_world(local)
    }

    /// The solid-angle density with which `sample` produces the unit world direction `wi`.
    pub fn pdf(&self, wi: Vec3) -> f32 {
        let mut previous = 0.0;
        let mut density = 0.0;
        for i in 0..self.count {
            let p = self.cdf[i] - previous;
            previous = self.cdf[i];
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
        // The photons found: direction to the focusing vertex, its distance, power.
        let mut found = [(Vec3::ZERO, 0.0f32, 0.0f32); MAX_GUIDE_CONES];
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
                        let to = ph.from - p;
                        let d = to.length();
                        if !(d > 0.0) || to.dot(n) <= 0.0 {
                            continue;
                        }
                        found[count] = (to / d, d, ph.power);
                        count += 1;
                        if count == MAX_GUIDE_CONES {
                            break 'cells;
                        }
                    }
                }
            }
        }
        let mut guide = CausticGuide::empty(GUIDE_SHARE);
        let mut total = 0.0f32;
        for &(axis, d, power) in &found[..count] {
            let sin = (self.radius / d).clamp(MIN_CONE_SIN, MAX_CONE_SIN);
            total += guide.push(axis, sin, power, total);
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
        for _ in 0..MAX_FOCUSING_BOUNCES {
            let wo = shaded.frame.to_local(towards_light);
            let Some(bs) = shaded.bsdf.sample(wo, rng.next_1d(), rng.next_2d()) else {
                break;
            };
            let dir = shaded.frame.to_world(bs.wi);
            let crosses = dir.dot(shaded.ng) * towards_light.dot(shaded.ng) < 0.0;
            if crosses != bs.is_transmission() {
                break;
            }
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
                out.push(Photon {
                    p: next.p,
                    from: point.p,
                    power: beta.average() / PHOTON_PATHS as f32,
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
