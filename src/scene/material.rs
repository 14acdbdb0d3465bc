//! Runtime materials: turn a material description plus the texture lookups at a surface point
//! into a `Bsdf` and an emitted spectrum for the path's wavelengths.

use super::desc::{
    GltfMaterialDesc, IorDesc, MaterialDesc, MaterialOverride, TextureDesc, TextureRef,
};
use super::gltf_graph;
use crate::bsdf::{
    Bsdf, Coat, DielectricBsdf, DiffuseBsdf, Iridescence, MetallicRoughnessBsdf, Sheen, SheenModel,
    ThinFilm, TranslucentBsdf,
};
use crate::bssrdf::{SubsurfaceAt, SubsurfaceMaterial};
use crate::geometry::{Geometry, SurfacePoint};
use crate::lights::spread::Spread;
use crate::media::{DensityField, Medium};
use crate::shading::graph::{ClosurePick, InputValues};
use crate::shading::{MaterialInput, ShadingGraph, ShadingInputs};
use crate::spectrum::{
    RgbAlbedoSpectrum, RgbIlluminantSpectrum, SampledSpectrum, SampledWavelengths,
};
use glam::{Vec2, Vec3, Vec4, Vec4Swizzles};
use std::sync::Arc;

/// Which scattering model replaces the glTF one (from the sidecar).
#[derive(Clone, Debug)]
enum SurfaceModel {
    Gltf,
    Dielectric {
        ior: IorDesc,
        alpha: f32,
    },
    /// Subsurface scattering: a dielectric boundary over a scattering medium (`crate::bssrdf`).
    /// `boundary` is the sidecar's spectral IOR: the boundary BSDF refracts each wavelength
    /// with its own IOR (dispersion, with hero MIS like any dielectric); the diffusion profile
    /// and the exit lobe use the medium's scalar eta (= `boundary.n_d()`), since a profile
    /// table per wavelength would cost far more than the sub-percent change it makes.
    Subsurface {
        medium: Arc<SubsurfaceMaterial>,
        boundary: IorDesc,
        /// Probability of the subsurface component at a shading point (else the glTF model).
        weight: f32,
    },
}

#[derive(Clone, Debug)]
pub struct Material {
    pub name: String,
    gltf: GltfMaterialDesc,
    model: SurfaceModel,
    /// IOR of glTF transmission (KHR_materials_ior + KHR_materials_dispersion).
    gltf_ior: IorDesc,
    /// Precomputed spectra for the untextured case (the common one).
    base_albedo: RgbAlbedoSpectrum,
    /// Multiple-scattering GGX and energy-conserving layers (not `"model": "gltf"`).
    energy_compensation: bool,
    /// Blender 3.x's Principled as Cycles 3.x renders it (`MaterialDesc::principled_v1`).
    principled_v1: bool,
    /// The clear coat (weight 0: none).
    coat: MaterialCoat,
    /// The sheen (None: none).
    sheen: Option<MaterialSheen>,
    /// A thin film and its weight (KHR_materials_iridescence): on the dielectric interface of
    /// transmissive surfaces and on the specular layer of opaque ones.
    thin_film: Option<(ThinFilm, f32)>,
    /// KHR_materials_specular colour, upsampled once (not per shading point).
    specular_color: RgbAlbedoSpectrum,
    emission: Option<RgbIlluminantSpectrum>,
    /// Blender's area light Spread (`GltfMaterialDesc::emission_spread`); `None`: Lambertian.
    spread: Option<Spread>,
    /// The medium inside the object: the sidecar's `volume`, or KHR_materials_volume's
    /// Beer–Lambert absorption. Entered where a path is transmitted into the surface.
    interior: Option<Medium>,
    /// The surface does not scatter (`MaterialDesc::null_surface`).
    null_surface: bool,
    /// The shading graph driving the inputs that are not constants: the sidecar's, with the
    /// glTF texture slots bound where it leaves inputs free (`scene::gltf_graph`).
    graph: Option<Arc<ShadingGraph>>,
}

/// Smallest GGX alpha treated as rough; below it lobes are taken as perfectly specular.
const MIN_ALPHA: f32 = 1e-3;

/// glTF/Blender roughness is perceptual: alpha = roughness^2.
fn roughness_to_alpha(r: f32) -> f32 {
    let a = r.clamp(0.0, 1.0);
    a * a
}

/// The IOR of `ior` at `lambda_nm` (nanometres); the models live in `crate::spectrum::dispersion`.
pub fn eval_ior(ior: &IorDesc, lambda_nm: f32) -> f32 {
    ior.eval(lambda_nm)
}

