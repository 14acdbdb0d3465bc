//! Perspective and orthographic cameras with an optional thin lens (depth of field) and lens
//! shift, and Cycles' panoramic cameras (equirectangular, equidistant and equisolid fisheye).
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

use super::desc::PanoramaDesc;
use crate::geometry::{MotionTransform, Ray};
use crate::math::sampling::sample_uniform_disk_concentric;
use glam::{Affine3A, Vec2, Vec3};

#[derive(Clone, Copy, Debug, PartialEq)]
enum Projection {
    /// Half extents of the image plane at distance 1.
    Perspective {
        tan_half_x: f32,
        tan_half_y: f32,
    },
    /// Half extents of the view in scene units.
    Orthographic {
        half_x: f32,
        half_y: f32,
    },
    Panorama(PanoramaDesc),
}

/// A pixel's footprint along a camera ray: `constant + per_distance * d` at distance `d`
/// (`Camera::pixel_footprint`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PixelFootprint {
    pub per_distance: f32,
    pub constant: f32,
}

impl PixelFootprint {
    pub fn at(&self, distance: f32) -> f32 {
        self.constant + self.per_distance * distance
    }
}

/// The camera-space direction (view axis -Z, up +Y, right +X) of the panorama's film point
/// (u, v) in [0, 1]^2, v up; `None` outside a fisheye's image circle. The mappings are Cycles'
/// (`kernel/camera/projection.h`), rotated from its +X-forward panorama frame to ours.
fn panorama_direction(p: &PanoramaDesc, u: f32, v: f32) -> Option<Vec3> {
    // A film point at distance r from the centre in direction (x, y) / r, `theta` from the axis.
    let around_axis = |x: f32, y: f32, r: f32, theta: f32| {
        let (sin_t, cos_t) = theta.sin_cos();
        let (cx, cy) = if r > 0.0 { (x / r, y / r) } else { (0.0, 0.0) };
        Vec3::new(cx * sin_t, cy * sin_t, -cos_t)
    };
    match *p {
        PanoramaDesc::Equirectangular {
            longitude,
            latitude,
        } => {
            let lon = longitude.0 + u * (longitude.1 - longitude.0);
            let lat = latitude.0 + v * (latitude.1 - latitude.0);
            let (sin_lat, cos_lat) = lat.sin_cos();
            Some(Vec3::new(
                lon.sin() * cos_lat,
                sin_lat,
                -lon.cos() * cos_lat,
            ))
        }
        PanoramaDesc::FisheyeEquidistant { fov } => {
            let (x, y) = (2.0 * u - 1.0, 2.0 * v - 1.0);
            let r = (x * x + y * y).sqrt();
            (r <= 1.0).then(|| around_axis(x, y, r, r * 0.5 * fov))
        }
        PanoramaDesc::FisheyeEquisolid { fov, lens, sensor } => {
            let (x, y) = ((u - 0.5) * sensor.x, (v - 0.5) * sensor.y);
            let r = (x * x + y * y).sqrt();
            let r_max = 2.0 * lens * (0.25 * fov).sin();
            (r <= r_max).then(|| around_axis(x, y, r, 2.0 * (r / (2.0 * lens)).min(1.0).asin()))
        }
    }
}

