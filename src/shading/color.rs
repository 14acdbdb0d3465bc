//! Colour nodes: luminance, HSV, the Mix node's blend modes, Color Ramp, Hue/Saturation/Value,
//! Bright/Contrast, Gamma, Invert. Formulas follow Blender's definitions (the same in Cycles and
//! EEVEE), so a graph gives the colour the user picked in Blender.

use glam::{Vec3, Vec4};

/// What Blender uses to turn a colour into a float (RGB to BW, implicit colour -> float
/// socket conversion).
pub use crate::spectrum::rgb::luminance;

/// RGB -> (hue in [0,1), saturation, value), the hexcone model.
pub fn rgb_to_hsv(c: Vec3) -> Vec3 {
    let cmax = c.max_element();
    let cmin = c.min_element();
    let delta = cmax - cmin;
    let v = cmax;
    let s = if cmax != 0.0 { delta / cmax } else { 0.0 };
    if s == 0.0 {
        return Vec3::new(0.0, 0.0, v);
    }
    let cc = (Vec3::splat(cmax) - c) / delta;
    let mut h = if c.x == cmax {
        cc.z - cc.y
    } else if c.y == cmax {
        2.0 + cc.x - cc.z
    } else {
        4.0 + cc.y - cc.x
    };
    h /= 6.0;
    if h < 0.0 {
        h += 1.0;
    }
    Vec3::new(h, s, v)
}

pub fn hsv_to_rgb(hsv: Vec3) -> Vec3 {
    let (h, s, v) = (hsv.x, hsv.y, hsv.z);
    if s == 0.0 {
        return Vec3::splat(v);
    }
    let h = if h == 1.0 { 0.0 } else { h } * 6.0;
    let i = h.floor();
    let f = h - i;
    let p = v * (1.0 - s);
    let q = v * (1.0 - s * f);
    let t = v * (1.0 - s * (1.0 - f));
    match i as i32 {
        0 => Vec3::new(v, t, p),
        1 => Vec3::new(q, v, p),
        2 => Vec3::new(p, v, t),
        3 => Vec3::new(p, q, v),
        4 => Vec3::new(t, p, v),
        _ => Vec3::new(v, p, q),
    }
}

/// RGB -> (hue, saturation, lightness), for Separate/Combine Color in HSL mode.
pub fn rgb_to_hsl(c: Vec3) -> Vec3 {
    let cmax = c.max_element();
    let cmin = c.min_element();
    let l = (cmax + cmin) * 0.5;
    if cmax == cmin {
        return Vec3::new(0.0, 0.0, l);
    }
    let d = cmax - cmin;
    let s = if l > 0.5 {
        d / (2.0 - cmax - cmin)
    } else {
        d / (cmax + cmin)
    };
    let h = if cmax == c.x {
        (c.y - c.z) / d + if c.y < c.z { 6.0 } else { 0.0 }
    } else if cmax == c.y {
        (c.z - c.x) / d + 2.0
    } else {
        (c.x - c.y) / d + 4.0
    };
    Vec3::new(h / 6.0, s, l)
}

pub fn hsl_to_rgb(hsl: Vec3) -> Vec3 {
    let (h, s, l) = (hsl.x, hsl.y, hsl.z);
    let nr = ((h * 6.0 - 3.0).abs() - 1.0).clamp(0.0, 1.0);
    let ng = (2.0 - (h * 6.0 - 2.0).abs()).clamp(0.0, 1.0);
    let nb = (2.0 - (h * 6.0 - 4.0).abs()).clamp(0.0, 1.0);
    let chroma = (1.0 - (2.0 * l - 1.0).abs()) * s;
    (Vec3::new(nr, ng, nb) - 0.5) * chroma + Vec3::splat(l)
}