impl Material {
    /// The runtime material of `desc`, whose texture slots index `textures`.
    pub fn new(desc: &MaterialDesc, textures: &[TextureDesc]) -> Self {
        let g = &desc.gltf;
        let model = match &desc.sidecar {
            None => SurfaceModel::Gltf,
            Some(MaterialOverride::Dielectric(d)) => SurfaceModel::Dielectric {
                ior: d.ior,
                alpha: roughness_to_alpha(d.roughness),
            },
            Some(MaterialOverride::Subsurface(s)) => SurfaceModel::Subsurface {
                medium: Arc::new(SubsurfaceMaterial::new(s)),
                boundary: s.boundary_ior(),
                weight: s.weight.clamp(0.0, 1.0),
            },
        };
        let emission =
            (g.emissive.max_element() > 0.0).then(|| RgbIlluminantSpectrum::new(g.emissive));
        let absorption = (g.attenuation_distance.is_finite() && g.attenuation_distance > 0.0)
            .then(|| {
                let c = g.attenuation_color.clamp(Vec3::splat(1e-6), Vec3::ONE);
                Medium::attenuation(c, g.attenuation_distance)
            })
            .filter(|_| g.attenuation_color.min_element() < 1.0);
        let density_graph = desc.graph.clone().filter(|g| {
            g.drives(crate::shading::MaterialInput::VolumeDensity)
                || g.drives(crate::shading::MaterialInput::VolumeColor)
        });
        let interior = desc
            .volume
            .as_ref()
            .map(|v| {
                let medium = Medium::new(v);
                match density_graph {
                    // The bound is estimated once the geometry exists (`Scene::build`).
                    Some(graph) => medium.with_density(DensityField {
                        graph,
                        majorant: 1.0,
                        grids: Vec::new(),
                    }),
                    None => medium,
                }
            })
            .or(absorption);
        Material {
            name: g.name.clone(),
            gltf: g.clone(),
            gltf_ior: g.ior_model(),
            model,
            base_albedo: RgbAlbedoSpectrum::new(g.base_color.xyz()),
            specular_color: RgbAlbedoSpectrum::new(g.specular_color),
            thin_film: (g.iridescence > 0.0).then_some((
                ThinFilm {
                    thickness_nm: g.iridescence_thickness,
                    ior: g.iridescence_ior,
                },
                g.iridescence,
            )),
            coat: MaterialCoat {
                weight: g.coat.clamp(0.0, 1.0),
                alpha: roughness_to_alpha(g.coat_roughness),
                ior: g.coat_ior,
                tint: RgbAlbedoSpectrum::new(g.coat_tint),
                additive: g.coat_additive,
            },
            sheen: MaterialSheen::new(
                g.sheen_color,
                g.sheen_roughness,
                sheen_model(desc.gltf_brdf, desc.principled_v1),
            ),
            emission,
            spread: Spread::new(g.emission_spread),
            interior,
            null_surface: desc.null_surface && desc.volume.is_some(),
            energy_compensation: !desc.gltf_brdf,
            principled_v1: desc.principled_v1,
            graph: material_graph(desc, textures),
        }
    }

    pub fn is_emissive(&self) -> bool {
        self.emission.is_some() || self.graph.as_ref().is_some_and(|g| g.drives_emission())
    }

    /// The surface is partly transparent somewhere (graph Alpha / Transparent BSDF, glTF
    /// alphaMode MASK or BLEND): rays pass through it with probability 1 - [`Material::alpha`].
    pub fn has_alpha(&self) -> bool {
        self.graph.as_ref().is_some_and(|g| g.has_alpha())
            || self.gltf.alpha_mode != crate::scene::desc::AlphaMode::Opaque
    }

    /// A Transparent BSDF of the graph is tinted: what passes depends on the wavelength.
    pub fn has_tinted_transparency(&self) -> bool {
        self.graph
            .as_ref()
            .is_some_and(|g| g.has_tinted_transparency())
    }

    /// Coverage (as [`Material::alpha`]) and the spectral transmittance of the transparent
    /// share: `1 - alpha` at every wavelength unless a Transparent BSDF is tinted, then its
    /// colour(s) upsampled as a reflectance.
    pub fn transparency(
        &self,
        inputs: Option<&ShadingInputs>,
        w: &SampledWavelengths,
    ) -> (f32, SampledSpectrum) {
        if let (Some(g), Some(inputs)) = (&self.graph, inputs) {
            if g.has_tinted_transparency() {
                let (alpha, pass) = g.transparency(inputs);
                return (alpha, RgbAlbedoSpectrum::new(pass).sample(w));
            }
        }
        let alpha = self.alpha(inputs);
        (alpha, SampledSpectrum::splat(1.0 - alpha))
    }

