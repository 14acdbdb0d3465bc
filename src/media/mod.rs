//! Participating media: homogeneous volumes inside closed meshes (Blender's Principled Volume,
//! Volume Absorption and Volume Scatter; glTF's KHR_materials_volume absorption).
//!
//! A path keeps a [`MediumStack`] of the volumes it is inside, updated where it crosses the
//! boundary of a material that has one (as Cycles' volume stack), so volumes may nest and
//! overlap: the coefficients of every enclosing volume add up ([`SegmentMedium`]). Along a ray
//! segment the integrator adds the volume's emission analytically, then samples a free-flight
//! distance with the hero wavelength's extinction (pbrt-v4's spectral MIS for media: the other
//! wavelengths carry the ratio of their densities, `integrator::spectral_mis`). Absorbing-only
//! media are not sampled: their transmittance multiplies the path.
//!
//! The random-walk subsurface medium is a medium behind a dielectric with its own estimator
//! (`crate::bssrdf::random_walk`); it shares the phase function (`phase`).

pub mod grid;
pub mod phase;

use crate::scene::desc::VolumeDesc;
use crate::spectrum::{
    RgbAlbedoSpectrum, RgbIlluminantSpectrum, SampledSpectrum, SampledWavelengths,
};
pub use grid::MajorantGrid;
pub use phase::{PhaseMixture, MAX_MEDIA};

/// An extinction-like coefficient spectrum (per unit length) from linear RGB.
///
/// Upsampling the coefficient itself as a smooth spectrum and exponentiating per wavelength
/// does not give back the RGB renderer's per-channel exp(-sigma d): the red channel of
/// sigma = (0.12, 0.72, 0.96) came out 0.89x of it through 1.6 units and 0.68x through 4,
/// because exp is taken of a spectrum that the colour-matching functions then mix across the
/// channels. Instead the transmittance over a reference length L, exp(-sigma L), is upsampled
/// as a reflectance (which reproduces its RGB, as glTF's attenuation colour at attenuation
/// distance defines a medium) and sigma(lambda) = -ln t(lambda) / L, with L one mean free path
/// of the channels' mean coefficient (scale-free, and t in a well-conditioned range). Red
/// channel against per-channel RGB for that sigma through 0.5 / 1.6 / 4 units: 1.02 / 1.00 /
/// 0.88 (L = 1 / max sigma: 1.01 / 0.96 / 0.80); a spectral renderer cannot match an RGB one at
/// every depth.
#[derive(Clone, Debug)]
pub struct CoefficientSpectrum {
    transmittance: RgbAlbedoSpectrum,
    length: f32,
    zero: bool,
}

impl CoefficientSpectrum {
    pub fn new(sigma: glam::Vec3) -> Self {
        let sigma = sigma.max(glam::Vec3::ZERO);
        let peak = sigma.max_element();
        let length = if peak > 0.0 {
            3.0 / (sigma.x + sigma.y + sigma.z)
        } else {
            1.0
        };
        CoefficientSpectrum {
            transmittance: RgbAlbedoSpectrum::new((-sigma * length).exp()),
            length,
            zero: !(peak > 0.0),
        }
    }

    /// The coefficient whose transmittance over `length` is the colour `t` (glTF's
    /// attenuation colour at attenuation distance): sigma(lambda) = -ln t(lambda) / length.
    pub fn from_transmittance(t: glam::Vec3, length: f32) -> Self {
        let t = t.clamp(glam::Vec3::ZERO, glam::Vec3::ONE);
        CoefficientSpectrum {
            transmittance: RgbAlbedoSpectrum::new(t),
            length,
            zero: t.min_element() >= 1.0,
        }
    }

    pub fn sample(&self, w: &SampledWavelengths) -> SampledSpectrum {
        if self.zero {
            return SampledSpectrum::ZERO;
        }
        let t = self.transmittance.sample(w);
        SampledSpectrum::from_fn(|k| -t[k].clamp(1e-12, 1.0).ln() / self.length)
    }
}

