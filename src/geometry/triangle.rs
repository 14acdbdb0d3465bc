use glam::Vec3;

/// Möller–Trumbore ray/triangle test (Möller & Trumbore 1997). Returns (t, b1, b2) for a hit
/// with 0 < t < t_max; b1, b2 are the barycentric weights of the second and third vertex.
#[inline(always)]
pub fn intersect_triangle(
    origin: Vec3,
    dir: Vec3,
    v0: Vec3,
    e1: Vec3,
    e2: Vec3,
    t_max: f32,
) -> Option<(f32, f32, f32)> {
    let (t, b1, b2) = ray_plane_barycentrics(origin, dir, v0, e1, e2)?;
    (b1 >= 0.0 && b2 >= 0.0 && b1 + b2 <= 1.0 && t > 0.0 && t < t_max).then_some((t, b1, b2))
}

/// Where the line `origin + t dir` meets the plane of the triangle (v0, v0 + e1, v0 + e2):
/// (t, b1, b2) with b1, b2 the barycentric weights of the second and third vertex, inside the
/// triangle or not (Möller–Trumbore's solution without its range tests; None when the line is
/// parallel to the plane). Light sampling uses it for directions known to point into the
/// triangle up to rounding.
#[inline(always)]
pub fn ray_plane_barycentrics(
    origin: Vec3,
    dir: Vec3,
    v0: Vec3,
    e1: Vec3,
    e2: Vec3,
) -> Option<(f32, f32, f32)> {
    let pvec = dir.cross(e2);
    let det = e1.dot(pvec);
    if det.abs() < 1e-20 {
        return None;
    }
    let inv_det = 1.0 / det;
    let tvec = origin - v0;
    let qvec = tvec.cross(e1);
    Some((
        e2.dot(qvec) * inv_det,
        tvec.dot(pvec) * inv_det,
        dir.dot(qvec) * inv_det,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hits_inside_misses_outside() {
        let (v0, e1, e2) = (Vec3::ZERO, Vec3::X, Vec3::Y);
        let h = intersect_triangle(Vec3::new(0.25, 0.25, 1.0), -Vec3::Z, v0, e1, e2, 10.0);
        let (t, b1, b2) = h.unwrap();
        assert!((t - 1.0).abs() < 1e-6 && (b1 - 0.25).abs() < 1e-6 && (b2 - 0.25).abs() < 1e-6);
        assert!(
            intersect_triangle(Vec3::new(0.75, 0.75, 1.0), -Vec3::Z, v0, e1, e2, 10.0).is_none()
        );
        assert!(
            intersect_triangle(Vec3::new(0.25, 0.25, 1.0), -Vec3::Z, v0, e1, e2, 0.5).is_none()
        );
        assert!(
            intersect_triangle(Vec3::new(0.25, 0.25, 1.0), Vec3::Z, v0, e1, e2, 10.0).is_none()
        );
    }
}
