//! Light sources and their sampling for next-event estimation: emissive triangles (area
//! lights), KHR_lights_punctual (point, spot, directional) and the world (a uniform colour or
//! an equirectangular environment map, `super::envmap`).
//! One light is chosen per sample in proportion to an estimate of its emitted power.

use super::desc::{PunctualKind, PunctualLightDesc, TextureDesc};
use super::envmap::EnvironmentMap;
use super::material::Material;
use crate::geometry::Geometry;
use crate::math::{sampling, DiscreteDistribution, Frame, PI};
use crate::spectrum::{RgbIlluminantSpectrum, SampledSpectrum, SampledWavelengths};
use glam::{Vec2, Vec3, Vec4Swizzles};

#[derive(Clone, Debug)]
pub enum Light {
    /// One emissive triangle of a placed mesh.
    Triangle { instance: u32, prim: u32 },
    Point {
        position: Vec3,
        intensity: RgbIlluminantSpectrum,
    },
    Spot {
        position: Vec3,
        frame: Frame,
        cos_outer: f32,
        /// Width in cosine of the smooth edge (Blender's spot blend).
        cos_smooth: f32,
        intensity: RgbIlluminantSpectrum,
    },
    /// Parallel light travelling along -`to_light`.
    Directional {
        to_light: Vec3,
        irradiance: RgbIlluminantSpectrum,
    },
    /// The world: its data is `Lights::world`.
    Environment,
}

/// What the world emits.
pub enum World {
    Black,
    /// Uniform radiance from every direction (linear RGB, colour x strength).
    Uniform(Vec3),
    /// An equirectangular environment map (colour x strength already applied).
    Map(Box<EnvironmentMap>),
}

enum WorldLight {
    Uniform(RgbIlluminantSpectrum),
    Map(Box<EnvironmentMap>),
}

/// A sampled light direction as seen from a shading point.
#[derive(Clone, Copy, Debug)]
pub struct LightSample {
    pub wi: Vec3,
    /// Shadow-ray extent along `wi` (INFINITY for lights at infinity).
    pub distance: f32,
    /// Incident radiance (or, for delta lights, intensity / distance^2 or irradiance).
    pub li: SampledSpectrum,
    /// Solid-angle density including the light-selection probability (delta lights: the
    /// selection probability alone).
    pub pdf: f32,
    pub delta: bool,
}

pub struct Lights {
    lights: Vec<Light>,
    distribution: DiscreteDistribution,
    /// First light index of each instance's triangles (u32::MAX: the instance does not emit).
    instance_base: Vec<u32>,
    /// Index of the world in `lights` and its emission.
    environment: Option<(usize, WorldLight)>,
    scene_radius: f32,
}

fn luminance(rgb: Vec3) -> f32 {
    0.2126 * rgb.x + 0.7152 * rgb.y + 0.0722 * rgb.z
}

fn mean_texture_rgb(tex: &TextureDesc) -> Vec3 {
    if tex.texels.is_empty() {
        return Vec3::ONE;
    }
    tex.texels.iter().map(|t| t.xyz()).sum::<Vec3>() / tex.texels.len() as f32
}

