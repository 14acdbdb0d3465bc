//! Blender's Math and Vector Math node operations, with Cycles' conventions for the undefined
//! cases (division by zero gives 0, `safe_powf`, `safe_logf`, clamped asin/acos, ...): the
//! values a Blender user sees in Cycles (`intern/cycles/kernel/svm/math_util.h` documents them).

use glam::Vec3;

/// Operations of the Math node, in Blender's order; `name` is Blender's enum identifier in
/// lower case (the add-on writes `node.operation.lower()`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum MathOp {
    Add,
    Subtract,
    Multiply,
    Divide,
    MultiplyAdd,
    Power,
    Logarithm,
    Sqrt,
    InverseSqrt,
    Absolute,
    Exponent,
    Minimum,
    Maximum,
    LessThan,
    GreaterThan,
    Sign,
    Compare,
    SmoothMin,
    SmoothMax,
    Round,
    Floor,
    Ceil,
    Trunc,
    Fraction,
    Modulo,
    FlooredModulo,
    Wrap,
    Snap,
    Pingpong,
    Sine,
    Cosine,
    Tangent,
    Arcsine,
    Arccosine,
    Arctangent,
    Arctan2,
    Sinh,
    Cosh,
    Tanh,
    Radians,
    Degrees,
}

pub const MATH_OPS: &[(&str, MathOp)] = &[
    ("add", MathOp::Add),
    ("subtract", MathOp::Subtract),
    ("multiply", MathOp::Multiply),
    ("divide", MathOp::Divide),
    ("multiply_add", MathOp::MultiplyAdd),
    ("power", MathOp::Power),
    ("logarithm", MathOp::Logarithm),
    ("sqrt", MathOp::Sqrt),
    ("inverse_sqrt", MathOp::InverseSqrt),
    ("absolute", MathOp::Absolute),
    ("exponent", MathOp::Exponent),
    ("minimum", MathOp::Minimum),
    ("maximum", MathOp::Maximum),
    ("less_than", MathOp::LessThan),
    ("greater_than", MathOp::GreaterThan),
    ("sign", MathOp::Sign),
    ("compare", MathOp::Compare),
    ("smooth_min", MathOp::SmoothMin),
    ("smooth_max", MathOp::SmoothMax),
    ("round", MathOp::Round),
    ("floor", MathOp::Floor),
    ("ceil", MathOp::Ceil),
    ("trunc", MathOp::Trunc),
    ("fract", MathOp::Fraction),
    ("modulo", MathOp::Modulo),
    ("floored_modulo", MathOp::FlooredModulo),
    ("wrap", MathOp::Wrap),
    ("snap", MathOp::Snap),
    ("pingpong", MathOp::Pingpong),
    ("sine", MathOp::Sine),
    ("cosine", MathOp::Cosine),
    ("tangent", MathOp::Tangent),
    ("arcsine", MathOp::Arcsine),
    ("arccosine", MathOp::Arccosine),
    ("arctangent", MathOp::Arctangent),
    ("arctan2", MathOp::Arctan2),
    ("sinh", MathOp::Sinh),
    ("cosh", MathOp::Cosh),
    ("tanh", MathOp::Tanh),
    ("radians", MathOp::Radians),
    ("degrees", MathOp::Degrees),
];

#[inline]
pub fn safe_divide(a: f32, b: f32) -> f32 {
    if b != 0.0 {
        a / b
    } else {
        0.0
    }
}

/// `a^b`, 0 where the real power is undefined (negative base, non-integer exponent).
#[inline]
pub fn safe_pow(a: f32, b: f32) -> f32 {
    if a < 0.0 && b != b.trunc() {
        0.0
    } else {
        a.powf(b)
    }
}

/// `value` wrapped into [min, max) (Blender's `wrapf`; `min` when the range is empty).
#[inline]
pub fn wrap(value: f32, max: f32, min: f32) -> f32 {
    let range = max - min;
    if range != 0.0 {
        value - range * ((value - min) / range).floor()
    } else {
        min
    }
}

/// The truncated remainder (C `fmodf`), 0 for a zero divisor.
#[inline]
pub fn safe_modulo(a: f32, b: f32) -> f32 {
    if b != 0.0 {
        a % b
    } else {
        0.0
    }
}

#[inline]
fn floored_modulo(a: f32, b: f32) -> f32 {
    if b != 0.0 {
        a - (a / b).floor() * b
    } else {
        0.0
    }
}