/// Blend modes of the Mix node (colour) and the legacy MixRGB node, Blender's identifiers in
/// lower case.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BlendMode {
    Mix,
    Darken,
    Multiply,
    Burn,
    Lighten,
    Screen,
    Dodge,
    Add,
    Overlay,
    SoftLight,
    LinearLight,
    Difference,
    Exclusion,
    Subtract,
    Divide,
    Hue,
    Saturation,
    Color,
    Value,
}

pub const BLEND_MODES: &[(&str, BlendMode)] = &[
    ("mix", BlendMode::Mix),
    ("darken", BlendMode::Darken),
    ("multiply", BlendMode::Multiply),
    ("burn", BlendMode::Burn),
    ("lighten", BlendMode::Lighten),
    ("screen", BlendMode::Screen),
    ("dodge", BlendMode::Dodge),
    ("add", BlendMode::Add),
    ("overlay", BlendMode::Overlay),
    ("soft_light", BlendMode::SoftLight),
    ("linear_light", BlendMode::LinearLight),
    ("difference", BlendMode::Difference),
    ("exclusion", BlendMode::Exclusion),
    ("subtract", BlendMode::Subtract),
    ("divide", BlendMode::Divide),
    ("hue", BlendMode::Hue),
    ("saturation", BlendMode::Saturation),
    ("color", BlendMode::Color),
    ("value", BlendMode::Value),
];

fn per_channel(a: Vec3, b: Vec3, f: impl Fn(f32, f32) -> f32) -> Vec3 {
    Vec3::new(f(a.x, b.x), f(a.y, b.y), f(a.z, b.z))
}

impl BlendMode {
    /// `a` blended with `b` by factor `t` (not clamped here: the node's `clamp_factor` does).
    pub fn blend(self, t: f32, a: Vec3, b: Vec3) -> Vec3 {
        use BlendMode::*;
        let tm = 1.0 - t;
        match self {
            Mix => a * tm + b * t,
            Add => a + b * t,
            Multiply => a * (Vec3::splat(tm) + b * t),
            Screen => Vec3::ONE - (Vec3::splat(tm) + (Vec3::ONE - b) * t) * (Vec3::ONE - a),
            Overlay => per_channel(a, b, |a, b| {
                if a < 0.5 {
                    a * (tm + 2.0 * t * b)
                } else {
                    1.0 - (tm + 2.0 * t * (1.0 - b)) * (1.0 - a)
                }
            }),
            Subtract => a - b * t,
            Divide => per_channel(a, b, |a, b| if b != 0.0 { tm * a + t * a / b } else { a }),
            Difference => a * tm + (a - b).abs() * t,
            Exclusion => (a * tm + (a + b - 2.0 * a * b) * t).max(Vec3::ZERO),
            Darken => a * tm + a.min(b) * t,
            Lighten => a * tm + a.max(b) * t,
            Dodge => per_channel(a, b, |a, b| {
                if a == 0.0 {
                    return a;
                }
                let d = 1.0 - t * b;
                if d <= 0.0 {
                    1.0
                } else {
                    (a / d).min(1.0)
                }
            }),
            Burn => per_channel(a, b, |a, b| {
                let d = tm + t * b;
                if d <= 0.0 {
                    0.0
                } else {
                    (1.0 - (1.0 - a) / d).clamp(0.0, 1.0)
                }
            }),
            Hue => {
                let hb = rgb_to_hsv(b);
                if hb.y == 0.0 {
                    return a;
                }
                let mut ha = rgb_to_hsv(a);
                ha.x = hb.x;
                a * tm + hsv_to_rgb(ha) * t
            }
            Saturation => {
                let mut ha = rgb_to_hsv(a);
                if ha.y == 0.0 {
                    return a;
                }
                ha.y = tm * ha.y + t * rgb_to_hsv(b).y;
                hsv_to_rgb(ha)
            }
            Value => {
                let mut ha = rgb_to_hsv(a);
                ha.z = tm * ha.z + t * rgb_to_hsv(b).z;
                hsv_to_rgb(ha)
            }
            Color => {
                let hb = rgb_to_hsv(b);
                if hb.y == 0.0 {
                    return a;
                }
                let mut ha = rgb_to_hsv(a);
                ha.x = hb.x;
                ha.y = hb.y;
                a * tm + hsv_to_rgb(ha) * t
            }
            SoftLight => {
                let screen = Vec3::ONE - (Vec3::ONE - b) * (Vec3::ONE - a);
                a * tm + ((Vec3::ONE - a) * b * a + a * screen) * t
            }
            LinearLight => a + (b * 2.0 - Vec3::ONE) * t,
        }
    }
}

