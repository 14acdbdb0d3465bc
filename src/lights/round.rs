//! The emitting shape of a point or spot light with a radius, as Blender defines it (Cycles
//! 4.x / 5.0): its "Radius" makes the light a soft source of the same radiant intensity I far
//! away, so the radiance is L = I / (pi r^2).
//!
//! * **Soft Falloff** (Blender's default): a disc of radius r through the light's centre that
//!   faces the shading point (Cycles' point light "with ad-hoc radius based on oriented
//!   disk"). Its irradiance at distance d on the axis is pi L r^2 / (r^2 + d^2) = I / (r^2 +
//!   d^2): no singularity where geometry touches the light, hence the name.
//! * Otherwise a **sphere** of radius r emitting L outwards and inwards: from outside it is
//!   sampled uniformly inside the cone it subtends (exact solid-angle sampling of a sphere,
//!   pbrt-v4 section 6.2.4), from inside uniformly over all directions.
//!
//! Rays are not blocked by these lights (Blender's lights cast no shadow and paths go through
//! them); a ray that crosses one sees its radiance once.

use crate::math::{sampling, Frame, INV_4PI, PI};
use glam::{Vec2, Vec3};

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RoundEmitter {
    pub center: Vec3,
    pub radius: f32,
    /// Blender's Soft Falloff: a disc facing the shading point instead of a sphere.
    pub soft_falloff: bool,
}

/// A direction from a shading point towards the emitter.
#[derive(Clone, Copy, Debug)]
pub struct RoundSample {
    pub wi: Vec3,
    /// Distance to the emitting surface along `wi`.
    pub distance: f32,
    /// Density per unit solid angle.
    pub pdf: f32,
}

impl RoundEmitter {
    /// Radiance per unit radiant intensity: 1 / (pi r^2), so that the disc (or the sphere's
    /// silhouette) far away has intensity I.
    pub fn radiance_per_intensity(&self) -> f32 {
        1.0 / (PI * self.radius * self.radius)
    }

    /// Lower and upper corners of the emitter's bounding box.
    pub fn bounds(&self) -> (Vec3, Vec3) {
        (
            self.center - Vec3::splat(self.radius),
            self.center + Vec3::splat(self.radius),
        )
    }

    /// Samples a direction from `p` towards the emitter.
    pub fn sample(&self, p: Vec3, u: Vec2) -> Option<RoundSample> {
        let to_center = self.center - p;
        let d2 = to_center.length_squared();
        if !(d2 > 0.0) {
            return None;
        }
        let d = d2.sqrt();
        let axis = to_center / d;
        let r = self.radius;
        if self.soft_falloff {
            // A uniform point on the disc facing p; area density 1 / (pi r^2) converted to
            // solid angle with the disc's cosine d / t: t^3 / (pi r^2 d).
            let disc = sampling::sample_uniform_disk_concentric(u) * r;
            let q = self.center + Frame::from_normal(axis).to_world(Vec3::new(disc.x, disc.y, 0.0));
            let v = q - p;
            let t = v.length();
            if !(t > 0.0) {
                return None;
            }
            return Some(RoundSample {
                wi: v / t,
                distance: t,
                pdf: t * t * t / (PI * r * r * d),
            });
        }
        let r2 = r * r;
        if d2 > r2 {
            let omc = self.cone_one_minus_cos(d2);
            let local = sampling::sample_uniform_cone_one_minus_cos(u, omc);
            let wi = Frame::from_normal(axis).to_world(local);
            // Nearest intersection with the sphere along wi (law of cosines), with sin^2 theta
            // taken from the sample itself: r^2 - d^2 sin^2 theta cancels badly otherwise.
            let sin2 = local.x * local.x + local.y * local.y;
            let t = d * local.z - (r2 - d2 * sin2).max(0.0).sqrt();
            Some(RoundSample {
                wi,
                distance: t.max(0.0),
                pdf: sampling::uniform_cone_pdf_one_minus_cos(omc),
            })
        } else {
            let wi = sampling::sample_uniform_sphere(u);
            let cos = wi.dot(axis);
            let t = d * cos + (r2 - d2 * (1.0 - cos * cos)).max(0.0).sqrt();
            Some(RoundSample {
                wi,
                distance: t,
                pdf: INV_4PI,
            })
        }
    }

