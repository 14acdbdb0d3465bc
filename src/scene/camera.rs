//! Perspective and orthographic cameras with an optional thin lens (depth of field).
//!
//! Conventions (glTF): the camera looks down its local -Z with +Y up. The vertical extent comes
//! from the file (`yfov` or `ymag`); the horizontal one follows from the image aspect, as
//! Blender does on import (the file's aspectRatio / xmag only matter for a viewport).
//!
//! Thin lens: the pinhole ray through a film position is replaced by the ray from a point on a
//! disk of radius `aperture_radius` (in the camera's XY plane) through the point where the
//! pinhole ray meets the focus plane z = -`focus_distance` (distance along the view axis, as
//! Cycles measures it). Points on that plane are sharp; the lens point comes from the
//! concentric square-to-disk map of the sampler's lens dimensions.

use crate::geometry::Ray;
use crate::math::sampling::sample_uniform_disk_concentric;
use glam::{Affine3A, Vec2, Vec3};

#[derive(Clone, Copy, Debug, PartialEq)]
enum Projection {
    /// Half extents of the image plane at distance 1.
    Perspective { tan_half_x: f32, tan_half_y: f32 },
    /// Half extents of the view in scene units.
    Orthographic { half_x: f32, half_y: f32 },
}

#[derive(Clone, Debug)]
pub struct Camera {
    camera_to_world: Affine3A,
    projection: Projection,
    /// 0 = pinhole.
    lens_radius: f32,
    focus_distance: f32,
    width: u32,
    height: u32,
}

impl Camera {
    /// Perspective camera; `yfov` is the vertical field of view (radians).
    pub fn new(camera_to_world: Affine3A, yfov: f32, width: u32, height: u32) -> Self {
        let tan_half_y = (0.5 * yfov).tan();
        let aspect = width as f32 / height as f32;
        Camera {
            camera_to_world,
            projection: Projection::Perspective {
                tan_half_x: tan_half_y * aspect,
                tan_half_y,
            },
            lens_radius: 0.0,
            focus_distance: 1.0,
            width,
            height,
        }
    }

    /// Orthographic camera; `ymag` is half the view height in scene units (glTF's ymag).
    pub fn orthographic(camera_to_world: Affine3A, ymag: f32, width: u32, height: u32) -> Self {
        let aspect = width as f32 / height as f32;
        Camera {
            camera_to_world,
            projection: Projection::Orthographic {
                half_x: ymag * aspect,
                half_y: ymag,
            },
            lens_radius: 0.0,
            focus_distance: 1.0,
            width,
            height,
        }
    }

    /// Adds a thin lens of radius `aperture_radius` focused at `focus_distance` along the view
    /// axis (scene units). A radius of 0 (or a non-positive focus distance) keeps the pinhole.
    pub fn with_thin_lens(mut self, aperture_radius: f32, focus_distance: f32) -> Self {
        if aperture_radius > 0.0 && focus_distance > 0.0 && focus_distance.is_finite() {
            self.lens_radius = aperture_radius;
            self.focus_distance = focus_distance;
        }
        self
    }

    pub fn is_orthographic(&self) -> bool {
        matches!(self.projection, Projection::Orthographic { .. })
    }

    /// World-space viewing direction (the camera's -Z), unit length: depth along it is what
    /// Blender's Depth (Z) pass stores.
    pub fn forward(&self) -> Vec3 {
        self.camera_to_world
            .transform_vector3(Vec3::NEG_Z)
            .normalize_or_zero()
    }