    /// Coverage in [0, 1] at a surface point (1 = opaque): the graph's (a textured glTF
    /// alpha is bound there too), else glTF's constant factor under its alpha mode.
    pub fn alpha(&self, inputs: Option<&ShadingInputs>) -> f32 {
        use crate::scene::desc::AlphaMode;
        if let (Some(g), Some(inputs)) = (&self.graph, inputs) {
            if g.has_alpha() {
                return g.alpha(inputs);
            }
        }
        let g = &self.gltf;
        let a = match g.alpha_mode {
            AlphaMode::Opaque => return 1.0,
            _ => g.base_color.w,
        };
        match g.alpha_mode {
            AlphaMode::Mask => {
                if a >= g.alpha_cutoff {
                    1.0
                } else {
                    0.0
                }
            }
            _ => a.clamp(0.0, 1.0),
        }
    }

    /// The graph sets the shading normal (a Bump node): see [`Material::graph_normal`].
    pub fn has_graph_normal(&self) -> bool {
        self.graph.as_ref().is_some_and(|g| g.drives_normal())
    }

    /// The graph's shading normal, outward (on `ng`'s side, as `SurfacePoint::ns`).
    pub fn graph_normal(
        &self,
        inputs: &ShadingInputs,
        bump: &crate::shading::BumpInputs,
    ) -> Option<Vec3> {
        let n = self.graph.as_ref()?.normal(inputs, bump)?;
        Some(if inputs.backfacing { -n } else { n })
    }

    /// The directions of the Bump nodes' offsets at a point of geometric normal `ng`
    /// (`ShadingGraph::bump_directions`; any tangent basis without a graph).
    pub fn bump_directions(&self, ng: Vec3) -> [Vec3; 2] {
        match &self.graph {
            Some(g) => g.bump_directions(ng),
            None => {
                let f = crate::math::frame::Frame::from_normal(ng);
                [f.s, f.t]
            }
        }
    }

    /// The Bump nodes' filter width in pixels (`ShadingGraph::bump_filter_width`).
    pub fn bump_filter_width(&self) -> f32 {
        self.graph.as_ref().map_or(0.1, |g| g.bump_filter_width())
    }

    /// The graph sets the clear coat's own normal (Blender's Coat Normal).
    pub fn has_graph_coat_normal(&self) -> bool {
        self.graph.as_ref().is_some_and(|g| g.drives_coat_normal())
    }

    /// The graph's coat normal, outward (as [`Material::graph_normal`]).
    pub fn graph_coat_normal(
        &self,
        inputs: &ShadingInputs,
        bump: &crate::shading::BumpInputs,
    ) -> Option<Vec3> {
        let n = self.graph.as_ref()?.coat_normal(inputs, bump)?;
        Some(if inputs.backfacing { -n } else { n })
    }

    /// The material reads [`ShadingInputs`] (a shading graph, glTF textures included): the
    /// integrator then gathers them.
    pub fn has_graph(&self) -> bool {
        self.graph.is_some()
    }

    /// What the material's graph reads at `sp` seen from `wo` (None without a graph): only
    /// the inputs it uses are gathered.
    pub fn graph_inputs(
        &self,
        geometry: &Geometry,
        sp: &SurfacePoint,
        wo: Vec3,
        camera_ray: bool,
    ) -> Option<ShadingInputs> {
        let graph = self.graph.as_ref()?;
        Some(geometry.surface_inputs(sp, wo, camera_ray, graph.reads_object_space()))
    }

    /// Linear RGB emitted radiance at a surface point (front side), for light power estimates.
    pub fn emitted_rgb_at(&self, inputs: &ShadingInputs) -> Vec3 {
        match &self.graph {
            Some(g) if g.has_closures() => g.mixed_emission(inputs),
            Some(g) if g.drives_emission() => {
                let v = g.evaluate(inputs, true);
                let color =
                    v[MaterialInput::Emission.index()].map_or(self.gltf.emissive, |c| c.xyz());
                let strength = v[MaterialInput::EmissionStrength.index()].map_or(1.0, |s| s.x);
                (color * strength).max(Vec3::ZERO)
            }
            _ => self.gltf.emissive,
        }
    }

