//! The film: accumulates CIE XYZ per pixel (box filter over the pixel area), converts to
//! linear Rec.709 (Blender's scene-linear default) and writes OpenEXR.

pub mod adaptive;
mod exr_io;
pub mod filter;
pub mod metrics;

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
    /// Sum over half of the samples (`in_half`), for adaptive sampling's error estimate.
    half_xyz: [f64; 3],
    albedo_xyz: [f32; 3],
    normal: [f32; 3],
    depth_sum: f32,
    depth_hits: u32,
}

/// Which samples of a pixel form the half whose mean adaptive sampling compares with the
/// mean of all: those whose index has an odd number of bits set at odd positions. Every
/// aligned block of four consecutive indices puts two samples in each half, and so does every
/// larger aligned block at every scale, so each half of a stratified (0, 2)-sequence prefix is
/// itself spread over the whole domain. The odd indices alone would be a single stratum of
/// the sequence (in the first dimension, all of them lie in one half of [0, 1)): their mean
/// would differ from the full mean by far more than the noise. Cycles splits its samples the
/// same way.
#[inline]
pub fn in_half(index: u32) -> bool {
    (index & 0xaaaa_aaaa).count_ones() & 1 == 1
}

/// Depth written where no sample hit a surface (Blender's background Z).
pub const BACKGROUND_DEPTH: f32 = 1e10;

impl FilmPixel {
    /// Adds sample number `index` of the pixel; non-finite estimates are rejected so no
    /// NaN/Inf reaches the image. Returns false if the sample was discarded.
    #[inline]
    pub fn add(&mut self, xyz: Vec3, index: u32) -> bool {
        self.samples += 1;
        if !xyz.is_finite() {
            return false;
        }
        let v = [xyz.x as f64, xyz.y as f64, xyz.z as f64];
        for (s, x) in self.xyz.iter_mut().zip(v) {
            *s += x;
        }
        if in_half(index) {
            for (s, x) in self.half_xyz.iter_mut().zip(v) {
                *s += x;
            }
        }
        true
    }

    /// Mean of half of the samples (`in_half`) as linear Rec.709 (`None` before the second
    /// sample).
    pub fn half_rgb(&self) -> Option<Vec3> {
        let n = (0..self.samples).filter(|&i| in_half(i)).count();
        if n == 0 || self.samples < 2 {
            return None;
        }
        let k = 1.0 / n as f64;
        let xyz = Vec3::new(
            (self.half_xyz[0] * k) as f32,
            (self.half_xyz[1] * k) as f32,
            (self.half_xyz[2] * k) as f32,
        );
        Some(xyz_to_linear_srgb(xyz)).filter(|c| c.is_finite())
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
}

impl Film {
    pub fn new(width: u32, height: u32) -> Self {
        Film {
            width,
            height,
            pixels: vec![FilmPixel::default(); width as usize * height as usize],
            write_guides: false,
        }
    }

    /// Linear Rec.709 RGBA, row 0 = top of the image, alpha 1.
    pub fn to_rgba(&self) -> Vec<[f32; 4]> {
        self.pixels
            .iter()
            .map(|p| {
                let c = p.rgb();
                [c.x, c.y, c.z, 1.0]
            })
            .collect()
    }

    pub fn write_exr(&self, path: &std::path::Path) -> crate::error::Result<()> {
        self.write_exr_with(path, ExrCompression::default())
    }

    /// [`Self::write_exr`] with a choice of compression.
    pub fn write_exr_with(
        &self,
        path: &std::path::Path,
        compression: ExrCompression,
    ) -> crate::error::Result<()> {
        if !self.write_guides {
            return write_exr_rgba_with(
                path,
                self.width,
                self.height,
                &self.to_rgba(),
                compression,
            );
        }
        let rgba = self.to_rgba();
        let channel = |f: &dyn Fn(usize) -> f32| -> Vec<f32> { (0..rgba.len()).map(f).collect() };
        let px = &self.pixels;
        let channels: Vec<(&str, Vec<f32>)> = vec![
            ("R", channel(&|i| rgba[i][0])),
            ("G", channel(&|i| rgba[i][1])),
            ("B", channel(&|i| rgba[i][2])),
            ("A", channel(&|i| rgba[i][3])),
            ("Albedo.R", channel(&|i| px[i].albedo_rgb().x)),
            ("Albedo.G", channel(&|i| px[i].albedo_rgb().y)),
            ("Albedo.B", channel(&|i| px[i].albedo_rgb().z)),
            ("Normal.X", channel(&|i| px[i].normal().x)),
            ("Normal.Y", channel(&|i| px[i].normal().y)),
            ("Normal.Z", channel(&|i| px[i].normal().z)),
            ("Depth.Z", channel(&|i| px[i].depth())),
        ];
        write_exr_channels(path, self.width, self.height, channels, compression)
    }
}
