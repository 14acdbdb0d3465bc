//! The film: accumulates CIE XYZ per pixel (box filter over the pixel area), converts to
//! linear Rec.709 (Blender's scene-linear default) and writes OpenEXR.

pub mod adaptive;
mod clamp;
pub mod denoise;
mod exr_io;
pub mod filter;
pub mod metrics;

pub use clamp::SampleClamp;
pub use exr_io::{
    read_exr_channel, read_exr_rgba, write_exr_channels, write_exr_rgba, write_exr_rgba_with,
    ExrCompression,
};
pub use filter::{FilterKind, PixelFilter};

use crate::spectrum::rgb::xyz_to_linear_srgb;
use glam::Vec3;

/// Sum of XYZ estimates and their count for one pixel (f64: thousands of samples, no drift),
/// plus the denoising guides (albedo XYZ, world normal, depth along the view axis).
#[derive(Clone, Copy, Debug, Default)]
pub struct FilmPixel {
    pub xyz: [f64; 3],
    pub samples: u32,
    /// The running XYZ sum when the sample count last reached a power of two 2^j (`[1]`) and
    /// when it reached 2^(j-1) (`[0]`): the two halves of the largest power-of-two prefix of the
    /// pixel's samples, for adaptive sampling's error estimate (`adaptive`).
    prefix_sums: [[f64; 3]; 2],
    albedo_xyz: [f32; 3],
    normal: [f32; 3],
    depth_sum: f32,
    depth_hits: u32,
    /// Sum of the samples' coverage (`Film::track_alpha`).
    alpha_sum: f32,
}

/// Depth written where no sample hit a surface (Blender's background Z).
pub const BACKGROUND_DEPTH: f32 = 1e10;

impl FilmPixel {
    /// Adds the pixel's next sample; non-finite estimates are rejected so no NaN/Inf reaches
    /// the image. Returns false if the sample was discarded.
    #[inline]
    pub fn add(&mut self, xyz: Vec3) -> bool {
        self.samples += 1;
        let finite = xyz.is_finite();
        if finite {
            let v = [xyz.x as f64, xyz.y as f64, xyz.z as f64];
            for (s, x) in self.xyz.iter_mut().zip(v) {
                *s += x;
            }
        }
        if self.samples.is_power_of_two() {
            self.prefix_sums = [self.prefix_sums[1], self.xyz];
        }
        finite
    }

    /// The means of the two halves of the pixel's largest power-of-two prefix of samples, as
    /// linear Rec.709, with that prefix's length (`None` before the second sample). Each half
    /// is an aligned block of the pixel's sequence, so each is a stratified estimate in its own
    /// right.
    pub fn prefix_halves(&self) -> Option<(Vec3, Vec3, u32)> {
        if self.samples < 2 {
            return None;
        }
        let n = 1u32 << (31 - self.samples.leading_zeros());
        let half = (n / 2) as f64;
        let rgb = |xyz: [f64; 3]| {
            xyz_to_linear_srgb(Vec3::new(
                (xyz[0] / half) as f32,
                (xyz[1] / half) as f32,
                (xyz[2] / half) as f32,
            ))
        };
        let [first, total] = self.prefix_sums;
        let a = rgb(first);
        let b = rgb([
            total[0] - first[0],
            total[1] - first[1],
            total[2] - first[2],
        ]);
        (a.is_finite() && b.is_finite()).then_some((a, b, n))
    }

    /// Adds one sample's guides; `depth` is `None` when the camera ray escaped. Non-finite
    /// values are ignored.
    #[inline]
    pub fn add_guides(&mut self, albedo_xyz: Vec3, normal: Vec3, depth: Option<f32>) {
        if albedo_xyz.is_finite() {
            for (s, v) in self.albedo_xyz.iter_mut().zip(albedo_xyz.to_array()) {
                *s += v;
            }
        }
        if normal.is_finite() {
            for (s, v) in self.normal.iter_mut().zip(normal.to_array()) {
                *s += v;
            }
        }
        if let Some(d) = depth.filter(|d| d.is_finite()) {
            self.depth_sum += d;
            self.depth_hits += 1;
        }
    }

    /// Adds one sample's coverage (0 transparent, 1 opaque).
    #[inline]
    pub fn add_alpha(&mut self, alpha: f32) {
        if alpha.is_finite() {
            self.alpha_sum += alpha.clamp(0.0, 1.0);
        }
    }

    /// Mean coverage over the pixel's samples.
    pub fn alpha(&self) -> f32 {
        if self.samples == 0 {
            return 0.0;
        }
        (self.alpha_sum / self.samples as f32).clamp(0.0, 1.0)
    }

    /// Mean albedo as linear Rec.709.
    pub fn albedo_rgb(&self) -> Vec3 {
        if self.samples == 0 {
            return Vec3::ZERO;
        }
        let rgb = xyz_to_linear_srgb(Vec3::from_array(self.albedo_xyz) / self.samples as f32);
        if rgb.is_finite() {
            rgb
        } else {
            Vec3::ZERO
        }
    }

    /// Mean world-space normal (renormalised; 0 where every sample escaped).
    pub fn normal(&self) -> Vec3 {
        Vec3::from_array(self.normal).normalize_or_zero()
    }

    /// Mean depth over the samples that hit something, else `BACKGROUND_DEPTH`.
    pub fn depth(&self) -> f32 {
        if self.depth_hits == 0 {
            BACKGROUND_DEPTH
        } else {
            self.depth_sum / self.depth_hits as f32
        }
    }