    pub fn is_subsurface(&self) -> bool {
        matches!(self.model, SurfaceModel::Subsurface { .. })
    }

    /// The medium below a subsurface material's boundary.
    pub fn subsurface(&self) -> Option<&SubsurfaceMaterial> {
        match &self.model {
            SurfaceModel::Subsurface { medium, .. } => Some(medium),
            _ => None,
        }
    }

    /// The spectral IOR the sidecar gave a subsurface material's boundary (constant `eta` when
    /// it gave none); see `SurfaceModel::Subsurface`.
    pub fn subsurface_boundary_ior(&self) -> Option<&IorDesc> {
        match &self.model {
            SurfaceModel::Subsurface { boundary, .. } => Some(boundary),
            _ => None,
        }
    }

    /// Linear RGB emitted radiance where no graph drives it, for light power estimates.
    pub fn emissive_rgb(&self) -> Vec3 {
        self.gltf.emissive
    }

    /// Light leaves the back face too (glTF doubleSided; Blender writes it for every material
    /// without backface culling, and Cycles' emitters are two-sided).
    pub fn double_sided(&self) -> bool {
        self.gltf.double_sided
    }

    /// The medium inside the object, if it has one.
    pub fn interior(&self) -> Option<&Medium> {
        self.interior.as_ref()
    }

    /// The interior medium, for setting its density bound (`Scene::build`).
    pub fn interior_mut(&mut self) -> Option<&mut Medium> {
        self.interior.as_mut()
    }

    /// Rays pass through the surface (a volume's boundary without a surface shader).
    pub fn is_null_surface(&self) -> bool {
        self.null_surface
    }

    /// Radiance emitted towards a viewer on the front (or, if double-sided, either) side.
    /// `inputs`: the shading graph's inputs at the point (needed when [`Material::has_graph`]).
    pub fn emitted(
        &self,
        inputs: Option<&ShadingInputs>,
        cos_emit: f32,
        w: &SampledWavelengths,
    ) -> SampledSpectrum {
        if cos_emit <= 0.0 && !self.gltf.double_sided {
            return SampledSpectrum::ZERO;
        }
        match &self.spread {
            None => self.emitted_lambertian(inputs, w),
            Some(s) => self.emitted_lambertian(inputs, w) * s.attenuation(cos_emit),
        }
    }

    /// Cosine of the widest angle from the normal at which the surface emits (0: the whole
    /// hemisphere), for the light tree's orientation bounds.
    pub fn emission_cos_cutoff(&self) -> f32 {
        self.spread.map_or(0.0, |s| s.cos_cutoff())
    }

    fn emitted_lambertian(
        &self,
        inputs: Option<&ShadingInputs>,
        w: &SampledWavelengths,
    ) -> SampledSpectrum {
        if let (Some(g), Some(inputs)) = (&self.graph, inputs) {
            if g.drives_emission() {
                let rgb = self.emitted_rgb_at(inputs);
                return RgbIlluminantSpectrum::new(rgb).sample(w);
            }
        }
        self.emission
            .as_ref()
            .map_or(SampledSpectrum::ZERO, |e| e.sample(w))
    }

    /// Whether the material has a normal map (the integrator then calls
    /// [`Material::apply_normal_map`]).
    pub fn has_normal_map(&self) -> bool {
        self.gltf.normal_texture.is_some()
    }

    /// Tangent-space normal from the material's normal map at `uv`, per glTF 2.0 spec 5.23:
    /// texels are linear, n = normalize((2c - 1) * (scale, scale, 1)). `None` without a map
    /// or where the texel decodes to no direction.
    ///
    /// A KHR_texture_transform moves the lookup only; the tangent frame stays that of the
    /// mesh's UVs (TANGENT or dp/du), as in Cycles, whose Normal Map node takes its tangents
    /// from the UV map whatever Mapping node feeds the image (the glTF spec leaves a rotated
    /// normal map's frame unspecified).
    pub fn tangent_space_normal(&self, textures: &[TextureDesc], uv: Vec2) -> Option<Vec3> {
        let t = self.gltf.normal_texture?;
        let c = lookup(textures, &t, uv).xyz();
        let s = self.gltf.normal_scale;
        let n = (c * 2.0 - Vec3::ONE) * Vec3::new(s, s, 1.0);
        n.try_normalize()
    }

