//! Small math toolbox shared by every module: shading frames, sampling warps,
//! multiple-importance-sampling heuristics. Everything geometric uses `glam::Vec3`.

pub mod catmull_rom;
pub mod distribution;
pub mod frame;
pub mod sampling;

pub use distribution::{DiscreteDistribution, InverseCdf};
pub use frame::Frame;

pub const PI: f32 = std::f32::consts::PI;
pub const INV_PI: f32 = std::f32::consts::FRAC_1_PI;
pub const INV_2PI: f32 = 0.5 * std::f32::consts::FRAC_1_PI;
pub const INV_4PI: f32 = 0.25 * std::f32::consts::FRAC_1_PI;

/// Power heuristic with beta = 2 (Veach 1997, eq. 9.13), for one sample of each strategy.
#[inline]
pub fn power_heuristic(pdf_a: f32, pdf_b: f32) -> f32 {
    let a = pdf_a * pdf_a;
    let b = pdf_b * pdf_b;
    if a.is_infinite() {
        return 1.0;
    }
    if a + b <= 0.0 {
        0.0
    } else {
        a / (a + b)
    }
}

#[inline]
pub fn sqr(x: f32) -> f32 {
    x * x
}

/// sqrt that tolerates tiny negative arguments produced by rounding.
#[inline]
pub fn safe_sqrt(x: f32) -> f32 {
    x.max(0.0).sqrt()
}

#[inline]
pub fn lerp(t: f32, a: f32, b: f32) -> f32 {
    (1.0 - t) * a + t * b
}
