//! Bidirectional scattering distribution functions, evaluated per sampled wavelength.
//!
//! Conventions (shared by every lobe): directions are unit vectors in the local shading frame
//! (normal = +z); `wo` points away from the surface towards the previous vertex (the camera side),
//! `wi` towards the next one (the light side). `eval` returns f(wo, wi) WITHOUT the cosine
//! factor; `sample` returns f and the solid-angle pdf of `wi`. Radiance transport only (the
//! 1/eta^2 factor for refraction is included).

pub mod coat;
pub mod dielectric;
pub mod diffuse;
pub mod energy;
pub mod fibre_sheen;
pub mod fresnel;
pub mod metallic_roughness;
pub mod microfacet;
pub mod sheen;
pub mod thin_film;

pub use coat::Coat;
pub use fresnel::{fresnel_dielectric, fresnel_schlick, refract};
pub use metallic_roughness::ViewTerms;
pub use microfacet::TrowbridgeReitz;
pub use sheen::{Sheen, SheenModel};
pub use thin_film::ThinFilm;

use crate::spectrum::SampledSpectrum;
use glam::{Vec2, Vec3};

/// What kind of scattering a lobe does (pbrt-v4's `BxDFFlags`): the side (reflection,
/// transmission) and the kind of lobe (diffuse, glossy, or specular, i.e. Dirac). A sample has
/// one side and one kind; `Bsdf::flags` is the union over the lobes a BSDF may sample.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub struct LobeFlags(u8);

impl LobeFlags {
    pub const REFLECTION: LobeFlags = LobeFlags(1);
    pub const TRANSMISSION: LobeFlags = LobeFlags(2);
    pub const DIFFUSE: LobeFlags = LobeFlags(4);
    pub const GLOSSY: LobeFlags = LobeFlags(8);
    /// A Dirac lobe: `f / pdf` is the weight, light sampling cannot reach its directions.
    pub const SPECULAR: LobeFlags = LobeFlags(16);
    /// Scattering in a volume (a phase function), for lights' Volume Scatter visibility.
    pub const VOLUME: LobeFlags = LobeFlags(32);

    /// The union.
    #[inline]
    pub const fn with(self, other: LobeFlags) -> LobeFlags {
        LobeFlags(self.0 | other.0)
    }

    /// Every flag of `other` is set.
    #[inline]
    pub const fn contains(self, other: LobeFlags) -> bool {
        self.0 & other.0 == other.0
    }

    /// The side and kind of a sample.
    #[inline]
    pub const fn sample(transmission: bool, specular: bool) -> LobeFlags {
        let side = if transmission {
            LobeFlags::TRANSMISSION
        } else {
            LobeFlags::REFLECTION
        };
        side.with(if specular {
            LobeFlags::SPECULAR
        } else {
            LobeFlags::GLOSSY
        })
    }
}

/// Which kinds of scattering see a light (Blender's Object > Visibility > Ray Visibility of a
/// light: Diffuse, Glossy, Transmission), as Cycles honours them: a light a kind does not see
/// gives that kind's lobes no direct light and its sampled rays no emission. Volume scattering
/// and subsurface exits see every light.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RayVisibility {
    pub diffuse: bool,
    pub glossy: bool,
    pub transmission: bool,
    /// Scattering in volumes (Blender's Volume Scatter).
    pub volume: bool,
}

impl RayVisibility {
    pub const ALL: RayVisibility = RayVisibility {
        diffuse: true,
        glossy: true,
        transmission: true,
        volume: true,
    };

    pub fn is_all(&self) -> bool {
        *self == RayVisibility::ALL
    }

    /// Whether a path whose last scattering was a lobe of `flags` sees the light: a volume's
    /// phase function is Volume Scatter, glossy and specular transmission Transmission, other
    /// diffuse lobes (diffuse reflection and translucency) Diffuse, the rest Glossy.
    pub fn sees(&self, flags: LobeFlags) -> bool {
        if flags.contains(LobeFlags::VOLUME) {
            self.volume
        } else if flags.contains(LobeFlags::DIFFUSE) {
            self.diffuse
        } else if flags.contains(LobeFlags::TRANSMISSION) {
            self.transmission
        } else {
            self.glossy
        }
    }
}