    /// The clear coat's own normal from `clearcoatNormalTexture` (world space, outward as
    /// `sp.ns`), applied to the surface's unperturbed normal; None without one.
    pub fn coat_normal_map(
        &self,
        geometry: &Geometry,
        textures: &[TextureDesc],
        sp: &SurfacePoint,
    ) -> Option<Vec3> {
        let g = &self.gltf;
        let t = g.coat_normal_texture.filter(|_| g.coat > 0.0)?;
        let c = lookup(textures, &t, sp.uv).xyz();
        let s = g.coat_normal_scale;
        let nt = ((c * 2.0 - Vec3::ONE) * Vec3::new(s, s, 1.0)).try_normalize()?;
        let mut coat = *sp;
        coat.ns = coat.ns_smooth;
        geometry.apply_normal_map(&mut coat, nt, None);
        Some(coat.ns)
    }

    /// Perturbs `sp.ns` by the material's normal map (no-op without one); `wo` is the unit
    /// direction towards the viewer, if there is one (see `Geometry::apply_normal_map`).
    pub fn apply_normal_map(
        &self,
        geometry: &Geometry,
        textures: &[TextureDesc],
        sp: &mut SurfacePoint,
        wo: Option<Vec3>,
    ) {
        if let Some(nt) = self.tangent_space_normal(textures, sp.uv) {
            // Only view-dependent lobes need the mapped normal to face the viewer. Cycles
            // bends it (for the mirror direction) in its microfacet closures only and shades
            // diffuse closures with the mapped normal as it is, even facing away from the
            // viewer. Prism has one frame per BSDF: materials with a diffuse base keep the
            // mapped normal as it is (the integrator then evaluates them for viewers behind
            // it, see `integrator::path`), which is exact for their diffuse part, the one that
            // dominates there; metals and transmissive materials get the bent normal.
            let wo = wo.filter(|_| !self.has_diffuse_base());
            geometry.apply_normal_map(sp, nt, wo);
        }
    }

    /// The material's constant thin film (KHR_materials_iridescence's factors; textured
    /// ones are the graph's `thin_film_*` inputs).
    fn iridescence(&self, w: &SampledWavelengths) -> Option<Iridescence> {
        let (film, weight) = self.thin_film?;
        (weight > 0.0).then(|| Iridescence {
            film,
            weight,
            lambda: SampledSpectrum::from_fn(|i| w.lambda[i]),
            averages: None,
        })
    }

    /// The glTF model has a Lambertian base everywhere: not a metal, not transmissive, no
    /// sidecar model (see `gltf_bsdf`).
    fn has_diffuse_base(&self) -> bool {
        let g = &self.gltf;
        matches!(self.model, SurfaceModel::Gltf) && g.metallic < 1.0 && g.transmission <= 0.0
    }

    /// What scatters at a surface point: the BSDF and, when it is the boundary of a
    /// subsurface medium, that medium. A partly subsurface material (`weight` < 1) picks the
    /// subsurface component with probability `weight`, else its glTF model, using `u_select`
    /// (stochastic selection of one component of a mixture keeps the estimator unbiased
    /// without evaluating both). When the material's graph mixes a subsurface leaf with other
    /// closures (a Mix / Add Shader tree), the graph's pick replaces `weight`.
    /// `inside_medium`: the path arrives from inside this material's medium (random walk),
    /// where only the medium's boundary makes sense.
    pub fn scattering(
        &self,
        inputs: Option<&ShadingInputs>,
        w: &SampledWavelengths,
        u_select: f32,
        inside_medium: bool,
    ) -> (Bsdf, Option<SubsurfaceAt<'_>>) {
        if let SurfaceModel::Subsurface { medium, weight, .. } = &self.model {
            if inside_medium {
                return (self.bsdf(inputs, w, u_select), Some(medium.at(None)));
            }
            if let (Some(graph), Some(ctx)) = (&self.graph, inputs) {
                if graph.has_subsurface_closure() {
                    return match graph.pick_closure(ctx, u_select) {
                        Some((ClosurePick::Subsurface(colour), u)) => {
                            (self.bsdf(inputs, w, u), Some(medium.at(colour)))
                        }
                        Some((ClosurePick::Bsdf(values), u)) => {
                            (self.gltf_bsdf_from(Some(values), w, u), None)
                        }
                        None => (Bsdf::black(), None),
                    };
                }
            }
            if u_select < *weight {
                let u = u_select / weight;
                // A textured subsurface colour (the graph's `subsurface_color`).
                let colour = match (&self.graph, inputs) {
                    (Some(graph), Some(ctx)) if graph.drives(MaterialInput::SubsurfaceColor) => {
                        graph.evaluate(ctx, false)[MaterialInput::SubsurfaceColor.index()]
                            .map(|v| v.xyz())
                    }
                    _ => None,
                };
                return (self.bsdf(inputs, w, u), Some(medium.at(colour)));
            }
            // The glTF part: reuse the leftover of `u_select` for its own choices.
            let u = ((u_select - weight) / (1.0 - weight)).clamp(0.0, 1.0);
            return (self.gltf_bsdf(inputs, w, u), None);
        }
        (self.bsdf(inputs, w, u_select), None)
    }

