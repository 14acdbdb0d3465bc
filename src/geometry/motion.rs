//! Transform motion blur: an object's placement over the shutter.
//!
//! A moving instance carries its object-to-world transform at `n >= 2` equally spaced times
//! over the shutter (normalised time 0 = shutter open, 1 = closed), as Blender's motion steps
//! give them. Between two keys the transform is interpolated the way Cycles does it
//! (`util/transform.cpp`, transform_motion_decompose / transform_motion_array_interpolate):
//! decomposed into translation, rotation (a unit quaternion) and scale, the translation and
//! scale interpolated linearly and the rotation by slerp along the shorter arc, so a spinning
//! object keeps its shape instead of shrinking through the chord between two keys. A key that
//! is not a rotation times a scale (a sheared matrix) makes the whole motion interpolate its
//! matrices element-wise, which is exact for any motion that is affine in time.
//!
//! Each camera path picks one time (the sampler's camera group, dimension 2), and every ray
//! of the path, its shadow rays and its light samples see the scene at that time.

use glam::{Affine3A, Quat, Vec3};
use obvhs::aabb::Aabb;

/// Placement keys over the shutter.
#[derive(Clone, Debug)]
pub struct MotionTransform {
    keys: Vec<Affine3A>,
    /// (scale, rotation, translation) per key, or None when a key does not decompose.
    decomposed: Option<Vec<(Vec3, Quat, Vec3)>>,
}

/// Sub-intervals per key interval over which `bounds` samples the motion: a rotation's arc
/// between two samples bulges out of the samples' box by at most 1 - cos(angle / 2) of the
/// radius, which `bounds` pads for.
const BOUND_SAMPLES_PER_INTERVAL: usize = 16;

impl MotionTransform {
    /// None unless there are at least two keys and all are finite and invertible.
    pub fn new(keys: Vec<Affine3A>) -> Option<MotionTransform> {
        if keys.len() < 2
            || keys
                .iter()
                .any(|k| !k.is_finite() || k.matrix3.determinant().abs() < 1e-30)
        {
            return None;
        }
        let decomposed: Option<Vec<_>> = keys
            .iter()
            .map(|k| {
                let (s, r, t) = k.to_scale_rotation_translation();
                let back = Affine3A::from_scale_rotation_translation(s, r, t);
                let tolerance = 1e-4
                    * (1.0
                        + k.matrix3
                            .to_cols_array()
                            .map(f32::abs)
                            .iter()
                            .cloned()
                            .fold(0.0, f32::max));
                back.abs_diff_eq(*k, tolerance).then_some((s, r, t))
            })
            .collect();
        // Slerp along the shorter arc: q and -q are the same rotation.
        let decomposed = decomposed.map(|mut d| {
            for i in 1..d.len() {
                if d[i - 1].1.dot(d[i].1) < 0.0 {
                    d[i].1 = -d[i].1;
                }
            }
            d
        });
        Some(MotionTransform { keys, decomposed })
    }

    /// Whether every key is the same transform (no motion to render).
    pub fn is_static(&self) -> bool {
        self.keys.windows(2).all(|w| w[0].abs_diff_eq(w[1], 1e-7))
    }

    pub fn keys(&self) -> &[Affine3A] {
        &self.keys
    }

    /// The object-to-world transform at normalised shutter time `time` (clamped to [0, 1]).
    pub fn at(&self, time: f32) -> Affine3A {
        let n = self.keys.len() - 1;
        let x = time.clamp(0.0, 1.0) * n as f32;
        let i = (x as usize).min(n - 1);
        let f = x - i as f32;
        match &self.decomposed {
            Some(d) => {
                let (s0, r0, t0) = d[i];
                let (s1, r1, t1) = d[i + 1];
                Affine3A::from_scale_rotation_translation(
                    s0.lerp(s1, f),
                    r0.slerp(r1, f),
                    t0.lerp(t1, f),
                )
            }
            None => {
                let (a, b) = (&self.keys[i], &self.keys[i + 1]);
                Affine3A::from_cols_array(&std::array::from_fn(|k| {
                    let (x, y) = (a.to_cols_array()[k], b.to_cols_array()[k]);
                    x + (y - x) * f
                }))
            }
        }
    }