/// Hue/Saturation/Value node: hue shifts by `hue - 0.5` turns, saturation and value scale.
pub fn hue_saturation_value(color: Vec3, hue: f32, saturation: f32, value: f32, fac: f32) -> Vec3 {
    let mut hsv = rgb_to_hsv(color);
    let h = hsv.x + hue + 0.5;
    hsv.x = h - h.floor();
    hsv.y = (hsv.y * saturation).clamp(0.0, 1.0);
    hsv.z *= value;
    let shifted = hsv_to_rgb(hsv);
    // Oversaturation can push channels below zero; Blender clamps them.
    (shifted * fac + color * (1.0 - fac)).max(Vec3::ZERO)
}

/// Bright/Contrast node.
pub fn bright_contrast(color: Vec3, bright: f32, contrast: f32) -> Vec3 {
    let a = 1.0 + contrast;
    let b = bright - contrast * 0.5;
    (color * a + Vec3::splat(b)).max(Vec3::ZERO)
}

/// Gamma node: positive channels raised to `gamma`, others unchanged.
pub fn gamma(color: Vec3, gamma: f32) -> Vec3 {
    let g = |c: f32| if c > 0.0 { c.powf(gamma) } else { c };
    Vec3::new(g(color.x), g(color.y), g(color.z))
}

/// Color Ramp interpolation modes (Blender's colour band).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum RampInterpolation {
    Constant,
    Linear,
    Ease,
    BSpline,
    Cardinal,
}

pub const RAMP_INTERPOLATIONS: &[(&str, RampInterpolation)] = &[
    ("constant", RampInterpolation::Constant),
    ("linear", RampInterpolation::Linear),
    ("ease", RampInterpolation::Ease),
    ("b_spline", RampInterpolation::BSpline),
    ("cardinal", RampInterpolation::Cardinal),
];

/// A Color Ramp: stops sorted by position, RGBA colours.
#[derive(Clone, Debug, PartialEq)]
pub struct ColorRamp {
    pub interpolation: RampInterpolation,
    pub stops: Vec<(f32, Vec4)>,
}

/// Weights of the four control points around a segment for Blender's key interpolation
/// (`key_curve_position_weights`): uniform cubic B-spline, or a cardinal spline of tension
/// 0.71. `t` runs from the segment's first point (weight index 1) to its second (index 2).
fn spline_weights(t: f32, cardinal: bool) -> [f32; 4] {
    let (t2, t3) = (t * t, t * t * t);
    if cardinal {
        let fc = 0.71;
        [
            -fc * t3 + 2.0 * fc * t2 - fc * t,
            (2.0 - fc) * t3 + (fc - 3.0) * t2 + 1.0,
            (fc - 2.0) * t3 + (3.0 - 2.0 * fc) * t2 + fc * t,
            fc * t3 - fc * t2,
        ]
    } else {
        [
            -t3 / 6.0 + 0.5 * t2 - 0.5 * t + 1.0 / 6.0,
            0.5 * t3 - t2 + 2.0 / 3.0,
            -0.5 * t3 + 0.5 * t2 + 0.5 * t + 1.0 / 6.0,
            t3 / 6.0,
        ]
    }
}

