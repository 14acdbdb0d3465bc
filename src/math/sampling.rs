//! Warps from the unit square to common domains, each with its pdf.
//! One implementation of each: BSDFs, lights and the camera all call these.

use super::{INV_2PI, INV_4PI, INV_PI, PI};
use glam::{DVec3, Vec2, Vec3};

/// Concentric square-to-disk map (Shirley & Chiu 1997): low distortion, keeps stratification.
pub fn sample_uniform_disk_concentric(u: Vec2) -> Vec2 {
    let o = 2.0 * u - Vec2::ONE;
    if o.x == 0.0 && o.y == 0.0 {
        return Vec2::ZERO;
    }
    let (r, theta) = if o.x.abs() > o.y.abs() {
        (o.x, (PI / 4.0) * (o.y / o.x))
    } else {
        (o.y, PI / 2.0 - (PI / 4.0) * (o.x / o.y))
    };
    r * Vec2::new(theta.cos(), theta.sin())
}

/// Cosine-weighted hemisphere around +z (Malley's method).
pub fn sample_cosine_hemisphere(u: Vec2) -> Vec3 {
    let d = sample_uniform_disk_concentric(u);
    let z = (1.0 - d.length_squared()).max(0.0).sqrt();
    Vec3::new(d.x, d.y, z)
}

#[inline]
pub fn cosine_hemisphere_pdf(cos_theta: f32) -> f32 {
    cos_theta.max(0.0) * INV_PI
}

