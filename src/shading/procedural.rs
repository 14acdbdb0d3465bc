//! Procedural textures with Blender's definitions, so a pattern lands where the user saw it in
//! Cycles.

use glam::Vec3;

/// Checker Texture factor: 1 in Color1's cells, 0 in Color2's (Blender: the x and y cell
/// parities agree exactly where the z parity is odd). The tiny offset and shrink keep integer-coordinate faces (a unit cube's sides) off
/// the cell boundaries, as Blender does.
pub fn checker(p: Vec3, scale: f32) -> f32 {
    let p = (p * scale + Vec3::splat(1e-6)) * 0.999_999;
    let cell = |x: f32| (x.floor() as i64).unsigned_abs() % 2;
    let (xi, yi, zi) = (cell(p.x), cell(p.y), cell(p.z));
    if (xi == yi) == (zi == 1) {
        1.0
    } else {
        0.0
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GradientKind {
    Linear,
    Quadratic,
    Easing,
    Diagonal,
    Radial,
    QuadraticSphere,
    Spherical,
}

pub const GRADIENT_KINDS: &[(&str, GradientKind)] = &[
    ("linear", GradientKind::Linear),
    ("quadratic", GradientKind::Quadratic),
    ("easing", GradientKind::Easing),
    ("diagonal", GradientKind::Diagonal),
    ("radial", GradientKind::Radial),
    ("quadratic_sphere", GradientKind::QuadraticSphere),
    ("spherical", GradientKind::Spherical),
];

/// Gradient Texture factor, clamped to [0, 1] as the node's output is.
pub fn gradient(p: Vec3, kind: GradientKind) -> f32 {
    let f = match kind {
        GradientKind::Linear => p.x,
        GradientKind::Quadratic => {
            let r = p.x.max(0.0);
            r * r
        }
        GradientKind::Easing => {
            let r = p.x.clamp(0.0, 1.0);
            let t = r * r;
            3.0 * t - 2.0 * t * r
        }
        GradientKind::Diagonal => (p.x + p.y) * 0.5,
        GradientKind::Radial => p.y.atan2(p.x) / (2.0 * std::f32::consts::PI) + 0.5,
        GradientKind::QuadraticSphere => {
            let r = (0.999_999 - p.length()).max(0.0);
            r * r
        }
        GradientKind::Spherical => (0.999_999 - p.length()).max(0.0),
    };
    f.clamp(0.0, 1.0)
}

/// Wave Texture: bands or rings with a sine, saw or triangle profile, optionally distorted by
/// normalised fBM noise (Blender's node; `p` already multiplied by Scale).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Wave {
    pub rings: bool,
    /// Bands: 0 = x, 1 = y, 2 = z, 3 = diagonal. Rings: 0 = x, 1 = y, 2 = z, 3 = spherical.
    pub direction: u8,
    /// 0 = sine, 1 = saw, 2 = triangle.
    pub profile: u8,
}

impl Wave {
    pub fn eval(
        &self,
        p: Vec3,
        distortion: f32,
        detail: f32,
        dscale: f32,
        droughness: f32,
        phase: f32,
    ) -> f32 {
        use crate::shading::noise::{Fractal, FractalKind};
        // Blender nudges unit coordinates off the exact lattice.
        let p = (p + Vec3::splat(1e-6)) * 0.999_999;
        let mut n = if !self.rings {
            match self.direction {
                0 => p.x * 20.0,
                1 => p.y * 20.0,
                2 => p.z * 20.0,
                _ => (p.x + p.y + p.z) * 10.0,
            }
        } else {
            let rp = match self.direction {
                0 => p * Vec3::new(0.0, 1.0, 1.0),
                1 => p * Vec3::new(1.0, 0.0, 1.0),
                2 => p * Vec3::new(1.0, 1.0, 0.0),
                _ => p,
            };
            rp.length() * 20.0
        };
        n += phase;
        if distortion != 0.0 {
            let fbm = Fractal {
                kind: FractalKind::Fbm,
                normalize: true,
                detail: detail.clamp(0.0, 15.0),
                roughness: droughness,
                lacunarity: 2.0,
                offset: 0.0,
                gain: 1.0,
            };
            n += distortion * (fbm.eval(p * dscale) * 2.0 - 1.0);
        }
        match self.profile {
            0 => 0.5 + 0.5 * (n - std::f32::consts::FRAC_PI_2).sin(),
            1 => {
                let n = n / std::f32::consts::TAU;
                n - n.floor()
            }
            _ => {
                let n = n / std::f32::consts::TAU;
                (n - (n + 0.5).floor()).abs() * 2.0
            }
        }
    }
}

/// Magic Texture: Blender's nested sines and cosines of `depth` levels (colour in about
/// [0, 1]; the node's Fac is the average).
pub fn magic(p: Vec3, scale: f32, depth: i32, distortion: f32) -> Vec3 {
    let tau = std::f32::consts::TAU;
    let (px, py, pz) = (p.x % tau, p.y % tau, p.z % tau);
    let mut x = ((px + py + pz) * 5.0 * scale).sin();
    let mut y = ((-px + py - pz) * 5.0 * scale).cos();
    let mut z = -((-px - py + pz) * 5.0 * scale).cos();
    let d = distortion;
    if depth > 0 {
        x *= d;
        y *= d;
        z *= d;
        y = -(x - y + z).cos() * d;
        // Each further level rewrites one channel from all three.
        let steps: [&dyn Fn(f32, f32, f32) -> (u8, f32); 9] = [
            &|x, y, z| (0, (x - y - z).cos()),
            &|x, y, z| (2, (-x - y - z).sin()),
            &|x, y, z| (0, -(-x + y - z).cos()),
            &|x, y, z| (1, -(-x + y + z).sin()),
            &|x, y, z| (1, -(-x + y + z).cos()),
            &|x, y, z| (0, (x + y + z).cos()),
            &|x, y, z| (2, (x + y - z).sin()),
            &|x, y, z| (0, -(-x - y + z).cos()),
            &|x, y, z| (1, -(x - y + z).sin()),
        ];
        for step in steps.iter().take((depth - 1).clamp(0, 9) as usize) {
            let (c, v) = step(x, y, z);
            match c {
                0 => x = v * d,
                1 => y = v * d,
                _ => z = v * d,
            }
        }
    }
    if d != 0.0 {
        let d2 = d * 2.0;
        x /= d2;
        y /= d2;
        z /= d2;
    }
    Vec3::new(0.5 - x, 0.5 - y, 0.5 - z)
}

/// Brick Texture's settings (the node's properties, not sockets).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Brick {
    pub offset: f32,
    pub offset_frequency: i32,
    pub squash: f32,
    pub squash_frequency: i32,
}