impl ColorRamp {
    /// The ramp's colour at `fac`, as Blender's colour band evaluates it
    /// (`BKE_colorband_evaluate`): Constant gives the stop at or below `fac`, Linear and Ease
    /// blend the two stops around it and hold the end colours outside; the spline modes run a
    /// cubic through the four stops around `fac` (the ends repeated, with virtual stops of the
    /// end colours at positions 0 and 1), clamped to [0, 1].
    pub fn eval(&self, fac: f32) -> Vec4 {
        let s = &self.stops;
        let n = s.len();
        match n {
            0 => return Vec4::ZERO,
            1 => return s[0].1,
            _ => {}
        }
        let fac = if fac.is_nan() { 0.0 } else { fac };
        let spline = matches!(
            self.interpolation,
            RampInterpolation::BSpline | RampInterpolation::Cardinal
        );
        if fac <= s[0].0 && !spline {
            return s[0].1;
        }
        // The first stop strictly above `fac` (n: none).
        let a = s.iter().position(|&(p, _)| p > fac).unwrap_or(n);
        if a == n && !spline {
            return s[n - 1].1;
        }
        let upper = if a == n { (1.0, s[n - 1].1) } else { s[a] };
        let lower = match a {
            0 => (0.0, s[0].1),
            _ => s[a - 1],
        };
        if self.interpolation == RampInterpolation::Constant {
            return lower.1;
        }
        let t = if upper.0 != lower.0 {
            (fac - lower.0) / (upper.0 - lower.0)
        } else if a != n {
            1.0
        } else {
            0.0
        };
        match self.interpolation {
            RampInterpolation::Linear => lower.1.lerp(upper.1, t),
            RampInterpolation::Ease => lower.1.lerp(upper.1, t * t * (3.0 - 2.0 * t)),
            _ => {
                let t = t.clamp(0.0, 1.0);
                let after = if a + 1 >= n { upper.1 } else { s[a + 1].1 };
                let before = if a < 2 { lower.1 } else { s[a - 2].1 };
                let w = spline_weights(t, self.interpolation == RampInterpolation::Cardinal);
                (before * w[0] + lower.1 * w[1] + upper.1 * w[2] + after * w[3])
                    .clamp(Vec4::ZERO, Vec4::ONE)
            }
        }
    }
}

/// The Wavelength node as Blender defines it (Cycles' `svm_node_wavelength`): the CIE 1931
/// colour-matching functions at `lambda_nm` in linear Rec.709, divided by 2.52 (Blender's
/// scale that keeps every channel at most 1), negative channels clamped to 0, black outside
/// 380-780 nm. A colour, not a spectral emitter: what the user sees in Cycles.
pub fn wavelength_color(lambda_nm: f32) -> Vec3 {
    if !(380.0..780.0).contains(&lambda_nm) {
        return Vec3::ZERO;
    }
    let xyz = crate::spectrum::cie::cie_xyz_bar(lambda_nm);
    (crate::spectrum::rgb::xyz_to_linear_srgb(xyz) / 2.52).max(Vec3::ZERO)
}