/// A density that varies inside the volume: a shading graph's `volume_density` output
/// multiplying the coefficients (emission excepted, as in Cycles' Principled Volume), bounded by
/// `majorant` (estimated when the scene is built: `scene::build`; larger values are clamped to
/// it, which no sampled point of the volume's box reached). A graph that drives `volume_color`
/// (with or without a density) makes the coefficients vary with that colour too.
#[derive(Clone, Debug)]
pub struct DensityField {
    pub graph: std::sync::Arc<crate::shading::ShadingGraph>,
    pub majorant: f32,
    /// Local bounds per instance of the volume (`grid`), from `scene::build`.
    pub grids: Vec<(u32, std::sync::Arc<MajorantGrid>)>,
}

/// A volume: coefficients per scene unit, upsampled from linear RGB, constant or times a
/// density field.
#[derive(Clone, Debug)]
pub struct Medium {
    sigma_a: CoefficientSpectrum,
    sigma_s: CoefficientSpectrum,
    /// Henyey-Greenstein anisotropy.
    g: f32,
    /// Emitted radiance per unit length.
    emission: Option<RgbIlluminantSpectrum>,
    emission_rgb: glam::Vec3,
    scatters: bool,
    density: Option<DensityField>,
    /// (sigma_a, sigma_s) where the field's colour is black (`VolumeDesc::color_zero`; black
    /// coefficients when the description has none); `sigma_a`, `sigma_s` hold where it is white.
    /// Only homogeneous media and fields that drive the colour keep it (`with_density`).
    color_zero: Option<(CoefficientSpectrum, CoefficientSpectrum)>,
}

/// A heterogeneous volume's field at one point: the density and, where the graph drives the
/// volume's colour, that colour at the path's wavelengths (in [0, 1]).
#[derive(Clone, Copy, Debug)]
pub struct FieldPoint {
    pub density: f32,
    pub color: Option<SampledSpectrum>,
}

impl FieldPoint {
    /// Density 1, no colour: a volume without a field.
    pub const UNIT: FieldPoint = FieldPoint {
        density: 1.0,
        color: None,
    };

    /// The same point with its density at most `cap` (a majorant run's bound).
    #[inline]
    pub fn capped(self, cap: f32) -> FieldPoint {
        FieldPoint {
            density: self.density.min(cap),
            ..self
        }
    }
}

impl Medium {
    pub fn new(desc: &VolumeDesc) -> Self {
        Medium {
            sigma_a: CoefficientSpectrum::new(desc.sigma_a),
            sigma_s: CoefficientSpectrum::new(desc.sigma_s),
            g: desc.g.clamp(-0.99, 0.99),
            emission: (desc.emission.max_element() > 0.0)
                .then(|| RgbIlluminantSpectrum::new(desc.emission)),
            emission_rgb: desc.emission.max(glam::Vec3::ZERO),
            scatters: desc.sigma_s.max_element() > 0.0,
            density: None,
            color_zero: None,
        }
        .with_color_zero(desc.color_zero)
    }

    /// Coefficients (sigma_a, sigma_s) where a field's colour is black (see `color_zero`).
    fn with_color_zero(mut self, zero: Option<(glam::Vec3, glam::Vec3)>) -> Self {
        let (a, s) = zero.unwrap_or((glam::Vec3::ZERO, glam::Vec3::ZERO));
        self.scatters |= s.max_element() > 0.0;
        self.color_zero = Some((CoefficientSpectrum::new(a), CoefficientSpectrum::new(s)));
        self
    }

    /// Absorption only, the medium of coloured glass: glTF's KHR_materials_volume, light keeps
    /// `color` over `distance`.
    pub fn attenuation(color: glam::Vec3, distance: f32) -> Self {
        Medium {
            sigma_a: CoefficientSpectrum::from_transmittance(color, distance),
            ..Self::new(&VolumeDesc::default())
        }
    }

    pub fn scatters(&self) -> bool {
        self.scatters
    }

    /// Makes the coefficients vary with `field`'s density (and colour, if its graph drives
    /// `volume_color`: otherwise the black end is dropped, so segments need not ask).
    pub fn with_density(mut self, field: DensityField) -> Self {
        if !field
            .graph
            .drives(crate::shading::MaterialInput::VolumeColor)
        {
            self.color_zero = None;
        }
        self.density = Some(field);
        self
    }