/// Blender's fast integer noise for brick tints, in [0, 1).
fn brick_noise(n: u32) -> f32 {
    let mut n = n.wrapping_add(1013) & 0x7fff_ffff;
    n ^= n >> 13;
    let nn = n
        .wrapping_mul(
            n.wrapping_mul(n)
                .wrapping_mul(60493)
                .wrapping_add(19_990_303),
        )
        .wrapping_add(1_376_312_589)
        & 0x7fff_ffff;
    0.5 * (nn as f32 / 1_073_741_824.0)
}

impl Brick {
    /// `(tint, mortar)` at `p` (already multiplied by Scale).
    #[allow(clippy::too_many_arguments)]
    pub fn eval(
        &self,
        p: Vec3,
        mortar_size: f32,
        mortar_smooth: f32,
        bias: f32,
        brick_width: f32,
        row_height: f32,
    ) -> (f32, f32) {
        let mut width = brick_width;
        let rownum = (p.y / row_height).floor() as i32;
        let mut offset = 0.0;
        if self.offset_frequency != 0 && self.squash_frequency != 0 {
            if rownum % self.squash_frequency == 0 {
                width *= self.squash;
            }
            if rownum % self.offset_frequency == 0 {
                offset = width * self.offset;
            }
        }
        let bricknum = ((p.x + offset) / width).floor() as i32;
        let x = (p.x + offset) - width * bricknum as f32;
        let y = p.y - row_height * rownum as f32;
        let key = (rownum.wrapping_shl(16)).wrapping_add(bricknum & 0xFFFF) as u32;
        let tint = (brick_noise(key) + bias).clamp(0.0, 1.0);
        let min_dist = x.min(y).min((width - x).min(row_height - y));
        let mortar = if min_dist >= mortar_size {
            0.0
        } else if mortar_smooth == 0.0 {
            1.0
        } else {
            let t = ((1.0 - min_dist / mortar_size) / mortar_smooth).clamp(0.0, 1.0);
            3.0 * t * t - 2.0 * t * t * t
        };
        (tint, mortar)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn checker_cells_alternate() {
        let c = |x, y, z| checker(Vec3::new(x, y, z), 1.0);
        assert_ne!(c(0.5, 0.5, 0.5), c(1.5, 0.5, 0.5));
        assert_ne!(c(0.5, 0.5, 0.5), c(0.5, 1.5, 0.5));
        assert_ne!(c(0.5, 0.5, 0.5), c(0.5, 0.5, 1.5));
        assert_eq!(c(0.5, 0.5, 0.5), c(1.5, 1.5, 0.5));
        assert_eq!(c(0.5, 0.5, 0.5), c(-0.5, -0.5, 0.5));
        // Scale 2 halves the cells.
        assert_ne!(
            checker(Vec3::splat(0.25), 2.0),
            checker(Vec3::new(0.75, 0.25, 0.25), 2.0)
        );
    }

    #[test]
    fn gradients() {
        let p = Vec3::new(0.25, 0.75, 0.0);
        assert_eq!(gradient(p, GradientKind::Linear), 0.25);
        assert_eq!(gradient(p, GradientKind::Quadratic), 0.0625);
        assert_eq!(gradient(p, GradientKind::Diagonal), 0.5);
        assert!((gradient(Vec3::new(0.0, 1.0, 0.0), GradientKind::Radial) - 0.75).abs() < 1e-6);
        assert_eq!(
            gradient(Vec3::new(2.0, 0.0, 0.0), GradientKind::Linear),
            1.0
        );
        assert!((gradient(Vec3::new(0.5, 0.0, 0.0), GradientKind::Spherical) - 0.5).abs() < 1e-5);
        assert_eq!(
            gradient(Vec3::new(0.5, 0.0, 0.0), GradientKind::Easing),
            0.5
        );
    }
}