/// The Blackbody node: linear Rec.709 colour of a black body at `kelvin`, scaled to
/// luminance 1, as Blender defines it (colours outside Rec.709 clamped to 0; temperatures held
/// at 800 K and 12000 K beyond that range, as Cycles does). Computed from Planck's law and the
/// CIE 1931 observer (tabulated once over reciprocal temperature, where the colour varies
/// smoothly).
pub fn blackbody(kelvin: f32) -> Vec3 {
    use std::sync::OnceLock;
    const N: usize = 512;
    const MIRED_LO: f64 = 1e6 / 12000.0;
    const MIRED_HI: f64 = 1e6 / 800.0;
    static TABLE: OnceLock<Vec<Vec3>> = OnceLock::new();
    let table = TABLE.get_or_init(|| {
        (0..N)
            .map(|k| {
                let mired = MIRED_LO + (MIRED_HI - MIRED_LO) * k as f64 / (N - 1) as f64;
                let t = 1e6 / mired;
                // Planck's law up to a constant factor (normalised below), lambda in nm.
                let planck = |lambda: f32| {
                    let l = lambda as f64 * 1e-9;
                    (1.0 / (l.powi(5) * ((1.438_776_877e-2 / (l * t)).exp() - 1.0)) * 1e-30) as f32
                };
                let xyz = crate::spectrum::cie::integrate_xyz(planck, 2);
                let rgb = crate::spectrum::rgb::xyz_to_linear_srgb(xyz);
                rgb / luminance(rgb)
            })
            .collect()
    });
    let mired = 1e6 / (kelvin.clamp(800.0, 12000.0) as f64);
    let x =
        ((mired - MIRED_LO) / (MIRED_HI - MIRED_LO) * (N - 1) as f64).clamp(0.0, (N - 1) as f64);
    let i = (x.floor() as usize).min(N - 2);
    let f = (x - i as f64) as f32;
    table[i].lerp(table[i + 1], f).max(Vec3::ZERO)
}

/// A curve tabulated at `values.len()` evenly spaced points over [`lo`, `hi`] (Cycles bakes
/// RGB Curves and Float Curve into such tables too): linear between samples, and outside the
/// range either the end value or the end segment's slope (Blender's Extend Horizontal /
/// Extrapolated).
#[derive(Clone, Debug, PartialEq)]
pub struct CurveTable {
    pub lo: f32,
    pub hi: f32,
    pub values: Vec<f32>,
    pub extrapolate: bool,
}

impl CurveTable {
    pub fn eval(&self, x: f32) -> f32 {
        let v = &self.values;
        let n = v.len();
        if n == 0 {
            return x;
        }
        if n == 1 || self.hi <= self.lo {
            return v[0];
        }
        let t = (x - self.lo) / (self.hi - self.lo) * (n - 1) as f32;
        if !t.is_finite() {
            return v[0];
        }
        if t <= 0.0 {
            return if self.extrapolate {
                v[0] + (v[1] - v[0]) * t
            } else {
                v[0]
            };
        }
        if t >= (n - 1) as f32 {
            let over = t - (n - 1) as f32;
            return if self.extrapolate {
                v[n - 1] + (v[n - 1] - v[n - 2]) * over
            } else {
                v[n - 1]
            };
        }
        let i = t.floor() as usize;
        let f = t - i as f32;
        v[i] + (v[i + 1] - v[i]) * f
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: Vec3, b: Vec3) -> bool {
        (a - b).abs().max_element() < 1e-5
    }

    #[test]
    fn wavelength_colours_follow_blender() {
        assert_eq!(wavelength_color(379.0), Vec3::ZERO);
        assert_eq!(wavelength_color(780.0), Vec3::ZERO);
        let (blue, green, red) = (
            wavelength_color(450.0),
            wavelength_color(540.0),
            wavelength_color(610.0),
        );
        assert!(blue.z > blue.x && blue.z > blue.y, "{blue}");
        assert!(green.y > green.x && green.y > green.z, "{green}");
        assert!(red.x > red.y && red.x > red.z, "{red}");
        // Blender's 1/2.52 keeps every channel at most about 1, none below 0.
        for nm in 380..780 {
            let c = wavelength_color(nm as f32);
            assert!(
                c.min_element() >= 0.0 && c.max_element() < 1.05,
                "{nm}: {c}"
            );
        }
    }

