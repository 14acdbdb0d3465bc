//! The film: accumulates CIE XYZ per pixel (box filter over the pixel area), converts to
//! linear Rec.709 (Blender's scene-linear default) and writes OpenEXR.

mod exr_io;
pub mod metrics;

pub use exr_io::{read_exr_rgba, write_exr_rgba};

use crate::spectrum::rgb::xyz_to_linear_srgb;
use glam::Vec3;

/// Sum of XYZ estimates and their count for one pixel (f64: thousands of samples, no drift).
#[derive(Clone, Copy, Debug, Default)]
pub struct FilmPixel {
    pub xyz: [f64; 3],
    pub samples: u32,
}

impl FilmPixel {
    /// Adds one sample; non-finite estimates are rejected so no NaN/Inf reaches the image.
    /// Returns false if the sample was discarded.
    #[inline]
    pub fn add(&mut self, xyz: Vec3) -> bool {
        self.samples += 1;
        if !xyz.is_finite() {
            return false;
        }
        self.xyz[0] += xyz.x as f64;
        self.xyz[1] += xyz.y as f64;
        self.xyz[2] += xyz.z as f64;
        true
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
}

impl Film {
    pub fn new(width: u32, height: u32) -> Self {
        Film {
            width,
            height,
            pixels: vec![FilmPixel::default(); width as usize * height as usize],
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
        write_exr_rgba(path, self.width, self.height, &self.to_rgba())
    }
}
