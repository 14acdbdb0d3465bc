//! Equirectangular environment map (the world texture): loading, spectral lookup and
//! importance sampling.
//!
//! **Mapping** (Blender/Cycles' Environment Texture, so a world exported from Blender looks
//! the same): in Blender's Z-up frame a direction `b` maps to
//! `u = 0.5 - atan2(b.y, b.x) / 2π` (u = 0 at the left edge of the image; the centre looks along
//! +X, u = 0.25 along +Y) and to the polar angle `θ = acos(b.z)`, the top image row being +Z.
//! Prism's world is glTF's Y-up frame, `b = (x, -z, y)`. `rotation_z` is the Z rotation of a
//! Blender Mapping node (Point type) on the texture vector: the texture is looked up at
//! `Rz(rotation_z) b`.
//!
//! **Spectra**: every texel's RGB (times the world colour x strength) is upsampled once, at load,
//! to an unbounded sigmoid-polynomial spectrum; a lookup blends the four bilinear neighbours'
//! spectra at the path's wavelengths and multiplies by normalised D65 once, which equals the
//! illuminant spectrum of each texel (`RgbIlluminantSpectrum`) blended bilinearly.
//!
//! **Sampling**: a 2D piecewise-constant distribution over the image (rows by their marginal,
//! then a column within the row) with weights = the bilinear radiance's luminance averaged over
//! each texel's cell (a separable 1/8, 3/4, 1/8 filter) times sin θ at the row centre; the point
//! is uniform inside the cell. The solid-angle density is
//! `p(u, t) / (2π² sin θ)` with `p(u, t) = pmf(row) pmf(column | row) W H`.

use std::path::Path;

use glam::{Vec2, Vec3};
use rayon::prelude::*;

use crate::math::{DiscreteDistribution, PI};
use crate::spectrum::{cie, RgbUnboundedSpectrum, SampledSpectrum, SampledWavelengths};

/// Linear RGB image, row 0 = top (+up), column 0 = u = 0.
#[derive(Clone, Debug)]
pub struct EnvImage {
    pub width: u32,
    pub height: u32,
    pub texels: Vec<Vec3>,
}

use crate::spectrum::rgb::luminance;

/// Blender's Z-up frame from glTF's Y-up frame and back.
#[inline]
fn to_blender(g: Vec3) -> Vec3 {
    Vec3::new(g.x, -g.z, g.y)
}
#[inline]
fn from_blender(b: Vec3) -> Vec3 {
    Vec3::new(b.x, b.z, -b.y)
}

pub struct EnvironmentMap {
    width: usize,
    height: usize,
    texels: Vec<RgbUnboundedSpectrum>,
    cos_rot: f32,
    sin_rot: f32,
    rows: DiscreteDistribution,
    columns: Vec<DiscreteDistribution>,
    /// Integral of the luminance over the sphere (for the light-selection power estimate).
    luminance_integral: f32,
}