    #[test]
    fn hsv_and_hsl_round_trip() {
        for c in [
            Vec3::new(0.8, 0.2, 0.1),
            Vec3::new(0.1, 0.7, 0.3),
            Vec3::new(0.2, 0.3, 0.9),
            Vec3::new(0.5, 0.5, 0.5),
            Vec3::new(1.0, 0.0, 1.0),
            Vec3::ZERO,
        ] {
            assert!(close(hsv_to_rgb(rgb_to_hsv(c)), c), "{c}");
            assert!(close(hsl_to_rgb(rgb_to_hsl(c)), c), "{c}");
        }
        assert!(close(
            rgb_to_hsv(Vec3::new(0.0, 1.0, 0.0)),
            Vec3::new(1.0 / 3.0, 1.0, 1.0)
        ));
        assert!(close(
            rgb_to_hsl(Vec3::new(1.0, 0.0, 0.0)),
            Vec3::new(0.0, 1.0, 0.5)
        ));
    }

    #[test]
    fn blend_modes() {
        let a = Vec3::new(0.2, 0.5, 0.8);
        let b = Vec3::new(0.6, 0.4, 0.1);
        let m = |mode: BlendMode, t| mode.blend(t, a, b);
        for (_, mode) in BLEND_MODES {
            // Factor 0 leaves `a` everywhere.
            assert!(close(m(*mode, 0.0), a), "{mode:?}");
        }
        assert!(close(m(BlendMode::Mix, 0.5), (a + b) * 0.5));
        assert!(close(m(BlendMode::Multiply, 1.0), a * b));
        assert!(close(m(BlendMode::Add, 1.0), a + b));
        assert!(close(m(BlendMode::Subtract, 1.0), a - b));
        assert!(close(
            m(BlendMode::Screen, 1.0),
            Vec3::ONE - (Vec3::ONE - a) * (Vec3::ONE - b)
        ));
        assert!(close(m(BlendMode::Difference, 1.0), (a - b).abs()));
        assert!(close(m(BlendMode::Darken, 1.0), a.min(b)));
        assert!(close(m(BlendMode::Lighten, 1.0), a.max(b)));
        assert!(close(m(BlendMode::Divide, 1.0), a / b));
        assert!(close(
            m(BlendMode::LinearLight, 1.0),
            a + 2.0 * b - Vec3::ONE
        ));
        assert!(close(m(BlendMode::Exclusion, 1.0), a + b - 2.0 * a * b));
        // Overlay: 2ab below a = 0.5, 1 - 2(1-a)(1-b) above.
        let o = m(BlendMode::Overlay, 1.0);
        assert!((o.x - 2.0 * 0.2 * 0.6).abs() < 1e-6);
        assert!((o.z - (1.0 - 2.0 * 0.2 * 0.9)).abs() < 1e-6);
        // Hue takes b's hue, keeps a's saturation and value.
        let h = rgb_to_hsv(m(BlendMode::Hue, 1.0));
        assert!((h.x - rgb_to_hsv(b).x).abs() < 1e-5 && (h.z - 0.8).abs() < 1e-5);
        let v = rgb_to_hsv(m(BlendMode::Value, 1.0));
        assert!((v.z - 0.6).abs() < 1e-5);
        let s = rgb_to_hsv(m(BlendMode::Saturation, 1.0));
        assert!((s.y - rgb_to_hsv(b).y).abs() < 1e-5);
        let d = m(BlendMode::Dodge, 1.0);
        assert!((d.x - 0.2 / 0.4).abs() < 1e-6);
        let bu = m(BlendMode::Burn, 1.0);
        assert_eq!(bu.x, 0.0); // 1 - 0.8 / 0.6 < 0
        let bu = BlendMode::Burn.blend(1.0, Vec3::splat(0.8), Vec3::splat(0.9));
        assert!((bu.x - (1.0 - 0.2 / 0.9)).abs() < 1e-6);
    }