/// Polynomial smooth minimum with blend distance `k` (Blender's `smoothminf`).
#[inline]
fn smooth_min(a: f32, b: f32, k: f32) -> f32 {
    if k != 0.0 {
        let h = (k - (a - b).abs()).max(0.0) / k;
        a.min(b) - h * h * h * k * (1.0 / 6.0)
    } else {
        a.min(b)
    }
}

#[inline]
fn pingpong(a: f32, b: f32) -> f32 {
    if b != 0.0 {
        let f = (a - b) / (b * 2.0);
        ((f - f.floor()) * b * 2.0 - b).abs()
    } else {
        0.0
    }
}

#[inline]
fn sign(a: f32) -> f32 {
    if a > 0.0 {
        1.0
    } else if a < 0.0 {
        -1.0
    } else {
        0.0
    }
}

impl MathOp {
    pub fn eval(self, a: f32, b: f32, c: f32) -> f32 {
        use MathOp::*;
        match self {
            Add => a + b,
            Subtract => a - b,
            Multiply => a * b,
            Divide => safe_divide(a, b),
            MultiplyAdd => a * b + c,
            Power => safe_pow(a, b),
            Logarithm => {
                if a > 0.0 && b > 0.0 {
                    safe_divide(a.ln(), b.ln())
                } else {
                    0.0
                }
            }
            Sqrt => {
                if a > 0.0 {
                    a.sqrt()
                } else {
                    0.0
                }
            }
            InverseSqrt => {
                if a > 0.0 {
                    1.0 / a.sqrt()
                } else {
                    0.0
                }
            }
            Absolute => a.abs(),
            Exponent => a.exp(),
            Minimum => a.min(b),
            Maximum => a.max(b),
            LessThan => (a < b) as u8 as f32,
            GreaterThan => (a > b) as u8 as f32,
            Sign => sign(a),
            Compare => ((a - b).abs() <= c.max(1e-5)) as u8 as f32,
            SmoothMin => smooth_min(a, b, c),
            SmoothMax => -smooth_min(-a, -b, c),
            Round => (a + 0.5).floor(),
            Floor => a.floor(),
            Ceil => a.ceil(),
            Trunc => a.trunc(),
            Fraction => a - a.floor(),
            Modulo => safe_modulo(a, b),
            FlooredModulo => floored_modulo(a, b),
            Wrap => wrap(a, b, c),
            Snap => safe_divide(a, b).floor() * b,
            Pingpong => pingpong(a, b),
            Sine => a.sin(),
            Cosine => a.cos(),
            Tangent => a.tan(),
            Arcsine => a.clamp(-1.0, 1.0).asin(),
            Arccosine => a.clamp(-1.0, 1.0).acos(),
            Arctangent => a.atan(),
            Arctan2 => a.atan2(b),
            Sinh => a.sinh(),
            Cosh => a.cosh(),
            Tanh => a.tanh(),
            Radians => a.to_radians(),
            Degrees => a.to_degrees(),
        }
    }
}

/// Operations of the Vector Math node (Blender's identifiers in lower case).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VectorMathOp {
    Add,
    Subtract,
    Multiply,
    Divide,
    MultiplyAdd,
    CrossProduct,
    Project,
    Reflect,
    Refract,
    Faceforward,
    DotProduct,
    Distance,
    Length,
    Scale,
    Normalize,
    Snap,
    Floor,
    Ceil,
    Modulo,
    Wrap,
    Fraction,
    Absolute,
    Minimum,
    Maximum,
    Sine,
    Cosine,
    Tangent,
    Power,
    Sign,
}

pub const VECTOR_MATH_OPS: &[(&str, VectorMathOp)] = &[
    ("add", VectorMathOp::Add),
    ("subtract", VectorMathOp::Subtract),
    ("multiply", VectorMathOp::Multiply),
    ("divide", VectorMathOp::Divide),
    ("multiply_add", VectorMathOp::MultiplyAdd),
    ("cross_product", VectorMathOp::CrossProduct),
    ("project", VectorMathOp::Project),
    ("reflect", VectorMathOp::Reflect),
    ("refract", VectorMathOp::Refract),
    ("faceforward", VectorMathOp::Faceforward),
    ("dot_product", VectorMathOp::DotProduct),
    ("distance", VectorMathOp::Distance),
    ("length", VectorMathOp::Length),
    ("scale", VectorMathOp::Scale),
    ("normalize", VectorMathOp::Normalize),
    ("snap", VectorMathOp::Snap),
    ("floor", VectorMathOp::Floor),
    ("ceil", VectorMathOp::Ceil),
    ("modulo", VectorMathOp::Modulo),
    ("wrap", VectorMathOp::Wrap),
    ("fraction", VectorMathOp::Fraction),
    ("absolute", VectorMathOp::Absolute),
    ("minimum", VectorMathOp::Minimum),
    ("maximum", VectorMathOp::Maximum),
    ("sine", VectorMathOp::Sine),
    ("cosine", VectorMathOp::Cosine),
    ("tangent", VectorMathOp::Tangent),
    ("power", VectorMathOp::Power),
    ("sign", VectorMathOp::Sign),
];