    /// The BSDF at a surface point (for a subsurface material, always its boundary). `u_select`
    /// picks one component of stochastic mixtures (partial transmission).
    pub fn bsdf(
        &self,
        inputs: Option<&ShadingInputs>,
        w: &SampledWavelengths,
        u_select: f32,
    ) -> Bsdf {
        match &self.model {
            SurfaceModel::Dielectric { ior, alpha } => Bsdf::Dielectric(DielectricBsdf {
                eta: SampledSpectrum::from_fn(|i| eval_ior(ior, w.lambda[i])),
                alpha: if *alpha < MIN_ALPHA { 0.0 } else { *alpha },
                transmission_tint: SampledSpectrum::ONE,
                iridescence: None,
                refraction_only: false,
                energy_compensation: self.energy_compensation,
            }),
            // The boundary of a subsurface medium: a (rough) dielectric; a transmission sample
            // hands the path to the BSSRDF (see `integrator::path`).
            SurfaceModel::Subsurface {
                medium: s,
                boundary,
                ..
            } => Bsdf::Dielectric(DielectricBsdf {
                eta: SampledSpectrum::from_fn(|i| eval_ior(boundary, w.lambda[i])),
                alpha: if s.alpha < MIN_ALPHA { 0.0 } else { s.alpha },
                transmission_tint: SampledSpectrum::ONE,
                iridescence: None,
                refraction_only: false,
                energy_compensation: self.energy_compensation,
            }),
            SurfaceModel::Gltf => self.gltf_bsdf(inputs, w, u_select),
        }
    }

    fn gltf_bsdf(
        &self,
        inputs: Option<&ShadingInputs>,
        w: &SampledWavelengths,
        u_select: f32,
    ) -> Bsdf {
        let (driven, u_select) = match (&self.graph, inputs) {
            (Some(graph), Some(ctx)) if graph.has_closures() => {
                match graph.pick_closure(ctx, u_select) {
                    Some((ClosurePick::Bsdf(values), u)) => (Some(values), u),
                    // No BSDF closure here: nothing scatters (a subsurface leaf only occurs
                    // with a subsurface medium, which `scattering` handles).
                    _ => return Bsdf::black(),
                }
            }
            (Some(graph), Some(ctx)) => (Some(graph.evaluate(ctx, false)), u_select),
            _ => (None, u_select),
        };
        self.gltf_bsdf_from(driven, w, u_select)
    }