    pub fn density(&self) -> Option<&DensityField> {
        self.density.as_ref()
    }

    /// Sets the bounds of the density field: global and per instance (no-op without one).
    pub fn set_bounds(&mut self, majorant: f32, grids: Vec<(u32, std::sync::Arc<MajorantGrid>)>) {
        if let Some(d) = &mut self.density {
            d.majorant = majorant;
            d.grids = grids;
        }
    }

    /// The emitted radiance per unit length as linear RGB (black when it does not emit).
    pub fn emitted_rgb(&self) -> glam::Vec3 {
        self.emission_rgb
    }
}

/// Bound on the tentative collisions of one tracked segment (a safety net).
pub const MAX_TRACKING_STEPS: u32 = 100_000;

/// One volume the path is inside: the instance whose boundary it crossed and its material.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MediumEntry {
    pub instance: u32,
    pub material: u32,
}

/// The volumes enclosing a point (at most [`MAX_MEDIA`]; deeper nesting ignores the innermost
/// ones). Entering a volume already on the stack (a second shell of the same object) does not
/// add it twice; leaving removes it wherever it is (overlapping volumes need not nest).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct MediumStack {
    entries: [MediumEntry; MAX_MEDIA],
    len: u8,
}

impl MediumStack {
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    pub fn entries(&self) -> &[MediumEntry] {
        &self.entries[..self.len as usize]
    }

    pub fn enter(&mut self, e: MediumEntry) {
        let n = self.len as usize;
        if n < MAX_MEDIA && !self.entries[..n].contains(&e) {
            self.entries[n] = e;
            self.len += 1;
        }
    }

    pub fn leave(&mut self, e: MediumEntry) {
        let n = self.len as usize;
        if let Some(i) = self.entries[..n].iter().position(|x| *x == e) {
            self.entries.copy_within(i + 1..n, i);
            self.len -= 1;
        }
    }

    /// A boundary of `e`'s volume crossed, into it when `entering`.
    pub fn cross(&mut self, e: MediumEntry, entering: bool) {
        if entering {
            self.enter(e)
        } else {
            self.leave(e)
        }
    }
}

/// The optical coefficients along a ray segment at the path's wavelengths: the sums over the
/// enclosing volumes.
#[derive(Clone, Copy, Debug)]
pub struct SegmentMedium<'m> {
    /// The homogeneous volumes' sums (the heterogeneous ones are in `varying`).
    pub sigma_s: SampledSpectrum,
    pub sigma_t: SampledSpectrum,
    /// Every enclosing volume's emission (constant: not scaled by a density).
    pub emission: SampledSpectrum,
    /// The homogeneous volumes' phase function; `None` when they do not scatter.
    pub phase: Option<PhaseMixture>,
    /// The homogeneous volumes' HG lobes `(g, mean sigma_s)`.
    lobes: [(f32, f32); MAX_MEDIA],
    n_lobes: usize,
    /// Volumes with a density field: their coefficients at density 1 and the field's bound.
    varying: [Option<VaryingPart>; MAX_MEDIA],
    /// sigma_t's majorant: `sigma_t` plus every varying part's at its bound.
    pub majorant: SampledSpectrum,
    /// With exactly one heterogeneous volume that has a majorant grid: the grid, its
    /// instance's world-to-object transform and the part's index in `varying`.
    grid: Option<(&'m MajorantGrid, glam::Affine3A, usize)>,
}

/// A heterogeneous volume on a segment.
#[derive(Clone, Copy, Debug)]
pub struct VaryingPart {
    pub entry: MediumEntry,
    /// The coefficients at density 1 (and where a varying colour is white).
    sigma_s: SampledSpectrum,
    sigma_t: SampledSpectrum,
    /// Where the field drives the colour: the coefficients at density 1 where it is black.
    color_zero: Option<(SampledSpectrum, SampledSpectrum)>,
    /// Bound of sigma_t at density 1 over every colour: a colour c in [0, 1] mixes the two
    /// ends per wavelength, c sigma_t + (1 - c) sigma_t0 <= max(sigma_t, sigma_t0).
    sigma_t_bound: SampledSpectrum,
    g: f32,
    max_density: f32,
}