    #[test]
    fn color_nodes() {
        let c = Vec3::new(0.8, 0.4, 0.2);
        // Hue 0.5 / saturation 1 / value 1 is the identity.
        assert!(close(hue_saturation_value(c, 0.5, 1.0, 1.0, 1.0), c));
        let grey = hue_saturation_value(c, 0.5, 0.0, 1.0, 1.0);
        assert!(close(grey, Vec3::splat(0.8)));
        let rotated =
            hue_saturation_value(Vec3::new(1.0, 0.0, 0.0), 0.5 + 1.0 / 3.0, 1.0, 1.0, 1.0);
        assert!(close(rotated, Vec3::new(0.0, 1.0, 0.0)));
        assert!(close(bright_contrast(c, 0.1, 0.0), c + 0.1));
        assert!(close(
            bright_contrast(Vec3::splat(0.5), 0.0, 1.0),
            Vec3::splat(0.5)
        ));
        assert!(close(gamma(c, 2.0), c * c));
    }

    #[test]
    fn blackbody_is_normalised_and_ordered() {
        for t in [1000.0, 2700.0, 6500.0, 10000.0] {
            let c = blackbody(t);
            // Luminance 1 (up to the clamping of out-of-gamut channels at low temperatures).
            assert!((luminance(c) - 1.0).abs() < 0.08, "{t}: {c}");
        }
        let warm = blackbody(2000.0);
        let cool = blackbody(10000.0);
        assert!(warm.x > warm.z && cool.z > cool.x);
        // 6500 K is close to D65, Rec.709's white: nearly neutral.
        let d = blackbody(6504.0);
        assert!((d - Vec3::ONE).abs().max_element() < 0.06, "{d}");
    }

    #[test]
    fn curve_tables() {
        let c = CurveTable {
            lo: 0.0,
            hi: 1.0,
            values: vec![0.0, 0.25, 1.0],
            extrapolate: false,
        };
        assert_eq!(c.eval(0.25), 0.125);
        assert_eq!(c.eval(0.75), 0.625);
        assert_eq!(c.eval(2.0), 1.0);
        assert_eq!(c.eval(-1.0), 0.0);
        let e = CurveTable {
            extrapolate: true,
            ..c
        };
        assert!((e.eval(1.5) - 1.75).abs() < 1e-6);
        assert!((e.eval(-0.5) + 0.25).abs() < 1e-6);
    }

    #[test]
    fn ramp_interpolations() {
        let black = Vec4::new(0.0, 0.0, 0.0, 1.0);
        let white = Vec4::ONE;
        let ramp = |i| ColorRamp {
            interpolation: i,
            stops: vec![(0.2, black), (0.6, white)],
        };
        let lin = ramp(RampInterpolation::Linear);
        assert_eq!(lin.eval(0.0), black);
        assert_eq!(lin.eval(1.0), white);
        assert!((lin.eval(0.3).x - 0.25).abs() < 1e-6);
        let ease = ramp(RampInterpolation::Ease);
        assert!((ease.eval(0.3).x - (0.0625 * 3.0 - 2.0 * 0.015625)).abs() < 1e-6);
        assert!((ease.eval(0.4).x - 0.5).abs() < 1e-6);
        let cons = ramp(RampInterpolation::Constant);
        assert_eq!(cons.eval(0.5), black);
        assert_eq!(cons.eval(0.1), black);
        assert_eq!(cons.eval(0.6), white);
        // Two stops, ends repeated: the B-spline from 5/6 black + 1/6 white at the first stop.
        let bs = ramp(RampInterpolation::BSpline);
        assert!((bs.eval(0.2 + 1e-6).x - 1.0 / 6.0).abs() < 1e-4);
        assert!((bs.eval(0.4).x - 0.5).abs() < 1e-5);
        // Cardinal splines interpolate: the stop colours are hit.
        let ca = ramp(RampInterpolation::Cardinal);
        assert!(ca.eval(0.2 + 1e-6).x.abs() < 1e-4);
        assert!((ca.eval(0.4).x - 0.5).abs() < 1e-5);
        // Below the first stop the splines run towards a virtual stop at 0 (Blender's
        // colour band): at half-way, 1/48 of the second stop's colour leaks in.
        assert!((bs.eval(0.1).x - 1.0 / 48.0).abs() < 1e-5);
    }
}