    /// 1 - cos of the half-angle the sphere subtends from distance sqrt(d2) > r:
    /// sin^2 / (1 + cos), without cancellation for small spheres far away.
    fn cone_one_minus_cos(&self, d2: f32) -> f32 {
        let sin2 = (self.radius * self.radius / d2).min(1.0);
        sin2 / (1.0 + (1.0 - sin2).sqrt())
    }

    /// Solid-angle density with which `sample` at `p` produces `wi` (0 if `wi` misses).
    pub fn pdf(&self, p: Vec3, wi: Vec3) -> f32 {
        let Some(t) = self.intersect(p, wi, f32::INFINITY) else {
            return 0.0;
        };
        let d2 = (self.center - p).length_squared();
        if self.soft_falloff {
            let d = d2.sqrt();
            let r = self.radius;
            return t * t * t / (PI * r * r * d);
        }
        if d2 > self.radius * self.radius {
            sampling::uniform_cone_pdf_one_minus_cos(self.cone_one_minus_cos(d2))
        } else {
            INV_4PI
        }
    }

    /// Distance along the ray (unit `dir`) to the emitter, if it is hit before `t_max`. The
    /// soft-falloff disc faces `origin`; the sphere is hit at its first crossing ahead.
    pub fn intersect(&self, origin: Vec3, dir: Vec3, t_max: f32) -> Option<f32> {
        let oc = origin - self.center;
        let r2 = self.radius * self.radius;
        if self.soft_falloff {
            let d = oc.length();
            if !(d > 0.0) {
                return None;
            }
            let n = oc / d;
            let approach = -dir.dot(n);
            if !(approach > 0.0) {
                return None;
            }
            let t = d / approach;
            let q = oc + t * dir;
            return (t < t_max && q.length_squared() <= r2).then_some(t);
        }
        // Distance of the closest approach from the perpendicular foot (stable for small
        // spheres far away, unlike b^2 - c).
        let b = oc.dot(dir);
        let perp = oc - b * dir;
        let h2 = r2 - perp.length_squared();
        if h2 < 0.0 {
            return None;
        }
        let h = h2.sqrt();
        let (t0, t1) = (-b - h, -b + h);
        let t = if t0 > 0.0 { t0 } else { t1 };
        (t > 0.0 && t < t_max).then_some(t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn emitters() -> [RoundEmitter; 2] {
        let e = RoundEmitter {
            center: Vec3::new(0.3, -0.2, 2.0),
            radius: 0.5,
            soft_falloff: true,
        };
        [
            e,
            RoundEmitter {
                soft_falloff: false,
                ..e
            },
        ]
    }

    /// Every sample hits the emitter where it says, and `pdf` agrees with `sample`.
    #[test]
    fn samples_hit_and_pdf_agrees() {
        for e in emitters() {
            for p in [
                Vec3::ZERO,
                Vec3::new(0.4, -0.1, 1.8),
                Vec3::new(5.0, 1.0, -3.0),
            ] {
                for i in 0..64 {
                    let u = Vec2::new((i % 8) as f32 / 8.0 + 0.06, (i / 8) as f32 / 8.0 + 0.03);
                    let s = e.sample(p, u).unwrap();
                    let t = e.intersect(p, s.wi, f32::INFINITY).unwrap();
                    assert!(
                        (t - s.distance).abs() < 1e-3 * (1.0 + t),
                        "{e:?} {p} {t} {s:?}"
                    );
                    let pdf = e.pdf(p, s.wi);
                    assert!((pdf - s.pdf).abs() < 1e-3 * s.pdf, "{pdf} vs {}", s.pdf);
                }
            }
        }
    }

    /// The densities integrate to one over the directions that hit the emitter (Monte Carlo
    /// over the sphere of directions).
    #[test]
    fn pdf_integrates_to_one() {
        for e in emitters() {
            for p in [Vec3::ZERO, Vec3::new(0.4, -0.1, 1.8)] {
                let n = 400_000;
                let mut sum = 0.0f64;
                let mut rng = crate::sampler::Pcg32::new(7, 3, 1);
                for _ in 0..n {
                    let wi = sampling::sample_uniform_sphere(rng.next_2d());
                    sum += (e.pdf(p, wi) / INV_4PI) as f64;
                }
                let mean = sum / n as f64;
                assert!((mean - 1.0).abs() < 0.02, "{e:?} at {p}: {mean}");
            }
        }
    }
}