/// The coefficients at one point of a segment (heterogeneous volumes evaluated there).
#[derive(Clone, Copy, Debug)]
pub struct PointCoefficients {
    pub sigma_s: SampledSpectrum,
    pub sigma_t: SampledSpectrum,
    pub phase: Option<PhaseMixture>,
}

/// A free-flight distance sampled with the hero wavelength (slot 0).
#[derive(Clone, Copy, Debug)]
pub struct DistanceSample {
    /// Distance along the segment (the segment's end when the flight passed it).
    pub t: f32,
    /// The flight ended inside the medium: a scattering event at `t`.
    pub scattered: bool,
    /// Contribution over the hero's density, per wavelength: sigma_s T(t) / p_0 at a scattering
    /// event, T(d) / p_0 past the segment.
    pub weight: SampledSpectrum,
    /// The hero's density of this outcome and every wavelength's (for the spectral MIS).
    pub pdf_hero: f32,
    pub pdf_wavelengths: SampledSpectrum,
}

impl<'m> SegmentMedium<'m> {
    /// The sum of the volumes on `stack` (`medium_of` gives a material's medium,
    /// `world_to_object` an instance's inverse transform), or `None` when the stack is empty or
    /// the volumes neither absorb, scatter nor emit.
    pub fn collect(
        stack: &MediumStack,
        medium_of: impl Fn(u32) -> Option<&'m Medium>,
        world_to_object: impl Fn(u32) -> glam::Affine3A,
        w: &SampledWavelengths,
    ) -> Option<Self> {
        if stack.is_empty() {
            return None;
        }
        let mut sigma_a = SampledSpectrum::ZERO;
        let mut sigma_s = SampledSpectrum::ZERO;
        let mut emission = SampledSpectrum::ZERO;
        let mut lobes = [(0.0f32, 0.0f32); MAX_MEDIA];
        let mut n_lobes = 0;
        let mut varying = [None; MAX_MEDIA];
        let mut majorant = SampledSpectrum::ZERO;
        let mut grids = 0;
        let mut grid = None;
        for (i, e) in stack.entries().iter().enumerate() {
            let Some(m) = medium_of(e.material) else {
                continue;
            };
            if let Some(em) = &m.emission {
                emission += em.sample(w);
            }
            let a = m.sigma_a.sample(w);
            let s = if m.scatters {
                m.sigma_s.sample(w)
            } else {
                SampledSpectrum::ZERO
            };
            if let Some(field) = &m.density {
                let color_zero = m.color_zero.as_ref().map(|(a0, s0)| {
                    let s0 = s0.sample(w);
                    (s0, a0.sample(w) + s0)
                });
                let sigma_t_bound = match color_zero {
                    Some((_, t0)) => SampledSpectrum::from_fn(|k| (a + s)[k].max(t0[k])),
                    None => a + s,
                };
                varying[i] = Some(VaryingPart {
                    entry: *e,
                    sigma_s: s,
                    sigma_t: a + s,
                    color_zero,
                    sigma_t_bound,
                    g: m.g,
                    max_density: field.majorant,
                });
                majorant += sigma_t_bound * field.majorant;
                grids += 1;
                grid = field
                    .grids
                    .iter()
                    .find(|(inst, _)| *inst == e.instance)
                    .map(|(_, g)| (&**g, world_to_object(e.instance), i));
                continue;
            }
            sigma_a += a;
            if m.scatters {
                sigma_s += s;
                // Overlapping volumes: each lobe weighted by its share of sigma_s averaged over
                // the path's wavelengths (exact for one volume or equal colours).
                lobes[n_lobes] = (m.g, s.average());
                n_lobes += 1;
            }
        }
        let sigma_t = sigma_a + sigma_s;
        majorant += sigma_t;
        if majorant.is_black() && emission.is_black() {
            return None;
        }
        Some(SegmentMedium {
            sigma_s,
            sigma_t,
            emission,
            phase: PhaseMixture::new(&lobes[..n_lobes]).filter(|_| !sigma_s.is_black()),
            lobes,
            n_lobes,
            varying,
            majorant,
            grid: grid.filter(|_| grids == 1),
        })
    }