impl Default for RayVisibility {
    fn default() -> Self {
        RayVisibility::ALL
    }
}

/// The GGX alphas of metals that focus light into caustics (`Bsdf::focuses_light`).
pub const FOCUSING_ALPHA: std::ops::RangeInclusive<f32> = 0.01..=0.1;

/// The GGX alphas of glass that focuses light into caustics: down to Principled roughness
/// 0.03. Light refracted through a glass object lands in a caustic spread over a broad part of
/// it (a ball is a lens), so photons point at it where a near-mirror's glint is too small:
/// with balls of roughness 0.05-0.5 under a small lamp (glass3, bench/README.md), guiding the
/// floor's caustics of the sharpest ball halved the floor's noise. Smooth glass stays out
/// (the photons would reach it as well): in the Cornell box the pilot's estimate for its
/// smooth ball, 0.62 of the image's variance, turned guiding on at 0.63x the efficiency.
pub const FOCUSING_GLASS_ALPHA: std::ops::RangeInclusive<f32> = 0.001..=0.1;

/// Result of sampling a direction from a BSDF.
#[derive(Clone, Copy, Debug)]
pub struct BsdfSample {
    pub wi: Vec3,
    /// f(wo, wi), no cosine.
    pub f: SampledSpectrum,
    /// Solid-angle density of `wi` (for a specular lobe: the discrete probability of choosing it).
    pub pdf: f32,
    /// The lobe that produced `wi`: reflection or transmission (`wi` on the other side of the
    /// surface from `wo`), and diffuse, glossy or specular.
    pub flags: LobeFlags,
    /// Per wavelength, the relative IOR `n(wi side) / n(wo side)` of the interface crossed by
    /// a transmission (1 for reflection and for interfaces without refraction): what the path
    /// tracer needs for the radiance scale of refraction (Veach 1997, sec. 5.2).
    pub eta: SampledSpectrum,
    /// The density with which each wavelength, had it been the hero, would have produced `wi`
    /// (slot 0 equals `pdf`). All slots are equal unless the BSDF is dispersive. A slot is 0
    /// where `wi` is unreachable for that wavelength (smooth dispersive refraction), and `f`
    /// is 0 there too. The path tracer's hero-wavelength MIS weights use these
    /// (`integrator::spectral_mis`).
    pub pdf_wavelengths: SampledSpectrum,
}

impl BsdfSample {
    /// A Dirac lobe was chosen.
    #[inline]
    pub fn is_specular(&self) -> bool {
        self.flags.contains(LobeFlags::SPECULAR)
    }

    /// `wi` is on the other side of the surface from `wo`.
    #[inline]
    pub fn is_transmission(&self) -> bool {
        self.flags.contains(LobeFlags::TRANSMISSION)
    }

    /// Only the hero wavelength can follow `wi` (the secondaries' path density is zero).
    pub fn hero_only(&self) -> bool {
        self.pdf_wavelengths.0[1..].iter().all(|&p| p == 0.0)
    }
}

/// The set of surface models. An enum rather than trait objects: a handful of lobes, built per
/// shading point on the stack, no allocation.
#[derive(Clone, Copy, Debug)]
pub enum Bsdf {
    Diffuse(DiffuseBsdf),
    MetallicRoughness(MetallicRoughnessBsdf),
    Dielectric(DielectricBsdf),
    Translucent(TranslucentBsdf),
}

/// Lambertian transmission (Blender's Translucent BSDF): light leaves on the other side.
#[derive(Clone, Copy, Debug)]
pub struct TranslucentBsdf {
    pub transmittance: SampledSpectrum,
}