    /// A box holding the object-space box `b` at every time of the shutter.
    pub fn bounds(&self, b: &Aabb) -> Aabb {
        let intervals = self.keys.len() - 1;
        let samples = intervals * BOUND_SAMPLES_PER_INTERVAL;
        let mut out = Aabb::empty();
        for k in 0..=samples {
            let m = self.at(k as f32 / samples as f32);
            out = out.union(&super::transform_aabb(b, &m));
        }
        // Between two samples a rotating corner leaves the chord by at most r (1 - cos(a / 2))
        // for the angle a turned between them: pad by that, with r the box's largest extent
        // from the rotation centre (bounded by the swept box's own diagonal).
        let max_angle = self.max_rotation_per_sample(samples);
        let radius = (Vec3::from(out.max) - Vec3::from(out.min)).length();
        let pad = radius * (1.0 - (0.5 * max_angle).cos()) + 1e-6 * radius;
        Aabb::new(
            out.min - glam::Vec3A::splat(pad),
            out.max + glam::Vec3A::splat(pad),
        )
    }

    fn max_rotation_per_sample(&self, samples: usize) -> f32 {
        let Some(d) = &self.decomposed else {
            // Element-wise interpolation is affine in time: corners move on straight lines.
            return 0.0;
        };
        let per_interval = samples / (d.len() - 1);
        d.windows(2)
            .map(|w| w[0].1.angle_between(w[1].1) / per_interval as f32)
            .fold(0.0, f32::max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolates_translation_and_rotation_between_keys() {
        let a = Affine3A::from_translation(Vec3::ZERO);
        let b = Affine3A::from_rotation_translation(
            Quat::from_rotation_z(std::f32::consts::FRAC_PI_2),
            Vec3::new(2.0, 0.0, 0.0),
        );
        let m = MotionTransform::new(vec![a, b]).unwrap();
        let half = m.at(0.5);
        // Halfway: 45 degrees about Z and half the translation; a unit X stays unit length.
        let x = half.transform_vector3(Vec3::X);
        assert!((x.length() - 1.0).abs() < 1e-5, "{x}");
        assert!((x - Vec3::new(0.5f32.sqrt(), 0.5f32.sqrt(), 0.0)).length() < 1e-5);
        assert!((half.translation - glam::Vec3A::new(1.0, 0.0, 0.0)).length() < 1e-5);
        assert!(m.at(0.0).abs_diff_eq(a, 1e-6) && m.at(1.0).abs_diff_eq(b, 1e-5));
    }

    #[test]
    fn three_keys_are_piecewise() {
        let keys = [0.0, 1.0, 3.0].map(|x| Affine3A::from_translation(Vec3::new(x, 0.0, 0.0)));
        let m = MotionTransform::new(keys.to_vec()).unwrap();
        assert!((m.at(0.25).translation.x - 0.5).abs() < 1e-6);
        assert!((m.at(0.75).translation.x - 2.0).abs() < 1e-6);
        assert!(!m.is_static());
    }

    #[test]
    fn sheared_keys_interpolate_elementwise() {
        let shear = Affine3A::from_cols_array(&[
            1.0, 0.0, 0.0, 0.5, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0,
        ]);
        let m = MotionTransform::new(vec![Affine3A::IDENTITY, shear]).unwrap();
        let h = m.at(0.5);
        assert!((h.matrix3.y_axis.x - 0.25).abs() < 1e-6);
    }

    #[test]
    fn bounds_hold_every_time() {
        let b = Aabb::new(glam::Vec3A::splat(-1.0), glam::Vec3A::splat(1.0));
        let keys = vec![
            Affine3A::from_rotation_translation(Quat::IDENTITY, Vec3::ZERO),
            Affine3A::from_rotation_translation(
                Quat::from_rotation_z(3.0),
                Vec3::new(5.0, 0.0, 0.0),
            ),
        ];
        let m = MotionTransform::new(keys).unwrap();
        let bounds = m.bounds(&b);
        for k in 0..=1000 {
            let xf = m.at(k as f32 / 1000.0);
            for c in 0..8 {
                let p = Vec3::new(
                    if c & 1 == 0 { -1.0 } else { 1.0 },
                    if c & 2 == 0 { -1.0 } else { 1.0 },
                    if c & 4 == 0 { -1.0 } else { 1.0 },
                );
                let w = glam::Vec3A::from(xf.transform_point3(p));
                assert!(
                    w.cmpge(bounds.min).all() && w.cmple(bounds.max).all(),
                    "{w} at {k}"
                );
            }
        }
    }

    #[test]
    fn refuses_degenerate_keys() {
        assert!(MotionTransform::new(vec![Affine3A::IDENTITY]).is_none());
        assert!(
            MotionTransform::new(vec![Affine3A::IDENTITY, Affine3A::from_scale(Vec3::ZERO)])
                .is_none()
        );
    }
}
