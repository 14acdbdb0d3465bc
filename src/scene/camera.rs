//! Pinhole perspective camera (glTF: looks down local -Z, +Y up, vertical field of view).

use crate::geometry::Ray;
use glam::{Affine3A, Vec2, Vec3};

#[derive(Clone, Debug)]
pub struct Camera {
    camera_to_world: Affine3A,
    /// Half extents of the image plane at distance 1.
    tan_half_x: f32,
    tan_half_y: f32,
    width: u32,
    height: u32,
}

impl Camera {
    /// `yfov` is the vertical field of view; the horizontal one follows from the image aspect
    /// (as Blender does on import; the file's aspectRatio only matters for the viewport).
    pub fn new(camera_to_world: Affine3A, yfov: f32, width: u32, height: u32) -> Self {
        let tan_half_y = (0.5 * yfov).tan();
        let aspect = width as f32 / height as f32;
        Camera {
            camera_to_world,
            tan_half_x: tan_half_y * aspect,
            tan_half_y,
            width,
            height,
        }
    }

    /// Primary ray through the film position `raster` (pixels, origin at the top-left corner).
    /// `u_lens` in [0,1)^2 picks the point on the lens (unused by a pinhole).
    pub fn generate_ray(&self, raster: Vec2, _u_lens: Vec2) -> Ray {
        let ndc_x = 2.0 * raster.x / self.width as f32 - 1.0;
        let ndc_y = 1.0 - 2.0 * raster.y / self.height as f32;
        let d_cam = Vec3::new(ndc_x * self.tan_half_x, ndc_y * self.tan_half_y, -1.0);
        let dir = self.camera_to_world.transform_vector3(d_cam).normalize();
        Ray::new(self.camera_to_world.translation.into(), dir)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn centre_ray_looks_down_minus_z() {
        let c = Camera::new(Affine3A::IDENTITY, 1.0, 64, 32);
        let r = c.generate_ray(Vec2::new(32.0, 16.0), Vec2::splat(0.5));
        assert!((r.dir - Vec3::NEG_Z).length() < 1e-6);
        let top = c.generate_ray(Vec2::new(32.0, 0.0), Vec2::splat(0.5));
        assert!((top.dir.y / -top.dir.z - 0.5f32.tan()).abs() < 1e-5);
        let right = c.generate_ray(Vec2::new(64.0, 16.0), Vec2::splat(0.5));
        assert!((right.dir.x / -right.dir.z - 2.0 * 0.5f32.tan()).abs() < 1e-5);
    }
}