/// Lambertian reflection.
#[derive(Clone, Copy, Debug)]
pub struct DiffuseBsdf {
    pub reflectance: SampledSpectrum,
}

/// The glTF 2.0 metallic-roughness BRDF (spec appendix B) with KHR_materials_specular:
/// `mix(dielectric_brdf, conductor_brdf, metallic)` where the dielectric part is a GGX
/// specular layer over Lambertian diffuse weighted by a Schlick Fresnel with
/// f0 = min(((ior-1)/(ior+1))^2 * specular_color, 1) * specular and f90 = specular, and the
/// conductor is GGX with Schlick Fresnel f0 = base_color.
#[derive(Clone, Copy, Debug)]
pub struct MetallicRoughnessBsdf {
    pub base_color: SampledSpectrum,
    pub metallic: f32,
    /// GGX alpha = perceptual roughness^2 (clamped away from 0 for numerical safety).
    pub alpha: f32,
    pub specular: f32,
    pub specular_color: SampledSpectrum,
    pub ior: f32,
    /// Energy-conserving layers with multiple-scattering GGX (Cycles' Principled; see
    /// `metallic_roughness.rs`); false: the glTF 2.0 spec's BRDF as written.
    pub energy_compensation: bool,
    /// Blender 3.x's Principled BSDF as Cycles 3.x renders it (with `energy_compensation`
    /// off): a Disney diffuse base that the specular layer does not dim, and Cycles 3.x's
    /// Fresnel (`metallic_roughness.rs`, "Principled v1").
    pub principled_v1: bool,
    /// A clear coat over all of it (`coat.rs`; `Coat::NONE` for none).
    pub coat: Coat,
    /// A sheen over the coat and all below (`sheen.rs`; `Sheen::NONE` for none).
    pub sheen: Sheen,
    /// A thin film on the dielectric specular layer (`thin_film.rs`; metals ignore it).
    pub iridescence: Option<Iridescence>,
    /// The terms that depend on the view direction alone, for one `wo` (`Bsdf::at_view`):
    /// a shading point evaluates its BSDF once per light sample and samples it once, all
    /// from the same `wo`. None: computed per evaluation. Set last, after every parameter.
    pub view: Option<ViewTerms>,
}

/// Dielectric interface: smooth (alpha < 1e-3, or eta == 1: exact Fresnel, specular reflection
/// and refraction) or rough (Walter et al. 2007 GGX microfacet BRDF + BTDF). See `dielectric.rs`
/// for the dispersion rules (`eta[0]` decides directions).
#[derive(Clone, Copy, Debug)]
pub struct DielectricBsdf {
    /// Relative IOR (inside / outside) per wavelength; all equal for non-dispersive glass.
    pub eta: SampledSpectrum,
    pub alpha: f32,
    /// Multiplies transmitted light (glTF transmission tinted by baseColor); ONE for clear glass.
    pub transmission_tint: SampledSpectrum,
    /// A thin film on the interface (`thin_film.rs`), with the path's wavelengths.
    pub iridescence: Option<Iridescence>,
    /// Blender's Refraction BSDF: the refraction alone, as if the Fresnel reflectance were 0
    /// (Cycles' refraction closure carries no Fresnel term; node setups mix in a reflection by
    /// a Fresnel or Layer Weight factor). Total internal reflection is then absorbed.
    pub refraction_only: bool,
    /// A rough interface gets back the energy single scattering loses (Turquin 2019, see
    /// `energy.rs`). Not for `refraction_only`, whose missing reflection is meant to be lost.
    pub energy_compensation: bool,
}

/// A thin film on a dielectric interface at the path's wavelengths: its Fresnel becomes
/// `mix(plain, film, weight)` (`KHR_materials_iridescence`'s factor; Blender's Thin Film is 1).
#[derive(Clone, Copy, Debug)]
pub struct Iridescence {
    pub film: ThinFilm,
    pub weight: f32,
    /// The wavelengths (nm) of the spectrum's slots.
    pub lambda: SampledSpectrum,
    /// A filmed metallic-roughness layer's direction-independent terms, once computed
    /// (`MetallicRoughnessBsdf::with_film_averages`); None: computed per evaluation.
    pub averages: Option<FilmAverages>,
}