    /// The runs of constant majorant along `[0, t_end)` of the ray (`origin`, `dir`): `(t0,
    /// t1, sigma_maj, cap)` where `cap` bounds the heterogeneous density in the run. One run
    /// with the global majorant unless a majorant grid applies.
    pub fn majorant_runs(
        &self,
        origin: glam::Vec3,
        dir: glam::Vec3,
        t_end: f32,
    ) -> impl Iterator<Item = (f32, f32, SampledSpectrum, f32)> + '_ {
        let (grid_runs, single) = match self.grid {
            Some((g, m, part)) => {
                let unit = self.varying[part].map_or(SampledSpectrum::ZERO, |v| v.sigma_t_bound);
                let runs = g
                    .runs(&m, origin, dir, t_end)
                    .map(move |(t0, t1, bound)| (t0, t1, self.sigma_t + unit * bound, bound));
                (Some(runs), None)
            }
            None => (None, Some((0.0, t_end, self.majorant, f32::INFINITY))),
        };
        grid_runs.into_iter().flatten().chain(single)
    }

    /// Some volume on the segment has a density field: flights need delta tracking
    /// (`PathTracer`) and transmittance ratio tracking ([`SegmentMedium::ratio_tracking`]).
    pub fn is_heterogeneous(&self) -> bool {
        self.varying.iter().any(Option::is_some)
    }

    /// Something on the segment can scatter.
    pub fn may_scatter(&self) -> bool {
        self.phase.is_some()
            || self.varying.iter().flatten().any(|v| {
                let s0 = v.color_zero.map_or(SampledSpectrum::ZERO, |(s0, _)| s0);
                !(v.sigma_s.is_black() && s0.is_black()) && v.max_density > 0.0
            })
    }

    /// The coefficients at a point, `field(entry)` giving each heterogeneous volume's density
    /// there (clamped to its bound) and its colour where the graph drives it.
    pub fn at(&self, mut field: impl FnMut(&MediumEntry) -> FieldPoint) -> PointCoefficients {
        let (mut sigma_s, mut sigma_t) = (self.sigma_s, self.sigma_t);
        let mut lobes = self.lobes;
        let mut n = self.n_lobes;
        for v in self.varying.iter().flatten() {
            let point = field(&v.entry);
            let d = point.density.clamp(0.0, v.max_density);
            if d > 0.0 {
                // Cycles' volume closures are linear in their colour per channel; here per
                // wavelength, with the colour upsampled as a reflectance.
                let (s, t) = match (v.color_zero, point.color) {
                    (Some((s0, t0)), Some(c)) => {
                        let one_minus = SampledSpectrum::ONE - c;
                        (
                            v.sigma_s * c + s0 * one_minus,
                            v.sigma_t * c + t0 * one_minus,
                        )
                    }
                    _ => (v.sigma_s, v.sigma_t),
                };
                sigma_s += s * d;
                sigma_t += t * d;
                if !s.is_black() && n < MAX_MEDIA {
                    lobes[n] = (v.g, s.average() * d);
                    n += 1;
                }
            }
        }
        PointCoefficients {
            sigma_s,
            sigma_t,
            phase: PhaseMixture::new(&lobes[..n]).filter(|_| !sigma_s.is_black()),
        }
    }

    /// An unbiased estimate of the transmittance over [0, `d`] (finite) for every wavelength:
    /// ratio tracking (Novak et al. 2014) with tentative points at the hero's majorant rate;
    /// each point multiplies wavelength k by T_maj,k sigma_n,k / (T_maj,0 sigma_maj,0) and the
    /// end by T_maj,k / T_maj,0, whose expectation is exp(-integral of sigma_t,k) for every k.
    /// `u` gives uniform numbers, `field(entry, t)` the fields at distance t.
    pub fn ratio_tracking(
        &self,
        origin: glam::Vec3,
        dir: glam::Vec3,
        d: f32,
        mut u: impl FnMut() -> f32,
        mut field: impl FnMut(&MediumEntry, f32) -> FieldPoint,
    ) -> SampledSpectrum {
        if !d.is_finite() {
            return self.transmittance(d);
        }
        let mut tr = SampledSpectrum::ONE;
        let mut steps = 0;
        for (t0, t1, sigma_maj, cap) in self.majorant_runs(origin, dir, d) {
            let m0 = sigma_maj[0];
            let mut t = t0;
            loop {
                if !(m0 > 0.0) {
                    tr *= transmittance(sigma_maj, t1 - t);
                    break;
                }
                let step = -(1.0 - u()).ln() / m0;
                if t + step >= t1 {
                    let rest = t1 - t;
                    tr *= transmittance(sigma_maj, rest) / (-m0 * rest).exp();
                    break;
                }
                t += step;
                steps += 1;
                if steps > MAX_TRACKING_STEPS {
                    return SampledSpectrum::ZERO;
                }
                let p = self.at(|e| field(e, t).capped(cap));
                let sigma_n = (sigma_maj - p.sigma_t).clamp_zero();
                tr *= transmittance(sigma_maj, step) * sigma_n / ((-m0 * step).exp() * m0);
                if tr.max_component() < 1e-4 {
                    // Russian roulette on a nearly opaque estimate.
                    if u() < 0.5 {
                        return SampledSpectrum::ZERO;
                    }
                    tr *= 2.0;
                }
            }
        }
        tr
    }

    /// Transmittance exp(-sigma_t d) (Beer-Lambert); 0 over an infinite distance unless
    /// sigma_t is 0.
    pub fn transmittance(&self, d: f32) -> SampledSpectrum {
        transmittance(self.sigma_t, d)
    }

    /// The emission seen along the segment: the integral of T(t) sigma_e over [0, d], in closed
    /// form for a homogeneous medium, sigma_e (1 - exp(-sigma_t d)) / sigma_t.
    pub fn emitted(&self, d: f32) -> SampledSpectrum {
        if self.emission.is_black() {
            return SampledSpectrum::ZERO;
        }
        let e = SampledSpectrum::from_fn(|k| {
            let st = self.sigma_t[k];
            if st > 0.0 {
                -(-st * d).exp_m1() / st * self.emission[k]
            } else {
                d * self.emission[k]
            }
        });
        // An emitting, non-extinguishing volume seen over an infinite distance (open mesh).
        if e.is_finite() {
            e
        } else {
            SampledSpectrum::ZERO
        }
    }

    /// Samples where the flight along a segment of length `d_max` (may be infinite) ends,
    /// with density sigma_t0 exp(-sigma_t0 t) of the hero's extinction.
    pub fn sample_distance(&self, d_max: f32, u: f32) -> DistanceSample {
        let st0 = self.sigma_t[0];
        let t = if st0 > 0.0 {
            -(1.0 - u).ln() / st0
        } else {
            f32::INFINITY
        };
        if t < d_max {
            let tr = self.transmittance(t);
            let pdf_wavelengths = self.sigma_t * tr;
            let pdf_hero = pdf_wavelengths[0];
            DistanceSample {
                t,
                scattered: true,
                weight: (self.sigma_s * tr) / pdf_hero,
                pdf_hero,
                pdf_wavelengths,
            }
        } else {
            let tr = self.transmittance(d_max);
            let pdf_hero = tr[0];
            DistanceSample {
                t: d_max,
                scattered: false,
                weight: if pdf_hero > 0.0 {
                    tr / pdf_hero
                } else {
                    SampledSpectrum::ZERO
                },
                pdf_hero,
                pdf_wavelengths: tr,
            }
        }
    }
}

