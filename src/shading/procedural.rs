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
