//! PLACEHOLDER (being replaced by tabulated CIE 1931 2-degree data): analytic multi-lobe fit of
//! Wyman, Sloan & Shirley 2013 and a 6504 K blackbody standing in for D65.
use glam::Vec3;

pub const CIE_Y_INTEGRAL: f32 = 106.856895;

fn g(x: f32, mu: f32, s1: f32, s2: f32) -> f32 {
    let t = (x - mu) / if x < mu { s1 } else { s2 };
    (-0.5 * t * t).exp()
}

pub fn cie_xyz_bar(lambda: f32) -> Vec3 {
    let x = 1.056 * g(lambda, 599.8, 37.9, 31.0) + 0.362 * g(lambda, 442.0, 16.0, 26.7)
        - 0.065 * g(lambda, 501.1, 20.4, 26.2);
    let y = 0.821 * g(lambda, 568.8, 46.9, 40.5) + 0.286 * g(lambda, 530.9, 16.3, 31.1);
    let z = 1.217 * g(lambda, 437.0, 11.8, 36.0) + 0.681 * g(lambda, 459.0, 26.0, 13.8);
    Vec3::new(x, y, z)
}

pub fn d65(lambda: f32) -> f32 {
    let l = lambda * 1e-9;
    let c1 = 3.741_771_9e-16f64;
    let c2 = 1.438_776_9e-2f64;
    let l = l as f64;
    let b = c1 / (l.powi(5) * ((c2 / (l * 6504.0)).exp() - 1.0));
    (b / 1.0e13) as f32
}

/// D65 scaled so that its luminance is 1 (Y of the normalised illuminant = 1).
pub fn d65_normalized(lambda: f32) -> f32 {
    static SCALE: std::sync::OnceLock<f32> = std::sync::OnceLock::new();
    let scale = *SCALE.get_or_init(|| {
        let mut y = 0.0;
        for l in 360..=830 {
            y += d65(l as f32) * cie_xyz_bar(l as f32).y;
        }
        CIE_Y_INTEGRAL / y
    });
    d65(lambda) * scale
}