pub fn sample_uniform_sphere(u: Vec2) -> Vec3 {
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

#[inline]
pub fn uniform_sphere_pdf() -> f32 {
    INV_4PI
}

pub fn sample_uniform_hemisphere(u: Vec2) -> Vec3 {
    let z = u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

#[inline]
pub fn uniform_hemisphere_pdf() -> f32 {
    INV_2PI
}

/// The unit vector at polar angle theta (given by its sine and cosine) from +z and azimuth
/// `phi` from +x.
#[inline]
pub fn spherical_direction(sin_theta: f32, cos_theta: f32, phi: f32) -> Vec3 {
    Vec3::new(sin_theta * phi.cos(), sin_theta * phi.sin(), cos_theta)
}

/// Uniform direction inside a cone around +z with the given cosine of the half-angle.
pub fn sample_uniform_cone(u: Vec2, cos_theta_max: f32) -> Vec3 {
    let cos_theta = (1.0 - u.x) + u.x * cos_theta_max;
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    spherical_direction(sin_theta, cos_theta, 2.0 * PI * u.y)
}

#[inline]
pub fn uniform_cone_pdf(cos_theta_max: f32) -> f32 {
    1.0 / (2.0 * PI * (1.0 - cos_theta_max))
}

/// Uniform direction inside a cone around +z given 1 - cos of its half-angle: exact for the
/// thin cones of a distant sphere or the sun's disc, where 1 - cos_theta_max rounds to 0 in f32
/// (compute it as 2 sin^2(theta / 2), or sin^2 / (1 + cos)).
pub fn sample_uniform_cone_one_minus_cos(u: Vec2, one_minus_cos_max: f32) -> Vec3 {
    let one_minus = u.x * one_minus_cos_max;
    let cos_theta = 1.0 - one_minus;
    let sin_theta = (one_minus * (2.0 - one_minus)).max(0.0).sqrt();
    spherical_direction(sin_theta, cos_theta, 2.0 * PI * u.y)
}

/// Density of [`sample_uniform_cone_one_minus_cos`] (per steradian).
#[inline]
pub fn uniform_cone_pdf_one_minus_cos(one_minus_cos_max: f32) -> f32 {
    INV_2PI / one_minus_cos_max
}

/// Uniform point on a triangle as barycentrics (b0, b1); b2 = 1 - b0 - b1.
/// Uses the low-distortion square-to-triangle map of Heitz 2019.
pub fn sample_uniform_triangle(u: Vec2) -> (f32, f32) {
    let (b0, b1);
    if u.x < u.y {
        b0 = u.x / 2.0;
        b1 = u.y - b0;
    } else {
        b1 = u.y / 2.0;
        b0 = u.x - b1;
    }
    (b0, b1)
}

/// Solid angle (steradians) of the spherical triangle spanned by the unit directions `a`, `b`,
/// `c`: Van Oosterom & Strackee 1983, tan(omega / 2) = |a . (b x c)| / (1 + a.b + b.c + c.a),
/// accurate for small triangles where the angle excess alpha + beta + gamma - pi cancels.
pub fn spherical_triangle_solid_angle(a: Vec3, b: Vec3, c: Vec3) -> f32 {
    let (a, b, c) = (a.as_dvec3(), b.as_dvec3(), c.as_dvec3());
    let triple = a.dot(b.cross(c)).abs();
    let den = 1.0 + a.dot(b) + b.dot(c) + c.dot(a);
    (2.0 * triple.atan2(den)) as f32
}

/// A direction distributed uniformly (per steradian) over the spherical triangle of the unit
/// directions `a`, `b`, `c`: Arvo 1995, "Stratified sampling of spherical triangles". `u.x`
/// chooses the sub-triangle a-b-c' of area u.x times the whole (c' on the arc a-c), `u.y` the
/// point on the arc from b to c'; the map is continuous, so stratified `u` stay stratified.
/// None for a degenerate triangle. The density is 1 / `solid_angle`, the triangle's
/// ([`spherical_triangle_solid_angle`], which callers have already computed: Arvo's own angle
/// excess alpha + beta + gamma - pi would cost two more arc cosines). In f64: the construction
/// subtracts nearly equal angles for small triangles.
pub fn sample_spherical_triangle(
    a: Vec3,
    b: Vec3,
    c: Vec3,
    solid_angle: f32,
    u: Vec2,
) -> Option<Vec3> {
    let (a, b, c) = (a.as_dvec3(), b.as_dvec3(), c.as_dvec3());
    if !(solid_angle > 0.0) {
        return None;
    }
    // The angle at vertex a: between the great circles a-b and a-c, i.e. between their
    // planes' normals (sin from their cross product, cos from their dot product).
    let n_ab = a.cross(b).try_normalize()?;
    let n_ac = a.cross(c).try_normalize()?;
    let (sin_alpha, cos_alpha) = (n_ab.cross(n_ac).length(), n_ab.dot(n_ac));
    let alpha = sin_alpha.atan2(cos_alpha);
    // Arvo's eqs. for the sub-triangle of area u.x * area: cos of the arc a-c' (q).
    let sub_area = u.x as f64 * solid_angle as f64;
    let (s, t) = (sub_area - alpha).sin_cos();
    let k1 = t - cos_alpha;
    let k2 = s + sin_alpha * a.dot(b);
    let den = (k2 * s + k1 * t) * sin_alpha;
    let q = if den.abs() > 0.0 {
        (((k2 * t - k1 * s) * cos_alpha - k2) / den).clamp(-1.0, 1.0)
    } else {
        1.0
    };
    let c_prime = q * a + (1.0 - q * q).max(0.0).sqrt() * orthogonal_part(c, a)?;
    // Uniform in z = cos of the angle from b along the arc b-c'.
    let z = 1.0 - u.y as f64 * (1.0 - c_prime.dot(b));
    let dir =
        z * b + (1.0 - z * z).max(0.0).sqrt() * orthogonal_part(c_prime, b).unwrap_or(DVec3::ZERO);
    let dir = dir.try_normalize()?;
    Some(dir.as_vec3())
}

/// The unit vector along the part of `v` orthogonal to the unit vector `axis` (Gram-Schmidt).
#[inline]
fn orthogonal_part(v: DVec3, axis: DVec3) -> Option<DVec3> {
    (v - v.dot(axis) * axis).try_normalize()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn warps_land_in_their_domain() {
        for i in 0..64 {
            for j in 0..64 {
                let u = Vec2::new((i as f32 + 0.5) / 64.0, (j as f32 + 0.5) / 64.0);
                assert!(sample_uniform_disk_concentric(u).length() <= 1.0 + 1e-6);
                let h = sample_cosine_hemisphere(u);
                assert!(h.z >= 0.0 && (h.length() - 1.0).abs() < 1e-5);
                assert!((sample_uniform_sphere(u).length() - 1.0).abs() < 1e-5);
                let c = sample_uniform_cone(u, 0.9);
                assert!(c.z >= 0.9 - 1e-6);
                let (b0, b1) = sample_uniform_triangle(u);
                assert!(b0 >= 0.0 && b1 >= 0.0 && b0 + b1 <= 1.0 + 1e-6);
            }
        }
    }
    /// Arvo's construction is uniform over the spherical triangle: split the planar triangle
    /// into 16 sub-triangles (midpoint subdivision twice); the fraction of sampled directions
    /// that pass through each equals its solid angle over the whole (chi-square, 15 degrees of
    /// freedom), for a near, a far and an obtuse sliver triangle. Every direction passes through
    /// the triangle (to f32 rounding: 1e-4 in barycentrics 14 units away).
    #[test]
    fn spherical_triangle_sampling_is_uniform_in_solid_angle() {
        fn split(t: [Vec3; 3], depth: u32, out: &mut Vec<[Vec3; 3]>) {
            if depth == 0 {
                out.push(t);
                return;
            }
            let [a, b, c] = t;
            let (ab, bc, ca) = ((a + b) / 2.0, (b + c) / 2.0, (c + a) / 2.0);
            for s in [[a, ab, ca], [ab, b, bc], [ca, bc, c], [ab, bc, ca]] {
                split(s, depth - 1, out);
            }
        }
        // The ray from the origin along d meets t (to rounding).
        fn hits(t: &[Vec3; 3], d: Vec3) -> bool {
            let (e1, e2) = (t[1] - t[0], t[2] - t[0]);
            crate::geometry::ray_plane_barycentrics(Vec3::ZERO, d, t[0], e1, e2).is_some_and(
                |(tt, u, v)| u >= -1e-4 && v >= -1e-4 && u + v <= 1.0 + 1e-4 && tt > 0.0,
            )
        }
        let triangles = [
            [
                Vec3::new(-1.0, -1.0, 1.0),
                Vec3::new(1.5, -0.5, 0.8),
                Vec3::new(0.0, 1.2, 0.3),
            ],
            [
                Vec3::new(9.0, 0.0, 10.0),
                Vec3::new(10.0, 0.2, 10.0),
                Vec3::new(9.5, 1.0, 10.5),
            ],
            [
                Vec3::new(-3.0, 0.0, 0.5),
                Vec3::new(3.0, 0.1, 0.5),
                Vec3::new(0.0, 0.3, 0.6),
            ],
        ];
        for tri in triangles {
            let mut parts = Vec::new();
            split(tri, 2, &mut parts);
            let dirs = tri.map(|v| v.normalize());
            let omega = spherical_triangle_solid_angle(dirs[0], dirs[1], dirs[2]) as f64;
            let expected: Vec<f64> = parts
                .iter()
                .map(|t| {
                    let d = t.map(|v| v.normalize());
                    spherical_triangle_solid_angle(d[0], d[1], d[2]) as f64 / omega
                })
                .collect();
            assert!(
                (expected.iter().sum::<f64>() - 1.0).abs() < 1e-3,
                "{expected:?}"
            );
            let n = 200_000;
            let mut counts = vec![0usize; parts.len()];
            let mut rng = crate::sampler::Pcg32::new(7, 3, 11);
            for _ in 0..n {
                let u = rng.next_2d();
                let d = sample_spherical_triangle(dirs[0], dirs[1], dirs[2], omega as f32, u)
                    .expect("direction");
                assert!(hits(&tri, d), "{d} misses {tri:?}");
                if let Some(k) = parts.iter().position(|t| hits(t, d)) {
                    counts[k] += 1;
                }
            }
            let chi2: f64 = counts
                .iter()
                .zip(&expected)
                .map(|(&c, &p)| (c as f64 - n as f64 * p).powi(2) / (n as f64 * p))
                .sum();
            // 15 degrees of freedom: P(chi2 > 37.7) = 0.001.
            assert!(
                chi2 < 37.7,
                "chi2 {chi2} for {tri:?}: {counts:?} vs {expected:?}"
            );
        }
    }

    /// The solid angle of a face of the unit cube seen from its centre is 4 pi / 6; each of the
    /// two triangles of the face takes half.
    #[test]
    fn spherical_triangle_solid_angle_of_a_cube_face() {
        let c = [
            Vec3::new(-1.0, -1.0, 1.0),
            Vec3::new(1.0, -1.0, 1.0),
            Vec3::new(1.0, 1.0, 1.0),
            Vec3::new(-1.0, 1.0, 1.0),
        ]
        .map(|v| v.normalize());
        let half = spherical_triangle_solid_angle(c[0], c[1], c[2]);
        assert!((half - 4.0 * PI / 12.0).abs() < 1e-5, "{half}");
        let tiny = [
            Vec3::new(0.0, 0.0, 1.0),
            Vec3::new(1e-3, 0.0, 1.0),
            Vec3::new(0.0, 1e-3, 1.0),
        ]
        .map(|v| v.normalize());
        let omega = spherical_triangle_solid_angle(tiny[0], tiny[1], tiny[2]);
        assert!((omega / 5e-7 - 1.0).abs() < 1e-3, "{omega}");
    }
}