impl EnvironmentMap {
    /// `texels`: `width` x `height` linear RGB, row 0 = top. `tint` (world colour x strength)
    /// multiplies every texel before upsampling.
    pub fn new(width: u32, height: u32, texels: &[Vec3], tint: Vec3, rotation_z: f32) -> Self {
        let (w, h) = (width as usize, height as usize);
        assert!(w > 0 && h > 0 && texels.len() == w * h);
        let rgb: Vec<Vec3> = texels
            .iter()
            .map(|&t| {
                let c = t * tint;
                if c.is_finite() {
                    c.max(Vec3::ZERO)
                } else {
                    Vec3::ZERO
                }
            })
            .collect();
        let texels = rgb
            .par_iter()
            .map(|&c| RgbUnboundedSpectrum::new(c))
            .collect();
        // Cell-averaged luminance of the bilinear reconstruction: separable (1/8, 3/4, 1/8)
        // over neighbours (wrapping in u, clamped in t).
        let lum: Vec<f32> = rgb.iter().map(|&c| luminance(c)).collect();
        let mut horiz = vec![0.0f32; w * h];
        for j in 0..h {
            for i in 0..w {
                let l = lum[j * w + (i + w - 1) % w];
                let r = lum[j * w + (i + 1) % w];
                horiz[j * w + i] = 0.75 * lum[j * w + i] + 0.125 * (l + r);
            }
        }
        let mut columns = Vec::with_capacity(h);
        let mut row_weights = Vec::with_capacity(h);
        let mut integral = 0.0f64;
        let cell_solid_angle = (2.0 * PI / w as f32) * (PI / h as f32);
        for j in 0..h {
            let up = horiz[j.saturating_sub(1) * w..][..w].to_vec();
            let down = horiz[(j + 1).min(h - 1) * w..][..w].to_vec();
            let weights: Vec<f32> = (0..w)
                .map(|i| 0.75 * horiz[j * w + i] + 0.125 * (up[i] + down[i]))
                .collect();
            let sin_theta = (PI * (j as f32 + 0.5) / h as f32).sin();
            let row_sum: f64 = weights.iter().map(|&x| x as f64).sum();
            integral += row_sum * (sin_theta * cell_solid_angle) as f64;
            row_weights.push((row_sum * sin_theta as f64) as f32);
            // Guide tables: two lookups per light sample on the world, O(1) instead of two
            // binary searches over the map's width and height (the same texel either way).
            columns.push(DiscreteDistribution::new(&weights).with_guide_table());
        }
        EnvironmentMap {
            width: w,
            height: h,
            texels,
            cos_rot: rotation_z.cos(),
            sin_rot: rotation_z.sin(),
            rows: DiscreteDistribution::new(&row_weights).with_guide_table(),
            columns,
            luminance_integral: integral as f32,
        }
    }

    /// Integral of the luminance over all directions (W/m² of a unit-luminance-weighted
    /// irradiance from the whole sphere); 0 for a black map.
    pub fn luminance_integral(&self) -> f32 {
        self.luminance_integral
    }

    /// Image coordinates (u, t) in [0,1)² (t from the top row) of the world direction `dir`.
    pub fn direction_to_uv(&self, dir: Vec3) -> Vec2 {
        let b = to_blender(dir.normalize_or_zero());
        let (c, s) = (self.cos_rot, self.sin_rot);
        let r = Vec3::new(c * b.x - s * b.y, s * b.x + c * b.y, b.z);
        let mut u = 0.5 - r.y.atan2(r.x) * (0.5 / PI);
        if u >= 1.0 {
            u -= 1.0;
        }
        if u < 0.0 {
            u += 1.0;
        }
        let t = r.z.clamp(-1.0, 1.0).acos() / PI;
        Vec2::new(u.min(0.999_999_94), t.min(0.999_999_94))
    }

    /// The world direction of image coordinates (u, t).
    pub fn uv_to_direction(&self, uv: Vec2) -> Vec3 {
        let theta = PI * uv.y;
        let phi = PI * (1.0 - 2.0 * uv.x);
        let (st, ct) = theta.sin_cos();
        let r = Vec3::new(st * phi.cos(), st * phi.sin(), ct);
        let (c, s) = (self.cos_rot, self.sin_rot);
        // Inverse rotation.
        let b = Vec3::new(c * r.x + s * r.y, -s * r.x + c * r.y, r.z);
        from_blender(b)
    }

    /// Bilinear neighbours of image coordinates: four (texel index, weight) pairs.
    fn bilinear(&self, uv: Vec2) -> [(usize, f32); 4] {
        let (w, h) = (self.width, self.height);
        let x = uv.x * w as f32 - 0.5;
        let y = uv.y * h as f32 - 0.5;
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let i0 = (x0 as i64).rem_euclid(w as i64) as usize;
        let i1 = (i0 + 1) % w;
        let j0 = (y0 as i64).clamp(0, h as i64 - 1) as usize;
        let j1 = (y0 as i64 + 1).clamp(0, h as i64 - 1) as usize;
        [
            (j0 * w + i0, (1.0 - fx) * (1.0 - fy)),
            (j0 * w + i1, fx * (1.0 - fy)),
            (j1 * w + i0, (1.0 - fx) * fy),
            (j1 * w + i1, fx * fy),
        ]
    }

    /// Radiance arriving from the world along the escaping direction `dir`.
    pub fn radiance(&self, dir: Vec3, wl: &SampledWavelengths) -> SampledSpectrum {
        let taps = self.bilinear(self.direction_to_uv(dir));
        SampledSpectrum::from_fn(|k| {
            let lambda = wl.lambda[k];
            let mut v = 0.0;
            for &(i, wt) in &taps {
                if wt > 0.0 {
                    v += wt * self.texels[i].eval(lambda);
                }
            }
            v * cie::d65_normalized(lambda)
        })
    }