/// exp(-sigma_t d) per wavelength, with exp(-0 * inf) = 1.
pub fn transmittance(sigma_t: SampledSpectrum, d: f32) -> SampledSpectrum {
    SampledSpectrum::from_fn(|k| {
        if sigma_t[k] > 0.0 {
            (-sigma_t[k] * d).exp()
        } else {
            1.0
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::spectrum::WavelengthPdf;
    use glam::Vec3;

    fn medium(sigma_a: Vec3, sigma_s: Vec3, emission: Vec3) -> Medium {
        Medium::new(&VolumeDesc {
            sigma_a,
            sigma_s,
            g: 0.3,
            emission,
            ..Default::default()
        })
    }

    #[test]
    fn stack_enters_once_and_leaves_out_of_order() {
        let a = MediumEntry {
            instance: 1,
            material: 2,
        };
        let b = MediumEntry {
            instance: 3,
            material: 2,
        };
        let mut s = MediumStack::default();
        s.enter(a);
        s.enter(a);
        s.enter(b);
        assert_eq!(s.entries(), &[a, b]);
        s.leave(a);
        assert_eq!(s.entries(), &[b]);
        s.leave(a);
        s.cross(b, false);
        assert!(s.is_empty());
    }

    #[test]
    fn coefficients_add_and_the_flight_is_unbiased() {
        let w = SampledWavelengths::sample_hero(0.31, WavelengthPdf::Visible);
        let fog = medium(
            Vec3::new(0.2, 0.1, 0.05),
            Vec3::new(0.5, 0.7, 0.9),
            Vec3::ZERO,
        );
        let glow = medium(Vec3::splat(0.1), Vec3::ZERO, Vec3::new(1.0, 0.5, 0.2));
        let media = [fog, glow];
        let mut stack = MediumStack::default();
        for m in 0..2 {
            stack.enter(MediumEntry {
                instance: m,
                material: m,
            });
        }
        let seg = SegmentMedium::collect(
            &stack,
            |m| media.get(m as usize),
            |_| glam::Affine3A::IDENTITY,
            &w,
        )
        .unwrap();
        let single = SegmentMedium::collect(
            &MediumStack {
                entries: [MediumEntry::default(); MAX_MEDIA],
                len: 1,
            },
            |m| media.get(m as usize),
            |_| glam::Affine3A::IDENTITY,
            &w,
        )
        .unwrap();
        assert!(seg.sigma_t[1] > single.sigma_t[1]);
        assert_eq!(seg.sigma_s, single.sigma_s);
        // E[weight over passing flights] = T(d) for every wavelength, and the scattering
        // outcomes integrate sigma_s T over [0, d]: (sigma_s / sigma_t)(1 - T(d)).
        let d = 1.7;
        let n = 200_000;
        let (mut pass, mut scatter) = (SampledSpectrum::ZERO, SampledSpectrum::ZERO);
        for i in 0..n {
            let s = seg.sample_distance(d, (i as f32 + 0.5) / n as f32);
            if s.scattered {
                assert!(s.t < d);
                scatter += s.weight;
            } else {
                pass += s.weight;
            }
        }
        let t = seg.transmittance(d);
        for k in 0..4 {
            let p = pass[k] / n as f32;
            let sc = scatter[k] / n as f32;
            let sc_expected = seg.sigma_s[k] / seg.sigma_t[k] * (1.0 - t[k]);
            assert!(
                (p - t[k]).abs() < 2e-3 * t[k].max(0.1),
                "{k}: {p} vs {}",
                t[k]
            );
            assert!(
                (sc - sc_expected).abs() < 3e-3,
                "{k}: {sc} vs {sc_expected}"
            );
        }
        // Emission: sigma_e (1 - T) / sigma_t, and sigma_e d without extinction.
        let e = seg.emitted(d);
        for k in 0..4 {
            let expected = seg.emission[k] * (1.0 - t[k]) / seg.sigma_t[k];
            assert!((e[k] - expected).abs() < 1e-5 * expected.max(1.0));
        }
        let clear = SegmentMedium {
            sigma_t: SampledSpectrum::ZERO,
            ..seg
        };
        assert!((clear.emitted(2.0)[0] - 2.0 * seg.emission[0]).abs() < 1e-5);
        assert_eq!(clear.emitted(f32::INFINITY), SampledSpectrum::ZERO);
        assert_eq!(transmittance(SampledSpectrum::ZERO, f32::INFINITY)[0], 1.0);
    }
}