/// The terms of a filmed specular layer that do not depend on the directions
/// (`MetallicRoughnessBsdf::film_averages`): the hemispherical averages of the filmed
/// dielectric's and conductor's Fresnel.
#[derive(Clone, Copy, Debug)]
pub struct FilmAverages {
    pub dielectric_avg: SampledSpectrum,
    pub conductor_avg: SampledSpectrum,
}

impl Bsdf {
    /// Nothing scatters: the path is absorbed (a mixture's missing weight).
    pub fn black() -> Self {
        Bsdf::Diffuse(DiffuseBsdf {
            reflectance: SampledSpectrum::ZERO,
        })
    }

    /// f(wo, wi) without the cosine; zero for Dirac lobes (they cannot be evaluated).
    pub fn eval(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum {
        match self {
            Bsdf::Diffuse(b) => b.eval(wo, wi),
            Bsdf::MetallicRoughness(b) => b.eval(wo, wi),
            Bsdf::Dielectric(b) => b.eval(wo, wi),
            Bsdf::Translucent(b) => b.eval(wo, wi),
        }
    }

    /// Solid-angle density with which `sample` produces `wi` through its non-Dirac lobes
    /// (already multiplied by the probability of choosing those lobes). Zero for Dirac lobes.
    pub fn pdf(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self {
            Bsdf::Diffuse(b) => b.pdf(wo, wi),
            Bsdf::MetallicRoughness(b) => b.pdf(wo, wi),
            Bsdf::Dielectric(b) => b.pdf(wo, wi),
            Bsdf::Translucent(b) => b.pdf(wo, wi),
        }
    }

    /// The Lambertian (diffuse) component of `eval(wo, wi)`: all of it for `Diffuse`, the
    /// Fresnel-weighted base for `MetallicRoughness`, none for dielectrics. Normal-mapped
    /// surfaces scale this part by the bump-terminator shadowing, as Cycles does for its
    /// diffuse closures only (`crate::geometry::bump_terminator_shadowing`).
    pub fn diffuse_part(&self, wo: Vec3, wi: Vec3) -> SampledSpectrum {
        match self {
            Bsdf::Diffuse(b) => b.eval(wo, wi),
            Bsdf::MetallicRoughness(b) => b.diffuse_part(wo, wi),
            Bsdf::Dielectric(_) | Bsdf::Translucent(_) => SampledSpectrum::ZERO,
        }
    }

    /// The part of `f` = `eval(wo, wi)` that a light of ray visibility `vis` lights: diffuse
    /// reflection and translucency are Diffuse, the rest of the reflection Glossy, other
    /// transmission Transmission (as Cycles classifies its closures for light visibility).
    pub fn visible_part(
        &self,
        wo: Vec3,
        wi: Vec3,
        f: SampledSpectrum,
        vis: RayVisibility,
    ) -> SampledSpectrum {
        let keep = |on: bool, x: SampledSpectrum| if on { x } else { SampledSpectrum::ZERO };
        if wo.z * wi.z > 0.0 {
            let diffuse = self.diffuse_part(wo, wi);
            keep(vis.diffuse, diffuse) + keep(vis.glossy, (f - diffuse).clamp_zero())
        } else if matches!(self, Bsdf::Translucent(_)) {
            keep(vis.diffuse, f)
        } else {
            keep(vis.transmission, f)
        }
    }

    /// `(eval(wo, wi), pdf(wo, wi))` computed in one pass (what light sampling with MIS needs).
    pub fn eval_pdf(&self, wo: Vec3, wi: Vec3) -> (SampledSpectrum, f32) {
        match self {
            Bsdf::Diffuse(b) => b.eval_pdf(wo, wi),
            Bsdf::MetallicRoughness(b) => b.eval_pdf(wo, wi),
            Bsdf::Dielectric(b) => b.eval_pdf(wo, wi),
            Bsdf::Translucent(b) => b.eval_pdf(wo, wi),
        }
    }

    /// `eval(wo, wi)` and, per wavelength, the density with which `sample` would produce `wi`
    /// had that wavelength been the hero (see `BsdfSample::pdf_wavelengths`).
    pub fn eval_pdf_wavelengths(&self, wo: Vec3, wi: Vec3) -> (SampledSpectrum, SampledSpectrum) {
        match self {
            Bsdf::Dielectric(b) => b.eval_pdf_wavelengths(wo, wi),
            _ => {
                let (f, pdf) = self.eval_pdf(wo, wi);
                (f, SampledSpectrum::splat(pdf))
            }
        }
    }

    /// Samples `wi` given `wo`; `uc` chooses the lobe, `u` the direction. `None` when the
    /// sample carries no energy (direction below the surface, total absorption, degenerate
    /// input). For non-specular samples `f == eval(wo, wi)` and `pdf == pdf(wo, wi)`.
    pub fn sample(&self, wo: Vec3, uc: f32, u: Vec2) -> Option<BsdfSample> {
        let s = match self {
            Bsdf::Diffuse(b) => b.sample(wo, uc, u),
            Bsdf::MetallicRoughness(b) => b.sample(wo, uc, u),
            Bsdf::Dielectric(b) => b.sample(wo, uc, u),
            Bsdf::Translucent(b) => b.sample(wo, uc, u),
        }?;
        if s.pdf > 0.0 && s.pdf.is_finite() && s.f.is_finite() && s.wi.is_finite() {
            Some(s)
        } else {
            None
        }
    }

    /// The lobes this BSDF may sample (union of their flags).
    pub fn flags(&self) -> LobeFlags {
        let (r, t) = (LobeFlags::REFLECTION, LobeFlags::TRANSMISSION);
        let kind = |specular: bool| {
            if specular {
                LobeFlags::SPECULAR
            } else {
                LobeFlags::GLOSSY
            }
        };
        match self {
            Bsdf::Diffuse(_) => r.with(LobeFlags::DIFFUSE),
            Bsdf::Translucent(_) => t.with(LobeFlags::DIFFUSE),
            Bsdf::MetallicRoughness(b) => {
                let mut flags = r.with(kind(b.distribution().effectively_smooth()));
                if b.coat.is_present() {
                    flags = flags.with(kind(b.coat.is_smooth()));
                }
                if b.sheen.is_present() {
                    flags = flags.with(LobeFlags::GLOSSY);
                }
                if b.has_diffuse_base() {
                    flags = flags.with(LobeFlags::DIFFUSE);
                }
                flags
            }
            Bsdf::Dielectric(b) => r.with(t).with(kind(b.is_specular())),
        }
    }

    /// Purely Dirac: every sample is specular and `eval`/`pdf` are identically zero, so light
    /// sampling is pointless. (A BSDF may still return some specular samples while this is
    /// false, e.g. a smooth metallic-roughness surface with a diffuse part: check
    /// `BsdfSample::is_specular`.)
    pub fn is_specular(&self) -> bool {
        let f = self.flags();
        f.contains(LobeFlags::SPECULAR)
            && !f.contains(LobeFlags::DIFFUSE)
            && !f.contains(LobeFlags::GLOSSY)
    }

    /// Concentrates the light it redirects into caustics that photons can find
    /// (`integrator::caustics`): a metal whose microfacets are sharp but not mirror-like (GGX
    /// alpha in `FOCUSING_ALPHA`, Principled roughness 0.1-0.32) or a glass interface of
    /// roughness 0.03-0.32 (`FOCUSING_GLASS_ALPHA`). Plastics are left out (their specular
    /// layer reflects a few percent), and so are mirrors and smooth glass: the glint of a
    /// small light in a mirror is far smaller than what photons landing within a gathering
    /// radius can point at (the everyday scene's chrome ball of roughness 0.05 under the sun:
    /// 7x the bulk noise).
    pub fn focuses_light(&self) -> bool {
        self.focusing_alpha().is_some()
    }

    /// The GGX alpha of the lobe that focuses light (`focuses_light`), if one does.
    pub fn focusing_alpha(&self) -> Option<f32> {
        let range = match self {
            Bsdf::Dielectric(_) => &FOCUSING_GLASS_ALPHA,
            _ => &FOCUSING_ALPHA,
        };
        self.interface_alpha().filter(|alpha| range.contains(alpha))
    }

    /// Reflects like a mirror or a near-mirror: specular, or a metal or glass interface no
    /// rougher than those that focus light (`focuses_light`).
    pub fn is_sharp(&self) -> bool {
        self.is_specular()
            || self
                .interface_alpha()
                .is_some_and(|alpha| alpha <= *FOCUSING_ALPHA.end())
    }

    /// The GGX alpha of a metal's or a glass interface's microfacets.
    fn interface_alpha(&self) -> Option<f32> {
        match self {
            Bsdf::MetallicRoughness(b) if b.metallic >= 0.5 => Some(b.alpha),
            Bsdf::Dielectric(b) if !b.refraction_only => Some(b.alpha),
            _ => None,
        }
    }

    /// Reflects through a Lambertian lobe (which normal-mapped surfaces shade differently).
    pub fn has_diffuse_reflection(&self) -> bool {
        self.flags()
            .contains(LobeFlags::DIFFUSE.with(LobeFlags::REFLECTION))
    }

    /// The surface colour a denoiser's albedo guide expects (Cycles' "Denoising Albedo"):
    /// diffuse reflectance, base colour, or the glass tint.
    pub fn albedo(&self) -> SampledSpectrum {
        match self {
            Bsdf::Diffuse(b) => b.reflectance,
            Bsdf::MetallicRoughness(b) => b.base_color,
            Bsdf::Dielectric(b) => b.transmission_tint,
            Bsdf::Translucent(b) => b.transmittance,
        }
    }

    /// Its value or density differ between the path's wavelengths (a dispersive dielectric, a thin
    /// film): `eval_pdf_wavelengths` then costs one evaluation per wavelength.
    pub fn is_dispersive(&self) -> bool {
        matches!(self, Bsdf::Dielectric(d) if d.varies_per_wavelength())
    }

    /// f(wo, wi) of the hero wavelength alone (one evaluation even when dispersive).
    pub fn hero_value(&self, wo: Vec3, wi: Vec3) -> f32 {
        match self {
            Bsdf::Dielectric(d) => d.hero_value(wo, wi),
            _ => self.eval(wo, wi)[0],
        }
    }

    /// The same BSDF with its view-dependent terms computed once for `wo` (see
    /// `MetallicRoughnessBsdf::view`); evaluations and samples from another `wo` ignore them.
    /// Must come after the last change of the BSDF's parameters.
    pub fn at_view(self, wo: Vec3) -> Bsdf {
        match self {
            Bsdf::MetallicRoughness(b) => Bsdf::MetallicRoughness(b.at_view(wo)),
            other => other,
        }
    }

    /// The same BSDF with its clear coat (if it has one) shaded with normal `n` (unit, in the
    /// BSDF's local frame) instead of the base's: see `coat.rs`.
    pub fn with_coat_normal(self, n: Vec3) -> Bsdf {
        match self {
            Bsdf::MetallicRoughness(mut b) if b.coat.is_present() && n.z > 0.0 => {
                b.coat.normal = n;
                Bsdf::MetallicRoughness(b)
            }
            other => other,
        }
    }

    /// True if the BSDF can scatter to the other side of the surface (the integrator must not
    /// flip the frame to face `wo` for these).
    pub fn has_transmission(&self) -> bool {
        self.flags().contains(LobeFlags::TRANSMISSION)
    }
}