/// Cycles' spot-light edge: smoothstep over a cosine band of width (1 - cos_outer) * blend,
/// with blend = 1 - inner/outer (the glTF importer's mapping of the inner cone).
fn spot_falloff(cos_theta: f32, cos_outer: f32, cos_smooth: f32) -> f32 {
    if cos_theta <= cos_outer {
        return 0.0;
    }
    if cos_smooth <= 0.0 {
        return 1.0;
    }
    let t = ((cos_theta - cos_outer) / cos_smooth).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

impl Lights {
    pub fn build(
        geometry: &Geometry,
        materials: &[Material],
        textures: &[TextureDesc],
        punctual: &[PunctualLightDesc],
        world: World,
    ) -> Self {
        let mut lights = Vec::new();
        let mut power = Vec::new();
        let mut instance_base = vec![u32::MAX; geometry.instances.len()];
        for (ii, inst) in geometry.instances.iter().enumerate() {
            let mesh = &geometry.meshes[inst.mesh as usize];
            let mat = &materials[mesh.material as usize];
            if !mat.is_emissive() {
                continue;
            }
            let mut rgb = mat.emissive_rgb();
            if let Some(t) = mat.emissive_texture() {
                rgb *= textures.get(t.texture).map_or(Vec3::ONE, mean_texture_rgb);
            }
            let sides = if mat.double_sided() { 2.0 } else { 1.0 };
            instance_base[ii] = lights.len() as u32;
            for prim in 0..mesh.triangle_count() as u32 {
                let area = geometry.surface_point_at(ii as u32, prim, 0.0, 0.0).area;
                lights.push(Light::Triangle {
                    instance: ii as u32,
                    prim,
                });
                power.push(luminance(rgb) * area * PI * sides);
            }
        }
        for p in punctual {
            let rgb = p.color * p.intensity;
            let spectrum = RgbIlluminantSpectrum::new(rgb);
            match p.kind {
                PunctualKind::Point => {
                    lights.push(Light::Point {
                        position: p.position,
                        intensity: spectrum,
                    });
                    power.push(4.0 * PI * luminance(rgb));
                }
                PunctualKind::Spot {
                    inner_cone,
                    outer_cone,
                } => {
                    let outer = outer_cone.clamp(1e-4, PI / 2.0);
                    let cos_outer = outer.cos();
                    let blend = (1.0 - inner_cone.clamp(0.0, outer) / outer).clamp(0.0, 1.0);
                    lights.push(Light::Spot {
                        position: p.position,
                        frame: Frame::from_normal(p.direction.normalize()),
                        cos_outer,
                        cos_smooth: (1.0 - cos_outer) * blend,
                        intensity: spectrum,
                    });
                    power.push(2.0 * PI * (1.0 - cos_outer) * luminance(rgb));
                }
                PunctualKind::Directional => {
                    lights.push(Light::Directional {
                        to_light: -p.direction.normalize(),
                        irradiance: spectrum,
                    });
                    power.push(0.0); // filled below once the scene radius is known
                }
            }
        }
        let (lo, hi) = geometry.bounds();
        let scene_radius = if geometry.is_empty() {
            1.0
        } else {
            (0.5 * (hi - lo).length()).max(1e-3)
        };
        for (l, p) in lights.iter().zip(power.iter_mut()) {
            if let Light::Directional { irradiance, .. } = l {
                *p = PI * scene_radius * scene_radius * luminance_of(irradiance);
            }
        }
        // Power of the world through a disk of the scene's radius: pi r^2 x the integral of
        // the luminance over the sphere.
        let world = match world {
            World::Uniform(rgb) if rgb.max_element() > 0.0 && rgb.is_finite() => Some((
                WorldLight::Uniform(RgbIlluminantSpectrum::new(rgb)),
                4.0 * PI * luminance(rgb),
            )),
            World::Map(map) if map.luminance_integral() > 0.0 => {
                let l = map.luminance_integral();
                Some((WorldLight::Map(map), l))
            }
            _ => None,
        };
        let environment = world.map(|(light, integral)| {
            let index = lights.len();
            lights.push(Light::Environment);
            power.push(PI * scene_radius * scene_radius * integral);
            (index, light)
        });
        let distribution = DiscreteDistribution::new(&power);
        Lights {
            lights,
            distribution,
            instance_base,
            environment,
            scene_radius,
        }
    }

    pub fn is_empty(&self) -> bool {
        self.lights.is_empty()
    }

    pub fn len(&self) -> usize {
        self.lights.len()
    }

    pub fn scene_radius(&self) -> f32 {
        self.scene_radius
    }

    /// Radiance of the world seen along the escaping world-space direction `dir` (unit).
    pub fn environment_radiance(&self, dir: Vec3, w: &SampledWavelengths) -> SampledSpectrum {
        match &self.environment {
            Some((_, WorldLight::Uniform(radiance))) => radiance.sample(w),
            Some((_, WorldLight::Map(map))) => map.radiance(dir, w),
            None => SampledSpectrum::ZERO,
        }
    }

    /// Solid-angle density with which `sample` produces the escaping direction `dir`.
    pub fn environment_pdf(&self, dir: Vec3) -> f32 {
        match &self.environment {
            Some((i, WorldLight::Uniform(_))) => {
                self.distribution.pmf(*i) * sampling::uniform_sphere_pdf()
            }
            Some((i, WorldLight::Map(map))) => self.distribution.pmf(*i) * map.pdf(dir),
            None => 0.0,
        }
    }

    /// Density with which `sample` produces the direction towards triangle `prim` of
    /// `instance`, hit at distance `dist` with cosine `cos_light` at the light.
    pub fn triangle_pdf(
        &self,
        instance: u32,
        prim: u32,
        area: f32,
        dist: f32,
        cos_light: f32,
    ) -> f32 {
        let base = self
            .instance_base
            .get(instance as usize)
            .copied()
            .unwrap_or(u32::MAX);
        if base == u32::MAX || cos_light.abs() < 1e-7 || area <= 0.0 {
            return 0.0;
        }
        self.distribution.pmf((base + prim) as usize) * dist * dist / (cos_light.abs() * area)
    }

    /// Picks a light and a direction towards it from the shading point `p`.
    #[allow(clippy::too_many_arguments)]
    pub fn sample(
        &self,
        geometry: &Geometry,
        materials: &[Material],
        textures: &[TextureDesc],
        p: Vec3,
        u_select: f32,
        u: Vec2,
        w: &SampledWavelengths,
    ) -> Option<LightSample> {
        if self.lights.is_empty() {
            return None;
        }
        let (index, p_select, _) = self.distribution.sample(u_select);
        if p_select <= 0.0 {
            return None;
        }
        match &self.lights[index] {
            Light::Triangle { instance, prim } => {
                let (b1, b2) = sampling::sample_uniform_triangle(u);
                let sp = geometry.surface_point_at(*instance, *prim, b1, b2);
                let d = sp.p - p;
                let dist2 = d.length_squared();
                if dist2 <= 0.0 || sp.area <= 0.0 {
                    return None;
                }
                let dist = dist2.sqrt();
                let wi = d / dist;
                let cos_light = sp.ng.dot(-wi);
                let mat = &materials[sp.material as usize];
                let le = mat.emitted(textures, sp.uv, cos_light > 0.0, w);
                if le.is_black() || cos_light.abs() < 1e-7 {
                    return None;
                }
                Some(LightSample {
                    wi,
                    distance: dist * (1.0 - 1e-4),
                    li: le,
                    pdf: p_select * dist2 / (cos_light.abs() * sp.area),
                    delta: false,
                })
            }
            Light::Point {
                position,
                intensity,
            } => {
                let d = *position - p;
                let dist2 = d.length_squared();
                (dist2 > 0.0).then(|| {
                    let dist = dist2.sqrt();
                    LightSample {
                        wi: d / dist,
                        distance: dist,
                        li: intensity.sample(w) / dist2,
                        pdf: p_select,
                        delta: true,
                    }
                })
            }
            Light::Spot {
                position,
                frame,
                cos_outer,
                cos_smooth,
                intensity,
            } => {
                let d = *position - p;
                let dist2 = d.length_squared();
                if dist2 <= 0.0 {
                    return None;
                }
                let dist = dist2.sqrt();
                let wi = d / dist;
                let falloff = spot_falloff(frame.n.dot(-wi), *cos_outer, *cos_smooth);
                (falloff > 0.0).then(|| LightSample {
                    wi,
                    distance: dist,
                    li: intensity.sample(w) * (falloff / dist2),
                    pdf: p_select,
                    delta: true,
                })
            }
            Light::Directional {
                to_light,
                irradiance,
            } => Some(LightSample {
                wi: *to_light,
                distance: f32::INFINITY,
                li: irradiance.sample(w),
                pdf: p_select,
                delta: true,
            }),
            Light::Environment => match &self.environment {
                Some((_, WorldLight::Uniform(radiance))) => Some(LightSample {
                    wi: sampling::sample_uniform_sphere(u),
                    distance: f32::INFINITY,
                    li: radiance.sample(w),
                    pdf: p_select * sampling::uniform_sphere_pdf(),
                    delta: false,
                }),
                Some((_, WorldLight::Map(map))) => {
                    let (wi, pdf) = map.sample(u)?;
                    let li = map.radiance(wi, w);
                    (!li.is_black()).then_some(LightSample {
                        wi,
                        distance: f32::INFINITY,
                        li,
                        pdf: p_select * pdf,
                        delta: false,
                    })
                }
                None => None,
            },
        }
    }
}

fn luminance_of(s: &RgbIlluminantSpectrum) -> f32 {
    // Y of the illuminant over the visible range, by a coarse quadrature.
    let mut y = 0.0;
    let mut n = 0.0;
    for l in (380..=780).step_by(10) {
        let l = l as f32;
        y += s.eval(l) * crate::spectrum::cie::cie_xyz_bar(l).y;
        n += crate::spectrum::cie::cie_xyz_bar(l).y;
    }
    if n > 0.0 {
        y / n
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spot_edge_is_smooth_and_bounded() {
        let (co, cs) = (0.8f32, 0.05f32);
        assert_eq!(spot_falloff(0.79, co, cs), 0.0);
        assert_eq!(spot_falloff(0.9, co, cs), 1.0);
        let mid = spot_falloff(0.825, co, cs);
        assert!((mid - 0.5).abs() < 1e-5);
        assert_eq!(spot_falloff(0.81, co, 0.0), 1.0);
    }
}