fn map3(v: Vec3, f: impl Fn(f32) -> f32) -> Vec3 {
    Vec3::new(f(v.x), f(v.y), f(v.z))
}

fn zip3(a: Vec3, b: Vec3, f: impl Fn(f32, f32) -> f32) -> Vec3 {
    Vec3::new(f(a.x, b.x), f(a.y, b.y), f(a.z, b.z))
}

impl VectorMathOp {
    /// Whether the result is the Value output (else the Vector output).
    pub fn gives_value(self) -> bool {
        matches!(
            self,
            VectorMathOp::DotProduct | VectorMathOp::Distance | VectorMathOp::Length
        )
    }

    /// `(vector, value)` for inputs `a`, `b`, `c` and `scale` (Scale, and the IOR of Refract).
    pub fn eval(self, a: Vec3, b: Vec3, c: Vec3, scale: f32) -> (Vec3, f32) {
        use VectorMathOp::*;
        let v = match self {
            Add => a + b,
            Subtract => a - b,
            Multiply => a * b,
            Divide => zip3(a, b, safe_divide),
            MultiplyAdd => a * b + c,
            CrossProduct => a.cross(b),
            Project => {
                let len2 = b.length_squared();
                if len2 != 0.0 {
                    b * (a.dot(b) / len2)
                } else {
                    Vec3::ZERO
                }
            }
            Reflect => {
                let n = b.normalize_or_zero();
                a - 2.0 * n.dot(a) * n
            }
            Refract => {
                let n = b.normalize_or_zero();
                let eta = scale;
                let d = n.dot(a);
                let k = 1.0 - eta * eta * (1.0 - d * d);
                if k < 0.0 {
                    Vec3::ZERO
                } else {
                    eta * a - (eta * d + k.sqrt()) * n
                }
            }
            Faceforward => {
                if c.dot(b) < 0.0 {
                    a
                } else {
                    -a
                }
            }
            DotProduct => return (Vec3::ZERO, a.dot(b)),
            Distance => return (Vec3::ZERO, a.distance(b)),
            Length => return (Vec3::ZERO, a.length()),
            Scale => a * scale,
            Normalize => a.normalize_or_zero(),
            Snap => zip3(a, b, |x, y| safe_divide(x, y).floor() * y),
            Floor => a.floor(),
            Ceil => a.ceil(),
            Modulo => zip3(a, b, safe_modulo),
            Wrap => Vec3::new(
                wrap(a.x, b.x, c.x),
                wrap(a.y, b.y, c.y),
                wrap(a.z, b.z, c.z),
            ),
            Fraction => a - a.floor(),
            Absolute => a.abs(),
            Minimum => a.min(b),
            Maximum => a.max(b),
            Sine => map3(a, f32::sin),
            Cosine => map3(a, f32::cos),
            Tangent => map3(a, f32::tan),
            Power => zip3(a, b, safe_pow),
            Sign => map3(a, sign),
        };
        (v, 0.0)
    }
}

/// Blender's `smoothstep(edge0, edge1, x)`: 0 below, 1 at or above, Hermite between.
pub fn smoothstep(edge0: f32, edge1: f32, x: f32) -> f32 {
    if x < edge0 {
        0.0
    } else if x >= edge1 {
        1.0
    } else {
        let t = (x - edge0) / (edge1 - edge0);
        t * t * (3.0 - 2.0 * t)
    }
}