    /// Primary ray through the film position `raster` (pixels, origin at the top-left corner).
    /// `u_lens` in [0,1)^2 picks the point on the lens (unused without a lens).
    pub fn generate_ray(&self, raster: Vec2, u_lens: Vec2) -> Ray {
        let ndc_x = 2.0 * raster.x / self.width as f32 - 1.0;
        let ndc_y = 1.0 - 2.0 * raster.y / self.height as f32;
        // Pinhole ray in camera space; `dir` has z = -1 so that origin + dir * d lies on the
        // plane at distance d along the view axis.
        let (origin, dir) = match self.projection {
            Projection::Perspective {
                tan_half_x,
                tan_half_y,
            } => (
                Vec3::ZERO,
                Vec3::new(ndc_x * tan_half_x, ndc_y * tan_half_y, -1.0),
            ),
            Projection::Orthographic { half_x, half_y } => {
                (Vec3::new(ndc_x * half_x, ndc_y * half_y, 0.0), Vec3::NEG_Z)
            }
        };
        let (origin, dir) = if self.lens_radius > 0.0 {
            let focus = origin + dir * self.focus_distance;
            let lens = self.lens_radius * sample_uniform_disk_concentric(u_lens);
            let o = origin + lens.extend(0.0);
            (o, focus - o)
        } else {
            (origin, dir)
        };
        // `+ 0.0` turns -0.0 components into +0.0: the BVH traversal (obvhs) misses flat
        // geometry with rays that have a -0.0 direction component, which an orthographic
        // camera's axis-aligned rays often have.
        Ray::new(
            self.camera_to_world.transform_point3(origin),
            self.camera_to_world.transform_vector3(dir).normalize() + Vec3::ZERO,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(n: usize) -> impl Iterator<Item = Vec2> {
        (0..n * n).map(move |k| {
            Vec2::new(
                ((k % n) as f32 + 0.5) / n as f32,
                ((k / n) as f32 + 0.5) / n as f32,
            )
        })
    }

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

    #[test]
    fn orthographic_rays_are_parallel_with_the_right_extent() {
        let to_world = Affine3A::from_rotation_translation(
            glam::Quat::from_rotation_y(0.7) * glam::Quat::from_rotation_x(-0.3),
            Vec3::new(1.0, 2.0, 3.0),
        );
        let (w, h, ymag) = (80u32, 40u32, 1.5f32);
        let c = Camera::orthographic(to_world, ymag, w, h);
        assert!(c.is_orthographic());
        let axis = to_world.transform_vector3(Vec3::NEG_Z);
        let right = to_world.transform_vector3(Vec3::X);
        let up = to_world.transform_vector3(Vec3::Y);
        let centre = Vec3::new(1.0, 2.0, 3.0);
        for (raster, want_x, want_y) in [
            (Vec2::new(40.0, 20.0), 0.0, 0.0),
            (Vec2::new(0.0, 20.0), -3.0, 0.0), // xmag = ymag * aspect
            (Vec2::new(80.0, 0.0), 3.0, 1.5),
            (Vec2::new(20.0, 40.0), -1.5, -1.5),
        ] {
            for u in grid(4) {
                let r = c.generate_ray(raster, u);
                assert!((r.dir - axis).length() < 1e-6, "not parallel: {:?}", r.dir);
                assert!(r
                    .dir
                    .to_array()
                    .iter()
                    .all(|v| *v != 0.0 || v.is_sign_positive()));
                let d = r.origin - centre;
                assert!(d.dot(axis).abs() < 1e-5, "origin off the camera plane");
                assert!(
                    (d.dot(right) - want_x).abs() < 1e-5,
                    "{raster}: x {}",
                    d.dot(right)
                );
                assert!(
                    (d.dot(up) - want_y).abs() < 1e-5,
                    "{raster}: y {}",
                    d.dot(up)
                );
            }
        }
    }

    /// Every lens sample of one film position reaches the same point of the focus plane,
    /// which is where the pinhole ray meets it; the lens points fill the aperture disk.
    #[test]
    fn thin_lens_rays_meet_at_the_focus_plane() {
        let to_world = Affine3A::from_rotation_translation(
            glam::Quat::from_rotation_z(0.4) * glam::Quat::from_rotation_x(0.2),
            Vec3::new(-1.0, 0.5, 4.0),
        );
        let (radius, focus) = (0.25f32, 3.0f32);
        for ortho in [false, true] {
            let base = if ortho {
                Camera::orthographic(to_world, 2.0, 64, 48)
            } else {
                Camera::new(to_world, 0.9, 64, 48)
            };
            let lens = base.clone().with_thin_lens(radius, focus);
            let axis = to_world.transform_vector3(Vec3::NEG_Z);
            let eye = Vec3::new(-1.0, 0.5, 4.0);
            for raster in [
                Vec2::new(32.0, 24.0),
                Vec2::new(3.5, 40.25),
                Vec2::new(60.0, 1.0),
            ] {
                let pin = base.generate_ray(raster, Vec2::splat(0.5));
                let t_pin = focus / pin.dir.dot(axis);
                let target = pin.at(t_pin);
                let mut max_r = 0.0f32;
                let mut mean_offset = Vec3::ZERO;
                let n = 16;
                for u in grid(n) {
                    let r = lens.generate_ray(raster, u);
                    // The origin lies on the lens disk (camera plane) ...
                    let plane = if ortho { pin.origin } else { eye };
                    let off = r.origin - plane;
                    assert!(off.dot(axis).abs() < 1e-5);
                    assert!(off.length() <= radius * (1.0 + 1e-5));
                    max_r = max_r.max(off.length());
                    mean_offset += off;
                    // ... and the ray passes through the pinhole ray's focus-plane point.
                    let t = (focus - (r.origin - eye).dot(axis)) / r.dir.dot(axis);
                    let hit = r.at(t);
                    assert!(
                        (hit - target).length() < 1e-4,
                        "ortho {ortho} {raster}: {hit} vs {target}"
                    );
                }
                assert!(max_r > 0.9 * radius, "lens samples do not fill the disk");
                assert!((mean_offset / (n * n) as f32).length() < 0.02 * radius);
            }
        }
    }

    #[test]
    fn zero_aperture_is_a_pinhole() {
        let c = Camera::new(Affine3A::IDENTITY, 1.0, 8, 8);
        let l = c.clone().with_thin_lens(0.0, 2.0);
        for u in grid(3) {
            let a = c.generate_ray(Vec2::new(1.0, 2.0), u);
            let b = l.generate_ray(Vec2::new(1.0, 2.0), u);
            assert_eq!(a.origin, b.origin);
            assert_eq!(a.dir, b.dir);
        }
    }
}