    /// Samples an escaping direction; returns it with its solid-angle density.
    pub fn sample(&self, u: Vec2) -> Option<(Vec3, f32)> {
        let (j, p_row, v_rem) = self.rows.sample(u.y);
        let (i, p_col, u_rem) = self.columns[j].sample(u.x);
        let uv = Vec2::new(
            (i as f32 + u_rem) / self.width as f32,
            (j as f32 + v_rem) / self.height as f32,
        );
        let sin_theta = (PI * uv.y).sin();
        let pdf = p_row * p_col * (self.width * self.height) as f32 / (2.0 * PI * PI * sin_theta);
        (sin_theta > 0.0 && pdf > 0.0 && pdf.is_finite()).then(|| (self.uv_to_direction(uv), pdf))
    }

    /// Solid-angle density with which [`Self::sample`] returns `dir`.
    pub fn pdf(&self, dir: Vec3) -> f32 {
        let uv = self.direction_to_uv(dir);
        let sin_theta = (PI * uv.y).sin();
        if sin_theta <= 0.0 {
            return 0.0;
        }
        let i = ((uv.x * self.width as f32) as usize).min(self.width - 1);
        let j = ((uv.y * self.height as f32) as usize).min(self.height - 1);
        self.rows.pmf(j) * self.columns[j].pmf(i) * (self.width * self.height) as f32
            / (2.0 * PI * PI * sin_theta)
    }
}

/// Loads an equirectangular image: `.exr` (first RGB(A) layer, float), `.hdr` (Radiance RGBE)
/// or `.png` (8/16-bit, sRGB-decoded to linear). Errors are one line without the path.
pub fn load_env_image(path: &Path) -> Result<EnvImage, String> {
    let img = load_linear_image(path)?;
    if img.texels.iter().any(|t| t.min_element() < 0.0) {
        return Err("the image has negative values (radiance must be non-negative)".into());
    }
    Ok(img)
}

/// Loads a linear RGB image as `load_env_image` does, negative values allowed: data images
/// (a shading graph's vectors, signed textures baked by Cycles) hold them, and Cycles reads
/// them as they are. Non-finite texels are an error.
pub fn load_linear_image(path: &Path) -> Result<EnvImage, String> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase())
        .unwrap_or_default();
    let img = match ext.as_str() {
        "exr" => load_exr(path)?,
        "hdr" | "png" => {
            let bytes = std::fs::read(path).map_err(|e| io_msg(&e))?;
            let format = if ext == "hdr" {
                image::ImageFormat::Hdr
            } else {
                image::ImageFormat::Png
            };
            let mut reader =
                image::ImageReader::with_format(std::io::Cursor::new(&bytes[..]), format);
            reader.limits(image::Limits::default());
            let decoded = reader
                .decode()
                .map_err(|e| format!("cannot decode image: {e}"))?;
            let (width, height) = (decoded.width(), decoded.height());
            let rgb = decoded.to_rgb32f();
            let srgb = ext == "png";
            let texels = rgb
                .pixels()
                .map(|p| {
                    let c = Vec3::new(p.0[0], p.0[1], p.0[2]);
                    if srgb {
                        Vec3::new(
                            crate::spectrum::rgb::srgb_to_linear(c.x),
                            crate::spectrum::rgb::srgb_to_linear(c.y),
                            crate::spectrum::rgb::srgb_to_linear(c.z),
                        )
                    } else {
                        c
                    }
                })
                .collect();
            EnvImage {
                width,
                height,
                texels,
            }
        }
        _ => {
            return Err(format!(
                "unsupported environment image type '.{ext}' (expected .exr, .hdr or .png)"
            ))
        }
    };
    if img.width == 0 || img.height == 0 {
        return Err("the image has zero size".into());
    }
    if let Some(bad) = img.texels.iter().position(|t| !t.is_finite()) {
        let (x, y) = (bad as u32 % img.width, bad as u32 / img.width);
        return Err(format!(
            "pixel ({x}, {y}) is not finite (NaN or infinite values are not valid radiance)"
        ));
    }
    Ok(img)
}