    /// The glTF model with the graph-driven input values `driven` (one closure's, or the
    /// graph's inputs) over the material's constant factors.
    fn gltf_bsdf_from(
        &self,
        driven: Option<InputValues>,
        w: &SampledWavelengths,
        u_select: f32,
    ) -> Bsdf {
        let g = &self.gltf;
        let get = |m: MaterialInput| driven.as_ref().and_then(|d| d[m.index()]);
        let base = match get(MaterialInput::BaseColor) {
            Some(c) => RgbAlbedoSpectrum::new(c.xyz().clamp(Vec3::ZERO, Vec3::ONE)).sample(w),
            None => self.base_albedo.sample(w),
        };
        if get(MaterialInput::Translucent).is_some_and(|t| t.x > 0.5) {
            return Bsdf::Translucent(TranslucentBsdf {
                transmittance: base,
            });
        }
        let (mut metallic, mut roughness) = (g.metallic, g.roughness);
        if let Some(m) = get(MaterialInput::Metallic) {
            metallic = m.x.clamp(0.0, 1.0);
        }
        if let Some(r) = get(MaterialInput::Roughness) {
            roughness = r.x.clamp(0.0, 1.0);
        }
        let specular = get(MaterialInput::Specular).map_or(g.specular, |s| s.x.max(0.0));
        let alpha = roughness_to_alpha(roughness);
        // glTF transmission replaces the diffuse part of the dielectric base: we pick the
        // transmissive component with probability `transmission` (metals do not transmit).
        let refraction_only = get(MaterialInput::Refraction).is_some_and(|r| r.x > 0.5);
        let film_weight = get(MaterialInput::ThinFilmWeight).map_or(1.0, |v| v.x.clamp(0.0, 1.0));
        let iridescence = match get(MaterialInput::ThinFilmThickness) {
            // The graph's Thin Film (a Mix Shader leaf's, a textured thickness or a textured
            // glTF iridescence).
            Some(t) if t.x > 0.0 && film_weight > 0.0 => Some(Iridescence {
                film: ThinFilm {
                    thickness_nm: t.x,
                    ior: get(MaterialInput::ThinFilmIor)
                        .map_or(self.gltf.iridescence_ior, |n| n.x)
                        .max(1.0),
                },
                weight: film_weight,
                lambda: SampledSpectrum::from_fn(|i| w.lambda[i]),
                averages: None,
            }),
            Some(_) => None,
            None => self.iridescence(w),
        };
        let transmission = get(MaterialInput::Transmission)
            .map_or(g.transmission, |t| t.x.clamp(0.0, 1.0))
            * (1.0 - metallic);
        if refraction_only || (transmission > 0.0 && u_select < transmission) {
            return Bsdf::Dielectric(DielectricBsdf {
                eta: SampledSpectrum::from_fn(|i| self.gltf_ior.eval(w.lambda[i])),
                alpha: if alpha < MIN_ALPHA { 0.0 } else { alpha },
                transmission_tint: base,
                iridescence,
                refraction_only,
                energy_compensation: self.energy_compensation,
            });
        }
        let coat = self.coat_at(&get, w);
        let sheen = self.sheen_at(&get, w);
        if metallic <= 0.0
            && specular <= 0.0
            && !self.principled_v1
            && !coat.is_present()
            && !sheen.is_present()
            && iridescence.is_none()
        {
            return Bsdf::Diffuse(DiffuseBsdf { reflectance: base });
        }
        Bsdf::MetallicRoughness(
            MetallicRoughnessBsdf {
                base_color: base,
                metallic,
                alpha: alpha.max(MIN_ALPHA),
                specular,
                specular_color: match get(MaterialInput::SpecularTint) {
                    Some(c) => RgbAlbedoSpectrum::new(c.xyz().max(Vec3::ZERO)).sample(w),
                    None => self.specular_color.sample(w),
                },
                ior: g.ior,
                energy_compensation: self.energy_compensation,
                principled_v1: self.principled_v1,
                coat,
                sheen,
                iridescence,
                view: None,
            }
            .with_film_averages(),
        )
    }

    /// The coat at a shading point: the glTF factors, or what the shading graph drives
    /// (textured glTF clear coats included).
    fn coat_at(
        &self,
        get: &impl Fn(MaterialInput) -> Option<Vec4>,
        w: &SampledWavelengths,
    ) -> Coat {
        let g = &self.gltf;
        let (weight_in, roughness_in, tint_in, ior_in) = (
            get(MaterialInput::CoatWeight),
            get(MaterialInput::CoatRoughness),
            get(MaterialInput::CoatTint),
            get(MaterialInput::CoatIor),
        );
        if weight_in.is_none() && roughness_in.is_none() && tint_in.is_none() && ior_in.is_none() {
            return self.coat.sample(w);
        }
        let weight = weight_in.map_or(self.coat.weight, |v| v.x);
        if !(weight > 0.0) {
            return Coat::NONE;
        }
        let roughness = roughness_in.map_or(g.coat_roughness, |v| v.x);
        let alpha = roughness_to_alpha(roughness);
        Coat {
            weight: weight.clamp(0.0, 1.0),
            alpha: if alpha < MIN_ALPHA { 0.0 } else { alpha },
            // Blender clamps Coat IOR to [1, 4]; NaN keeps the material's.
            ior: ior_in.map_or(self.coat.ior, |v| {
                if v.x.is_nan() {
                    self.coat.ior
                } else {
                    v.x.clamp(1.0, 4.0)
                }
            }),
            tint: match tint_in {
                Some(c) => RgbAlbedoSpectrum::new(c.xyz().clamp(Vec3::ZERO, Vec3::ONE)).sample(w),
                None => self.coat.tint.sample(w),
            },
            normal: Vec3::Z,
            additive: self.coat.additive,
        }
    }

