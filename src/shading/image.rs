//! The Image Texture node: Blender's image coordinates (origin at the bottom-left corner, one
//! unit per image), its interpolation (Closest, Linear, Cubic = uniform cubic B-spline, as
//! Cycles filters "Cubic") and extension modes (Repeat, Extend, Clip, Mirror).

use glam::{Vec2, Vec4};
use std::sync::Arc;

/// Decoded, linear RGBA texels; row 0 is the TOP row (as decoded from the file).
#[derive(Debug)]
pub struct Image {
    pub name: String,
    pub width: u32,
    pub height: u32,
    pub texels: Vec<Vec4>,
    /// The texels hold sRGB-encoded colour, decoded after filtering: what Cycles does for
    /// 8-bit sRGB images (it keeps them as bytes and converts each lookup), so a magnified or
    /// cubic-filtered 8-bit texture blends like Cycles' (in encoded values).
    pub srgb_encoded: bool,
}

impl Image {
    /// Blender's colour for an image it cannot load.
    pub fn missing(name: &str) -> Arc<Image> {
        Arc::new(Image {
            name: name.to_string(),
            width: 1,
            height: 1,
            texels: vec![Vec4::new(1.0, 0.0, 1.0, 1.0)],
            srgb_encoded: false,
        })
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interpolation {
    Closest,
    Linear,
    Cubic,
}

pub const INTERPOLATIONS: &[(&str, Interpolation)] = &[
    ("closest", Interpolation::Closest),
    ("linear", Interpolation::Linear),
    ("cubic", Interpolation::Cubic),
    // Smart is Cubic when magnifying in Cycles' CPU kernel: for a path tracer, Cubic.
    ("smart", Interpolation::Cubic),
];

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Extension {
    Repeat,
    Extend,
    Clip,
    Mirror,
}

pub const EXTENSIONS: &[(&str, Extension)] = &[
    ("repeat", Extension::Repeat),
    ("extend", Extension::Extend),
    ("clip", Extension::Clip),
    ("mirror", Extension::Mirror),
];

/// Texel index along one axis after the extension mode; `None`: outside (Clip).
#[inline]
fn texel_index(i: i64, n: i64, ext: Extension) -> Option<usize> {
    let j = match ext {
        Extension::Repeat => i.rem_euclid(n),
        Extension::Extend => i.clamp(0, n - 1),
        Extension::Clip => {
            if i < 0 || i >= n {
                return None;
            }
            i
        }
        Extension::Mirror => {
            let m = i.rem_euclid(2 * n);
            if m < n {
                m
            } else {
                2 * n - 1 - m
            }
        }
    };
    Some(j as usize)
}

/// Uniform cubic B-spline weights for the four texels around a sample at fraction `t`.
#[inline]
fn bspline_weights(t: f32) -> [f32; 4] {
    let (t2, t3) = (t * t, t * t * t);
    [
        (1.0 - t).powi(3) / 6.0,
        (3.0 * t3 - 6.0 * t2 + 4.0) / 6.0,
        (-3.0 * t3 + 3.0 * t2 + 3.0 * t + 1.0) / 6.0,
        t3 / 6.0,
    ]
}

impl Image {
    /// Texel (x, y) with y counted from the BOTTOM row (Blender's convention).
    #[inline]
    fn texel(&self, x: i64, y: i64, ext: [Extension; 2]) -> Vec4 {
        let (w, h) = (self.width as i64, self.height as i64);
        match (texel_index(x, w, ext[0]), texel_index(y, h, ext[1])) {
            (Some(xi), Some(yi)) => {
                self.texels[(self.height as usize - 1 - yi) * self.width as usize + xi]
            }
            _ => Vec4::ZERO,
        }
    }

    /// The image at Blender texture coordinates `uv` ((0,0) = bottom-left corner, (1,1) =
    /// top-right), with extension `ext[0]` along u and `ext[1]` along v (glTF samplers wrap
    /// each axis on its own; Blender's node uses one mode for both). Clip returns transparent
    /// black outside [0,1] along a clipped axis.
    pub fn sample(&self, uv: Vec2, interpolation: Interpolation, ext: [Extension; 2]) -> Vec4 {
        let v = self.sample_stored(uv, interpolation, ext);
        if self.srgb_encoded {
            use crate::spectrum::rgb::srgb_to_linear;
            Vec4::new(
                srgb_to_linear(v.x),
                srgb_to_linear(v.y),
                srgb_to_linear(v.z),
                v.w,
            )
        } else {
            v
        }
    }

    /// The filtered stored values (see `srgb_encoded`).
    fn sample_stored(&self, uv: Vec2, interpolation: Interpolation, ext: [Extension; 2]) -> Vec4 {
        if self.texels.is_empty() {
            return Vec4::ZERO;
        }
        let uv = if uv.is_finite() { uv } else { Vec2::ZERO };
        let clipped = |t: f32, e: Extension| e == Extension::Clip && !(0.0..=1.0).contains(&t);
        if clipped(uv.x, ext[0]) || clipped(uv.y, ext[1]) {
            return Vec4::ZERO;
        }
        // Keep the arithmetic where f32 -> i64 is exact enough and cannot overflow.
        let x = (uv.x as f64 * self.width as f64).clamp(-1e12, 1e12);
        let y = (uv.y as f64 * self.height as f64).clamp(-1e12, 1e12);
        match interpolation {
            Interpolation::Closest => self.texel(x.floor() as i64, y.floor() as i64, ext),
            Interpolation::Linear => {
                // Texel centres sit at half-integers.
                let (fx, fy) = (x - 0.5, y - 0.5);
                let (x0, y0) = (fx.floor(), fy.floor());
                let (tx, ty) = ((fx - x0) as f32, (fy - y0) as f32);
                let (x0, y0) = (x0 as i64, y0 as i64);
                let a = self
                    .texel(x0, y0, ext)
                    .lerp(self.texel(x0 + 1, y0, ext), tx);
                let b = self
                    .texel(x0, y0 + 1, ext)
                    .lerp(self.texel(x0 + 1, y0 + 1, ext), tx);
                a.lerp(b, ty)
            }
            Interpolation::Cubic => {
                let (fx, fy) = (x - 0.5, y - 0.5);
                let (x0, y0) = (fx.floor(), fy.floor());
                let wx = bspline_weights((fx - x0) as f32);
                let wy = bspline_weights((fy - y0) as f32);
                let (x0, y0) = (x0 as i64, y0 as i64);
                let mut sum = Vec4::ZERO;
                for (j, wyj) in wy.iter().enumerate() {
                    let mut row = Vec4::ZERO;
                    for (i, wxi) in wx.iter().enumerate() {
                        row += self.texel(x0 - 1 + i as i64, y0 - 1 + j as i64, ext) * *wxi;
                    }
                    sum += row * *wyj;
                }
                sum
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 2x2 image: top row red, green; bottom row blue, white.
    fn quad() -> Image {
        Image {
            name: "q".into(),
            width: 2,
            height: 2,
            texels: vec![
                Vec4::new(1.0, 0.0, 0.0, 1.0),
                Vec4::new(0.0, 1.0, 0.0, 1.0),
                Vec4::new(0.0, 0.0, 1.0, 1.0),
                Vec4::ONE,
            ],
            srgb_encoded: false,
        }
    }

    #[test]
    fn origin_is_bottom_left() {
        let q = quad();
        let c = |u, v| {
            q.sample(
                Vec2::new(u, v),
                Interpolation::Closest,
                [Extension::Repeat; 2],
            )
        };
        assert_eq!(c(0.25, 0.25), Vec4::new(0.0, 0.0, 1.0, 1.0));
        assert_eq!(c(0.75, 0.75), Vec4::new(0.0, 1.0, 0.0, 1.0));
        assert_eq!(c(1.25, 0.75), Vec4::new(1.0, 0.0, 0.0, 1.0));
    }

    #[test]
    fn extension_modes() {
        let q = quad();
        let s = |u, e| q.sample(Vec2::new(u, 0.25), Interpolation::Closest, [e, e]);
        assert_eq!(s(1.25, Extension::Repeat), s(0.25, Extension::Repeat));
        assert_eq!(s(1.25, Extension::Extend), s(0.75, Extension::Extend));
        assert_eq!(s(1.25, Extension::Mirror), s(0.75, Extension::Mirror));
        assert_eq!(s(1.75, Extension::Mirror), s(0.25, Extension::Mirror));
        assert_eq!(s(1.25, Extension::Clip), Vec4::ZERO);
        assert_eq!(s(-0.25, Extension::Clip), Vec4::ZERO);
    }

    /// glTF samplers wrap u and v on their own: each axis follows its own mode.
    #[test]
    fn extension_per_axis() {
        let q = quad();
        let at = |u, v, e| q.sample(Vec2::new(u, v), Interpolation::Closest, e);
        let (rep, clip, mirror) = (Extension::Repeat, Extension::Clip, Extension::Mirror);
        // u repeats while v is clipped: outside in u still reads the image ...
        assert_eq!(at(1.25, 0.25, [rep, clip]), at(0.25, 0.25, [rep, rep]));
        // ... outside in v is transparent black.
        assert_eq!(at(0.25, 1.25, [rep, clip]), Vec4::ZERO);
        // Mirrored v with repeated u.
        assert_eq!(at(1.25, 1.25, [rep, mirror]), at(0.25, 0.75, [rep, rep]));
    }

    #[test]
    fn linear_and_cubic_preserve_constants_and_interpolate() {
        let q = quad();
        let mid = q.sample(
            Vec2::splat(0.5),
            Interpolation::Linear,
            [Extension::Repeat; 2],
        );
        assert!((mid - Vec4::new(0.5, 0.5, 0.5, 1.0)).abs().max_element() < 1e-6);
        // At a texel centre linear filtering returns the texel.
        let c = q.sample(
            Vec2::splat(0.25),
            Interpolation::Linear,
            [Extension::Extend; 2],
        );
        assert!((c - Vec4::new(0.0, 0.0, 1.0, 1.0)).abs().max_element() < 1e-6);
        let flat = Image {
            name: "f".into(),
            width: 3,
            height: 3,
            texels: vec![Vec4::splat(0.4); 9],
            srgb_encoded: false,
        };
        for uv in [
            Vec2::new(0.1, 0.9),
            Vec2::new(0.5, 0.5),
            Vec2::new(-3.3, 7.1),
        ] {
            let v = flat.sample(uv, Interpolation::Cubic, [Extension::Repeat; 2]);
            assert!((v - Vec4::splat(0.4)).abs().max_element() < 1e-6);
        }
        let w = bspline_weights(0.3);
        assert!((w.iter().sum::<f32>() - 1.0).abs() < 1e-6);
    }
}