fn load_exr(path: &Path) -> Result<EnvImage, String> {
    use exr::prelude::*;
    let image = read_first_rgba_layer_from_file(
        path,
        |res, _| (res.width(), vec![Vec3::ZERO; res.width() * res.height()]),
        |(w, px), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
            px[pos.y() * *w + pos.x()] = Vec3::new(r, g, b)
        },
    )
    .map_err(|e| match e {
        exr::error::Error::Io(io) => io_msg(&io),
        other => format!("cannot read EXR: {other}"),
    })?;
    let size = image.layer_data.size;
    let (_, texels) = image.layer_data.channel_data.pixels;
    Ok(EnvImage {
        width: size.width() as u32,
        height: size.height() as u32,
        texels,
    })
}

fn io_msg(e: &std::io::Error) -> String {
    let s = e.to_string();
    match s.find(" (os error") {
        Some(i) => s[..i].to_string(),
        None => s,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn test_map(rotation: f32) -> EnvironmentMap {
        let (w, h) = (16u32, 8u32);
        let texels = (0..w * h)
            .map(|k| Vec3::splat(1.0 + (k % 7) as f32 + 3.0 * (k / w) as f32))
            .collect();
        let texels: Vec<Vec3> = texels;
        EnvironmentMap::new(w, h, &texels, Vec3::ONE, rotation)
    }

    #[test]
    fn direction_uv_round_trip_and_blender_axes() {
        let m = test_map(0.0);
        // glTF (x, y, z) = Blender (x, -z, y).
        let cases = [
            (Vec3::X, Vec2::new(0.5, 0.5)),      // Blender +X: image centre
            (Vec3::NEG_Z, Vec2::new(0.25, 0.5)), // Blender +Y
            (Vec3::Z, Vec2::new(0.75, 0.5)),     // Blender -Y
            (Vec3::new(0.0, 1.0, 1e-4), Vec2::new(0.75, 0.0)), // up: top row
        ];
        for (dir, want) in cases {
            let uv = m.direction_to_uv(dir);
            assert!((uv - want).length() < 1e-3, "{dir}: {uv} vs {want}");
        }
        for rot in [0.0, 0.7, -2.0] {
            let m = test_map(rot);
            for k in 0..200 {
                let uv = Vec2::new((k as f32 * 0.618_034) % 1.0, (k as f32 + 0.5) / 200.0);
                let d = m.uv_to_direction(uv);
                assert!((d.length() - 1.0).abs() < 1e-5);
                let back = m.direction_to_uv(d);
                let du = (back.x - uv.x).abs().min(1.0 - (back.x - uv.x).abs());
                assert!(du < 1e-4 && (back.y - uv.y).abs() < 1e-4, "{uv} -> {back}");
            }
        }
        // A Mapping rotation of +90° about Z looks the texture up at Rz(90°) b: Blender +X
        // (world +X) then reads the texture's Blender +Y, u = 0.25.
        let m = test_map(std::f32::consts::FRAC_PI_2);
        assert!((m.direction_to_uv(Vec3::X) - Vec2::new(0.25, 0.5)).length() < 1e-4);
    }

    #[test]
    fn pdf_matches_sample_and_integrates_to_one() {
        let m = test_map(0.3);
        for k in 0..500 {
            let u = Vec2::new(
                ((k as f32 + 0.5) * 0.754_877_7) % 1.0,
                ((k as f32 + 0.5) * 0.569_840_3) % 1.0,
            );
            let (d, pdf) = m.sample(u).unwrap();
            let p2 = m.pdf(d);
            assert!((p2 - pdf).abs() <= 1e-3 * pdf, "{pdf} vs {p2}");
        }
        // Midpoint rule over the sphere in (θ, φ): pdf sin θ is piecewise constant.
        let n = 400;
        let mut total = 0.0f64;
        for a in 0..n {
            for b in 0..n {
                let theta = PI * (a as f32 + 0.5) / n as f32;
                let phi = 2.0 * PI * (b as f32 + 0.5) / n as f32;
                let (st, ct) = theta.sin_cos();
                let d = Vec3::new(st * phi.cos(), ct, st * phi.sin());
                total += (m.pdf(d) * st) as f64 * (2.0 * PI * PI) as f64 / (n * n) as f64;
            }
        }
        assert!((total - 1.0).abs() < 5e-3, "{total}");
    }
}