    /// The sheen at a shading point: the glTF factors, or what the shading graph drives
    /// (textured glTF sheens included).
    fn sheen_at(
        &self,
        get: &impl Fn(MaterialInput) -> Option<Vec4>,
        w: &SampledWavelengths,
    ) -> Sheen {
        let g = &self.gltf;
        let (color_in, roughness_in) = (
            get(MaterialInput::SheenColor),
            get(MaterialInput::SheenRoughness),
        );
        if color_in.is_none() && roughness_in.is_none() {
            return self.sheen.as_ref().map_or(Sheen::NONE, |s| s.sample(w));
        }
        let rgb = color_in.map_or(g.sheen_color, |c| c.xyz());
        let roughness = roughness_in.map_or(g.sheen_roughness, |v| v.x);
        MaterialSheen::new(
            rgb,
            roughness,
            sheen_model(!self.energy_compensation, self.principled_v1),
        )
        .map_or(Sheen::NONE, |s| s.sample(w))
    }
}

/// The sheen lobe of a material: Cycles' microfibre sheen, Blender 3.x's Disney sheen for its
/// Principled BSDF, the Charlie lobe for the glTF BRDF.
fn sheen_model(gltf_brdf: bool, principled_v1: bool) -> SheenModel {
    if principled_v1 {
        SheenModel::Disney
    } else if gltf_brdf {
        SheenModel::Charlie
    } else {
        SheenModel::Microfibre
    }
}

/// A material's sheen, its colour upsampled once.
#[derive(Clone, Debug)]
struct MaterialSheen {
    color: RgbAlbedoSpectrum,
    scale: f32,
    roughness: f32,
    model: SheenModel,
}

impl MaterialSheen {
    /// None for a black (or invalid) colour.
    fn new(rgb: Vec3, roughness: f32, model: SheenModel) -> Option<MaterialSheen> {
        let rgb = rgb.clamp(Vec3::ZERO, Vec3::ONE);
        let scale = rgb.max_element();
        (scale > 0.0 && rgb.is_finite()).then(|| MaterialSheen {
            color: RgbAlbedoSpectrum::new(rgb),
            scale,
            roughness: if roughness.is_finite() {
                roughness.clamp(0.0, 1.0)
            } else {
                0.5
            },
            model,
        })
    }

    fn sample(&self, w: &SampledWavelengths) -> Sheen {
        Sheen {
            color: self.color.sample(w),
            scale: self.scale,
            roughness: self.roughness,
            model: self.model,
        }
    }
}

/// A material's clear coat, its tint upsampled once.
#[derive(Clone, Debug)]
struct MaterialCoat {
    weight: f32,
    alpha: f32,
    ior: f32,
    tint: RgbAlbedoSpectrum,
    additive: bool,
}

impl MaterialCoat {
    fn sample(&self, w: &SampledWavelengths) -> Coat {
        if !(self.weight > 0.0) {
            return Coat::NONE;
        }
        Coat {
            weight: self.weight,
            alpha: if self.alpha < MIN_ALPHA {
                0.0
            } else {
                self.alpha
            },
            ior: self.ior,
            tint: self.tint.sample(w),
            normal: Vec3::Z,
            additive: self.additive,
        }
    }
}

/// A glTF normal texture's value at TEXCOORD_0 `uv` (white if the index is invalid).
fn lookup(textures: &[TextureDesc], tref: &TextureRef, uv: Vec2) -> Vec4 {
    textures
        .get(tref.texture)
        .map_or(Vec4::ONE, |t| gltf_graph::sample_slot(t, tref, uv))
}

/// The material's graph: the sidecar's, with glTF's texture slots bound where it leaves the
/// inputs free; glTF's alone when there is no sidecar graph; none without either.
fn material_graph(desc: &MaterialDesc, textures: &[TextureDesc]) -> Option<Arc<ShadingGraph>> {
    let (nodes, bindings) = gltf_graph::texture_graph(&desc.gltf, textures);
    if bindings.is_empty() {
        return desc.graph.clone();
    }
    Some(Arc::new(match &desc.graph {
        Some(sidecar) => sidecar.with_fallbacks(nodes, bindings),
        None => ShadingGraph::new(nodes, bindings),
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cauchy_ior() {
        let ior = IorDesc::cauchy(1.5, 0.01, 0.0).unwrap();
        assert!((eval_ior(&ior, 500.0) - (1.5 + 0.01 / 0.25)).abs() < 1e-6);
        assert_eq!(eval_ior(&IorDesc::Constant(1.33), 400.0), 1.33);
    }
}