    pub fn rgb(&self) -> Vec3 {
        if self.samples == 0 {
            return Vec3::ZERO;
        }
        let n = self.samples as f64;
        let xyz = Vec3::new(
            (self.xyz[0] / n) as f32,
            (self.xyz[1] / n) as f32,
            (self.xyz[2] / n) as f32,
        );
        let rgb = xyz_to_linear_srgb(xyz);
        if rgb.is_finite() {
            rgb
        } else {
            Vec3::ZERO
        }
    }
}

pub struct Film {
    pub width: u32,
    pub height: u32,
    pub pixels: Vec<FilmPixel>,
    /// Write the denoising guides as extra EXR channels (`--guides`).
    pub write_guides: bool,
    /// The denoised colour (linear Rec.709, row 0 = top), once the image has been denoised: it
    /// becomes the EXR's RGB and the noisy colour moves to the `Noisy` layer.
    pub denoised: Option<Vec<Vec3>>,
    /// Alpha is the pixels' coverage (Film Transparent or holdouts); else 1.
    pub track_alpha: bool,
}

impl Film {
    pub fn new(width: u32, height: u32) -> Self {
        Film {
            width,
            height,
            pixels: vec![FilmPixel::default(); width as usize * height as usize],
            write_guides: false,
            denoised: None,
            track_alpha: false,
        }
    }

    /// The noisy colour of every pixel (linear Rec.709, row 0 = top): the denoiser's input.
    pub fn color(&self) -> Vec<Vec3> {
        self.pixels.iter().map(FilmPixel::rgb).collect()
    }

    /// The albedo guide as the denoiser takes it: clamped to [0, 1] (the world's radiance
    /// stands in for it where paths escape, and may exceed 1).
    pub fn albedo_guide(&self) -> Vec<Vec3> {
        self.pixels
            .iter()
            .map(|p| p.albedo_rgb().clamp(Vec3::ZERO, Vec3::ONE))
            .collect()
    }

    /// The normal guide (world space, unit or zero).
    pub fn normal_guide(&self) -> Vec<Vec3> {
        self.pixels.iter().map(FilmPixel::normal).collect()
    }

    /// Linear Rec.709 RGBA (premultiplied, as Blender's), row 0 = top of the image; alpha is
    /// coverage with `track_alpha`, else 1.
    pub fn to_rgba(&self) -> Vec<[f32; 4]> {
        self.pixels
            .iter()
            .map(|p| {
                let c = p.rgb();
                let a = if self.track_alpha { p.alpha() } else { 1.0 };
                [c.x, c.y, c.z, a]
            })
            .collect()
    }

    pub fn write_exr(&self, path: &std::path::Path) -> crate::error::Result<()> {
        self.write_exr_with(path, ExrCompression::default())
    }

    /// [`Self::write_exr`] with a choice of compression: the denoised colour if there is one
    /// (`denoised`), else the noisy one.
    pub fn write_exr_with(
        &self,
        path: &std::path::Path,
        compression: ExrCompression,
    ) -> crate::error::Result<()> {
        self.write_exr_denoised(path, compression, self.denoised.as_deref())
    }

    /// Writes the image with `denoised` (one colour per pixel) as its RGB, when given, and the
    /// noisy colour in `Noisy.RGBA` (Cycles' Noisy Image pass); guides when `write_guides`.
    pub fn write_exr_denoised(
        &self,
        path: &std::path::Path,
        compression: ExrCompression,
        denoised: Option<&[Vec3]>,
    ) -> crate::error::Result<()> {
        let rgba = self.to_rgba();
        if !self.write_guides && denoised.is_none() {
            return write_exr_rgba_with(path, self.width, self.height, &rgba, compression);
        }
        let channel = |f: &dyn Fn(usize) -> f32| -> Vec<f32> { (0..rgba.len()).map(f).collect() };
        let px = &self.pixels;
        let mut channels: Vec<(&str, Vec<f32>)> = Vec::new();
        match denoised {
            Some(d) => {
                channels.push(("R", channel(&|i| d[i].x)));
                channels.push(("G", channel(&|i| d[i].y)));
                channels.push(("B", channel(&|i| d[i].z)));
                channels.push(("Noisy.R", channel(&|i| rgba[i][0])));
                channels.push(("Noisy.G", channel(&|i| rgba[i][1])));
                channels.push(("Noisy.B", channel(&|i| rgba[i][2])));
                channels.push(("Noisy.A", channel(&|i| rgba[i][3])));
            }
            None => {
                channels.push(("R", channel(&|i| rgba[i][0])));
                channels.push(("G", channel(&|i| rgba[i][1])));
                channels.push(("B", channel(&|i| rgba[i][2])));
            }
        }
        channels.push(("A", channel(&|i| rgba[i][3])));
        if self.write_guides {
            channels.extend([
                ("Albedo.R", channel(&|i| px[i].albedo_rgb().x)),
                ("Albedo.G", channel(&|i| px[i].albedo_rgb().y)),
                ("Albedo.B", channel(&|i| px[i].albedo_rgb().z)),
                ("Normal.X", channel(&|i| px[i].normal().x)),
                ("Normal.Y", channel(&|i| px[i].normal().y)),
                ("Normal.Z", channel(&|i| px[i].normal().z)),
                ("Depth.Z", channel(&|i| px[i].depth())),
            ]);
        }
        write_exr_channels(path, self.width, self.height, channels, compression)
    }
}