#[derive(Clone, Debug)]
pub struct Camera {
    camera_to_world: Affine3A,
    projection: Projection,
    /// Offset of the view window (Blender's shift), in image-plane units: at distance 1 for
    /// a perspective camera, scene units for an orthographic one.
    shift: Vec2,
    /// 0 = pinhole.
    lens_radius: f32,
    focus_distance: f32,
    width: u32,
    height: u32,
    /// The camera's placement over the shutter (motion blur), else `camera_to_world` always.
    motion: Option<std::sync::Arc<MotionTransform>>,
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
            shift: Vec2::ZERO,
            lens_radius: 0.0,
            focus_distance: 1.0,
            width,
            height,
            motion: None,
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
            shift: Vec2::ZERO,
            lens_radius: 0.0,
            focus_distance: 1.0,
            width,
            height,
            motion: None,
        }
    }

    /// A panoramic camera (no lens, no shift).
    pub fn panoramic(
        camera_to_world: Affine3A,
        panorama: PanoramaDesc,
        width: u32,
        height: u32,
    ) -> Self {
        Camera {
            camera_to_world,
            projection: Projection::Panorama(panorama),
            shift: Vec2::ZERO,
            lens_radius: 0.0,
            focus_distance: 1.0,
            width,
            height,
            motion: None,
        }
    }

    /// The width of one pixel's footprint at distance `d` along a camera ray, as Cycles' ray
    /// differentials give it at the first hit (facing the camera): `d` x the pixel's angle for
    /// perspective cameras, the pixel's size for orthographic ones; panoramas use their
    /// height's angle over the pixels (pi / height). For Bump nodes' offsets.
    pub fn pixel_footprint(&self) -> PixelFootprint {
        let h = self.height.max(1) as f32;
        match self.projection {
            Projection::Perspective { tan_half_y, .. } => PixelFootprint {
                per_distance: 2.0 * tan_half_y / h,
                constant: 0.0,
            },
            Projection::Orthographic { half_y, .. } => PixelFootprint {
                per_distance: 0.0,
                constant: 2.0 * half_y / h,
            },
            Projection::Panorama(_) => PixelFootprint {
                per_distance: std::f32::consts::PI / h,
                constant: 0.0,
            },
        }
    }

    /// Moves the view window by `shift` x the view's height (Blender's lens shift, converted
    /// by the caller from its fraction of the fitted dimension). Panoramas ignore it.
    pub fn with_shift(mut self, shift: Vec2) -> Self {
        let height = match self.projection {
            Projection::Perspective { tan_half_y, .. } => 2.0 * tan_half_y,
            Projection::Orthographic { half_y, .. } => 2.0 * half_y,
            Projection::Panorama(_) => 0.0,
        };
        self.shift = shift * height;
        self
    }

    /// Whether rays start from a lens (depth of field): a pinhole needs no lens sample.
    pub fn has_lens(&self) -> bool {
        self.lens_radius > 0.0
    }

    /// Adds a thin lens of radius `aperture_radius` focused at `focus_distance` along the view
    /// axis (scene units). A radius of 0 (or a non-positive focus distance) keeps the pinhole.
    pub fn with_thin_lens(mut self, aperture_radius: f32, focus_distance: f32) -> Self {
        let panorama = matches!(self.projection, Projection::Panorama(_));
        if !panorama && aperture_radius > 0.0 && focus_distance > 0.0 && focus_distance.is_finite()
        {
            self.lens_radius = aperture_radius;
            self.focus_distance = focus_distance;
        }
        self
    }

    /// Moves the camera over the shutter (`motion`'s keys replace its transform); a motion
    /// whose keys are all equal leaves it still.
    pub fn with_motion(mut self, motion: MotionTransform) -> Self {
        if !motion.is_static() {
            self.camera_to_world = motion.at(0.5);
            self.motion = Some(std::sync::Arc::new(motion));
        }
        self
    }

    /// Whether the camera moves during the shutter.
    pub fn has_motion(&self) -> bool {
        self.motion.is_some()
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

    /// Depth of a hit at `distance` along the camera ray `dir`, as Blender's Depth pass stores
    /// it: along the view axis, or (panoramas) the distance itself.
    pub fn depth(&self, distance: f32, dir: Vec3) -> f32 {
        match self.projection {
            Projection::Panorama(_) => distance,
            _ => distance * dir.dot(self.forward()),
        }
    }

    /// Primary ray through the film position `raster` (pixels, origin at the top-left corner).
    /// `u_lens` in [0,1)^2 picks the point on the lens (unused without a lens). `None` where the
    /// film sees nothing (outside a fisheye's image circle).
    pub fn generate_ray(&self, raster: Vec2, u_lens: Vec2) -> Option<Ray> {
        self.generate_ray_at(raster, u_lens, 0.5)
    }

    /// [`Camera::generate_ray`] at normalised shutter time `time`: the ray starts from where
    /// the camera is then and carries the time for the rest of the path.
    pub fn generate_ray_at(&self, raster: Vec2, u_lens: Vec2, time: f32) -> Option<Ray> {
        let moved;
        let camera_to_world = match &self.motion {
            None => &self.camera_to_world,
            Some(m) => {
                moved = m.at(time);
                &moved
            }
        };
        let u = raster.x / self.width as f32;
        let v = 1.0 - raster.y / self.height as f32;
        if let Projection::Panorama(p) = &self.projection {
            let dir = panorama_direction(p, u, v)?;
            return Some(Ray::new_at(
                camera_to_world.transform_point3(Vec3::ZERO),
                camera_to_world.transform_vector3(dir).normalize() + Vec3::ZERO,
                time,
            ));
        }
        let ndc_x = 2.0 * u - 1.0;
        let ndc_y = 2.0 * v - 1.0;
        // Pinhole ray in camera space; `dir` has z = -1 so that origin + dir * d lies on the
        // plane at distance d along the view axis.
        let (origin, dir) = match self.projection {
            Projection::Perspective {
                tan_half_x,
                tan_half_y,
            } => (
                Vec3::ZERO,
                Vec3::new(
                    ndc_x * tan_half_x + self.shift.x,
                    ndc_y * tan_half_y + self.shift.y,
                    -1.0,
                ),
            ),
            Projection::Orthographic { half_x, half_y } => (
                Vec3::new(
                    ndc_x * half_x + self.shift.x,
                    ndc_y * half_y + self.shift.y,
                    0.0,
                ),
                Vec3::NEG_Z,
            ),
            Projection::Panorama(_) => unreachable!("handled above"),
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
        Some(Ray::new_at(
            camera_to_world.transform_point3(origin),
            camera_to_world.transform_vector3(dir).normalize() + Vec3::ZERO,
            time,
        ))
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

    /// A pixel's footprint: its angle times the distance (perspective), its size (ortho).
    #[test]
    fn pixel_footprint() {
        let yfov = 1.0f32;
        let c = Camera::new(Affine3A::IDENTITY, yfov, 64, 32);
        let f = c.pixel_footprint();
        let want = 2.0 * (0.5 * yfov).tan() / 32.0 * 5.0;
        assert!((f.at(5.0) - want).abs() < 1e-6, "{} vs {want}", f.at(5.0));
        let o = Camera::orthographic(Affine3A::IDENTITY, 2.0, 64, 32).pixel_footprint();
        assert_eq!(o.at(1.0), o.at(100.0));
        assert!((o.at(1.0) - 4.0 / 32.0).abs() < 1e-7);
    }

    #[test]
    fn centre_ray_looks_down_minus_z() {
        let c = Camera::new(Affine3A::IDENTITY, 1.0, 64, 32);
        let r = c
            .generate_ray(Vec2::new(32.0, 16.0), Vec2::splat(0.5))
            .unwrap();
        assert!((r.dir - Vec3::NEG_Z).length() < 1e-6);
        let top = c
            .generate_ray(Vec2::new(32.0, 0.0), Vec2::splat(0.5))
            .unwrap();
        assert!((top.dir.y / -top.dir.z - 0.5f32.tan()).abs() < 1e-5);
        let right = c
            .generate_ray(Vec2::new(64.0, 16.0), Vec2::splat(0.5))
            .unwrap();
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
                let r = c.generate_ray(raster, u).unwrap();
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
                let pin = base.generate_ray(raster, Vec2::splat(0.5)).unwrap();
                let t_pin = focus / pin.dir.dot(axis);
                let target = pin.at(t_pin);
                let mut max_r = 0.0f32;
                let mut mean_offset = Vec3::ZERO;
                let n = 16;
                for u in grid(n) {
                    let r = lens.generate_ray(raster, u).unwrap();
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
            let a = c.generate_ray(Vec2::new(1.0, 2.0), u).unwrap();
            let b = l.generate_ray(Vec2::new(1.0, 2.0), u).unwrap();
            assert_eq!(a.origin, b.origin);
            assert_eq!(a.dir, b.dir);
        }
    }

    /// Blender's shift moves the view window: the centre pixel looks where the pixel at
    /// (0.5 + shift) x height would have looked.
    #[test]
    fn shift_moves_the_view_window() {
        let (w, h) = (64u32, 32u32);
        let plain = Camera::new(Affine3A::IDENTITY, 0.8, w, h);
        let shifted = plain.clone().with_shift(Vec2::new(0.25, -0.125));
        let a = shifted
            .generate_ray(Vec2::new(32.0, 16.0), Vec2::ZERO)
            .unwrap();
        // 0.25 heights right = 8 px, 0.125 heights down = 4 px.
        let b = plain
            .generate_ray(Vec2::new(40.0, 20.0), Vec2::ZERO)
            .unwrap();
        assert!((a.dir - b.dir).length() < 1e-6, "{} vs {}", a.dir, b.dir);
        let ortho = Camera::orthographic(Affine3A::IDENTITY, 1.0, w, h).with_shift(Vec2::X);
        let o = ortho
            .generate_ray(Vec2::new(32.0, 16.0), Vec2::ZERO)
            .unwrap();
        assert!((o.origin - Vec3::new(2.0, 0.0, 0.0)).length() < 1e-6);
    }

    #[test]
    fn equirectangular_directions() {
        let pi = std::f32::consts::PI;
        let c = Camera::panoramic(
            Affine3A::IDENTITY,
            PanoramaDesc::Equirectangular {
                longitude: (-pi, pi),
                latitude: (-pi / 2.0, pi / 2.0),
            },
            64,
            32,
        );
        let dir = |x: f32, y: f32| c.generate_ray(Vec2::new(x, y), Vec2::ZERO).unwrap().dir;
        assert!(
            (dir(32.0, 16.0) - Vec3::NEG_Z).length() < 1e-6,
            "centre: forward"
        );
        assert!(
            (dir(48.0, 16.0) - Vec3::X).length() < 1e-6,
            "3/4 across: right"
        );
        assert!(
            (dir(16.0, 16.0) - Vec3::NEG_X).length() < 1e-6,
            "1/4 across: left"
        );
        assert!((dir(32.0, 0.0) - Vec3::Y).length() < 1e-6, "top: up");
        assert!(
            (dir(0.0, 16.0) - Vec3::Z).length() < 1e-5,
            "left edge: behind"
        );
    }

    #[test]
    fn fisheye_directions_and_circle() {
        let fov = std::f32::consts::PI;
        let c = Camera::panoramic(
            Affine3A::IDENTITY,
            PanoramaDesc::FisheyeEquidistant { fov },
            64,
            64,
        );
        let ray = |x: f32, y: f32| c.generate_ray(Vec2::new(x, y), Vec2::ZERO);
        assert!((ray(32.0, 32.0).unwrap().dir - Vec3::NEG_Z).length() < 1e-6);
        // Half way to the edge: 45 degrees off the axis, to the right.
        let d = ray(48.0, 32.0).unwrap().dir;
        assert!((d - Vec3::new(0.5f32.sqrt(), 0.0, -(0.5f32.sqrt()))).length() < 1e-5);
        assert!(ray(1.0, 1.0).is_none(), "corner: outside the image circle");
        let solid = Camera::panoramic(
            Affine3A::IDENTITY,
            PanoramaDesc::FisheyeEquisolid {
                fov,
                lens: 10.0,
                sensor: Vec2::new(36.0, 36.0),
            },
            64,
            64,
        );
        // r = 2 f sin(theta / 2): at the edge of a 36 mm sensor (r = 18 mm), theta = 2 asin(0.9).
        let e = solid.generate_ray(Vec2::new(64.0, 32.0), Vec2::ZERO);
        assert!(e.is_none(), "r = 18 mm > r_max = 2 f sin(45 deg) = 14.1 mm");
        let d = solid
            .generate_ray(Vec2::new(32.0 + 32.0 * 10.0 / 18.0, 32.0), Vec2::ZERO)
            .unwrap()
            .dir;
        let theta = 2.0 * (0.5f32).asin();
        assert!((d.x - theta.sin()).abs() < 1e-4 && (d.z + theta.cos()).abs() < 1e-4);
    }
}
