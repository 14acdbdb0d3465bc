//! Procedural meshes for tests, benchmarks and generated scenes.

use glam::Vec3;

/// Unit UV sphere at the origin: (positions, normals, triangle indices), counter-clockwise seen
/// from outside. Degenerate triangles at the poles are left out.
pub fn uv_sphere(segments: u32, rings: u32) -> (Vec<Vec3>, Vec<Vec3>, Vec<[u32; 3]>) {
    let mut positions = Vec::new();
    for r in 0..=rings {
        let theta = std::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..=segments {
            let phi = 2.0 * std::f32::consts::PI * s as f32 / segments as f32;
            positions.push(Vec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            ));
        }
    }
    let row = segments + 1;
    let mut triangles = Vec::new();
    for r in 0..rings {
        for s in 0..segments {
            let (a, b, c, d) = (
                r * row + s,
                r * row + s + 1,
                (r + 1) * row + s,
                (r + 1) * row + s + 1,
            );
            if r > 0 {
                triangles.push([a, b, c]);
            }
            if r + 1 < rings {
                triangles.push([b, d, c]);
            }
        }
    }
    (positions.clone(), positions, triangles)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_is_closed_and_outward() {
        let (p, n, t) = uv_sphere(16, 8);
        assert_eq!(t.len(), 2 * 16 * 8 - 2 * 16);
        for [a, b, c] in t {
            let (pa, pb, pc) = (p[a as usize], p[b as usize], p[c as usize]);
            let face = (pb - pa).cross(pc - pa);
            assert!(face.length() > 0.0);
            assert!(face.dot(pa + pb + pc) > 0.0, "triangle faces inwards");
        }
        assert!(n.iter().all(|v| (v.length() - 1.0).abs() < 1e-5));
    }
}