/// Perlin's smootherstep, `6t^5 - 15t^4 + 10t^3` of the clamped fraction.
pub fn smootherstep(edge0: f32, edge1: f32, x: f32) -> f32 {
    let t = safe_divide(x - edge0, edge1 - edge0).clamp(0.0, 1.0);
    t * t * t * (t * (t * 6.0 - 15.0) + 10.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn math_matches_blender_conventions() {
        let e = |op: MathOp, a, b, c| op.eval(a, b, c);
        assert_eq!(e(MathOp::Divide, 1.0, 0.0, 0.0), 0.0);
        assert_eq!(e(MathOp::Power, -2.0, 0.5, 0.0), 0.0);
        assert_eq!(e(MathOp::Power, -2.0, 3.0, 0.0), -8.0);
        assert_eq!(e(MathOp::Logarithm, 8.0, 2.0, 0.0), 3.0);
        assert_eq!(e(MathOp::Logarithm, -8.0, 2.0, 0.0), 0.0);
        assert_eq!(e(MathOp::Modulo, -5.5, 2.0, 0.0), -1.5);
        assert_eq!(e(MathOp::FlooredModulo, -5.5, 2.0, 0.0), 0.5);
        assert!((e(MathOp::Wrap, 5.5, 2.0, 0.0) - 1.5).abs() < 1e-6);
        assert!((e(MathOp::Wrap, -0.5, 1.0, 0.0) - 0.5).abs() < 1e-6);
        assert_eq!(e(MathOp::Snap, 2.7, 0.5, 0.0), 2.5);
        assert!((e(MathOp::Pingpong, 2.5, 1.0, 0.0) - 0.5).abs() < 1e-6);
        assert!((e(MathOp::Pingpong, 1.25, 1.0, 0.0) - 0.75).abs() < 1e-6);
        assert_eq!(e(MathOp::Compare, 1.0, 1.05, 0.1), 1.0);
        assert_eq!(e(MathOp::Compare, 1.0, 1.2, 0.1), 0.0);
        assert_eq!(e(MathOp::Round, -1.5, 0.0, 0.0), -1.0);
        assert_eq!(e(MathOp::Trunc, -1.5, 0.0, 0.0), -1.0);
        assert!((e(MathOp::Fraction, -1.25, 0.0, 0.0) - 0.75).abs() < 1e-6);
        assert_eq!(
            e(MathOp::Arcsine, 2.0, 0.0, 0.0),
            std::f32::consts::FRAC_PI_2
        );
        assert_eq!(e(MathOp::SmoothMin, 1.0, 2.0, 0.0), 1.0);
        // At a == b the smooth minimum lies k/6 below both.
        assert!((e(MathOp::SmoothMin, 1.0, 1.0, 0.6) - 0.9).abs() < 1e-6);
        assert!((e(MathOp::SmoothMax, 1.0, 1.0, 0.6) - 1.1).abs() < 1e-6);
        assert_eq!(e(MathOp::Sign, -3.0, 0.0, 0.0), -1.0);
        assert_eq!(e(MathOp::MultiplyAdd, 2.0, 3.0, 1.0), 7.0);
        assert_eq!(MATH_OPS.len(), 41);
    }

    #[test]
    fn vector_math() {
        let x = Vec3::X;
        let (v, _) = VectorMathOp::Reflect.eval(Vec3::new(1.0, -1.0, 0.0), Vec3::Y * 3.0, x, 1.0);
        assert!((v - Vec3::new(1.0, 1.0, 0.0)).length() < 1e-6);
        let (v, _) = VectorMathOp::Project.eval(Vec3::new(2.0, 3.0, 0.0), x * 2.0, x, 1.0);
        assert!((v - Vec3::new(2.0, 0.0, 0.0)).length() < 1e-6);
        let (_, d) = VectorMathOp::Distance.eval(Vec3::ZERO, Vec3::new(3.0, 4.0, 0.0), x, 1.0);
        assert_eq!(d, 5.0);
        // Refraction at normal incidence keeps the direction; total internal reflection gives 0.
        let (v, _) = VectorMathOp::Refract.eval(-Vec3::Z, Vec3::Z, x, 1.0 / 1.5);
        assert!((v + Vec3::Z).length() < 1e-6);
        let grazing = Vec3::new(0.9, 0.0, -(1.0f32 - 0.81).sqrt());
        let (v, _) = VectorMathOp::Refract.eval(grazing, Vec3::Z, x, 1.5);
        assert_eq!(v, Vec3::ZERO);
        let (v, _) = VectorMathOp::Divide.eval(Vec3::ONE, Vec3::new(2.0, 0.0, 4.0), x, 1.0);
        assert_eq!(v, Vec3::new(0.5, 0.0, 0.25));
        assert!(VectorMathOp::Length.gives_value());
    }

    #[test]
    fn smooth_steps() {
        assert_eq!(smoothstep(0.0, 1.0, 0.5), 0.5);
        assert_eq!(smoothstep(0.0, 1.0, 1.0), 1.0);
        assert_eq!(smootherstep(0.0, 1.0, 0.5), 0.5);
        assert!((smootherstep(0.0, 1.0, 0.25) - 0.103_515_63).abs() < 1e-6);
        assert_eq!(smootherstep(0.0, 1.0, 2.0), 1.0);
    }
}
