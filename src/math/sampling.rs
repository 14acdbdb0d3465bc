//! Warps from the unit square to common domains, each with its pdf.
//! One implementation of each: BSDFs, lights and the camera all call these.

use super::{INV_2PI, INV_4PI, INV_PI, PI};
use glam::{Vec2, Vec3};

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

/// Uniform direction inside a cone around +z with the given cosine of the half-angle.
pub fn sample_uniform_cone(u: Vec2, cos_theta_max: f32) -> Vec3 {
    let cos_theta = (1.0 - u.x) + u.x * cos_theta_max;
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    let phi = 2.0 * PI * u.y;
    Vec3::new(sin_theta * phi.cos(), sin_theta * phi.sin(), cos_theta)
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
    let phi = 2.0 * PI * u.y;
    Vec3::new(sin_theta * phi.cos(), sin_theta * phi.sin(), cos_theta)
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
}
