//! Ray traversal of obvhs' compressed wide BVH ([`CwBvh`]) with an 8-wide node test.
//!
//! obvhs' traversal loop (its `traverse!` macro: Ylitie et al. 2017's child ordering by ray
//! octant and hit masks) is used as it is; only the test of a node's eight child boxes is
//! ours. obvhs tests them four at a time with SSE and builds each child's quantised plane from
//! its byte with a scalar load and conversion (24 per half), which it measures as the test's
//! most expensive part. With AVX2 one load and one widening conversion give all eight
//! children's value of a plane, and one comparison all eight results.
//!
//! The arithmetic is the same as obvhs' (a multiply, then an add, in single precision; the
//! same order of maxima and minima; the same epsilon): each box test, and therefore every hit
//! and every image, is bit for bit what obvhs' traversal gives (the test below compares the
//! two node tests on random rays; `tests/geometry_rays.rs` the hits with brute force). Without
//! AVX2 at compile time obvhs' own test is used.

// `UVec2` is named by obvhs' `traverse!` macro where it expands.
use glam::UVec2;
use obvhs::cwbvh::{node::CwBvhNode, CwBvh};
use obvhs::ray::Ray;

/// Where traversal starts a box's parametric range: obvhs' `EPSILON` (0.0001), which its
/// node test takes as every ray's minimum distance.
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
const BOX_T_MIN: f32 = 0.0001;

/// The node's hit mask for `ray` (`CwBvhNode::intersect_ray`'s: the high byte one bit per
/// hit inner child, in traversal priority; the low 24 bits the hit leaves' primitives).
#[inline(always)]
pub fn node_hits(node: &CwBvhNode, ray: &Ray, oct_inv4: u32) -> u32 {
    #[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
    {
        // SAFETY: AVX2 is enabled at compile time (the cfg above); the loads read the node's
        // own 8-byte arrays.
        let hits = unsafe { child_box_hits_avx2(node, ray) };
        let (child_bits8, bit_index8) = node.get_child_and_index_bits(oct_inv4);
        let mut mask = 0u32;
        let mut left = hits;
        while left != 0 {
            let j = left.trailing_zeros();
            left &= left - 1;
            let child_bits = ((child_bits8 >> (j * 8)) as u32) & 0xff;
            let bit_index = ((bit_index8 >> (j * 8)) as u32) & 0xff;
            mask |= child_bits << bit_index;
        }
        mask
    }
    #[cfg(not(all(target_arch = "x86_64", target_feature = "avx2")))]
    {
        node.intersect_ray(ray, oct_inv4)
    }
}

/// Bit j set: the ray's segment meets child j's box (obvhs' slab test, all eight children at
/// once).
#[cfg(all(target_arch = "x86_64", target_feature = "avx2"))]
#[inline(always)]
unsafe fn child_box_hits_avx2(node: &CwBvhNode, ray: &Ray) -> u32 {
    use std::arch::x86_64::*;
    let scale = node.compute_extent() * ray.inv_direction;
    let offset = (glam::Vec3A::from(node.p) - ray.origin) * ray.inv_direction;
    let planes = |bytes: &[u8; 8]| {
        _mm256_cvtepi32_ps(_mm256_cvtepu8_epi32(_mm_loadl_epi64(
            bytes.as_ptr() as *const __m128i
        )))
    };
    // The near and far planes of each axis: swapped where the ray runs backwards.
    let axis = |lo: &[u8; 8], hi: &[u8; 8], backwards: bool, scale: f32, offset: f32| {
        let (near, far) = if backwards { (hi, lo) } else { (lo, hi) };
        let (s, o) = (_mm256_set1_ps(scale), _mm256_set1_ps(offset));
        (
            _mm256_add_ps(_mm256_mul_ps(planes(near), s), o),
            _mm256_add_ps(_mm256_mul_ps(planes(far), s), o),
        )
    };
    let d = ray.direction;
    let (tmin_x, tmax_x) = axis(
        &node.child_min_x,
        &node.child_max_x,
        d.x < 0.0,
        scale.x,
        offset.x,
    );
    let (tmin_y, tmax_y) = axis(
        &node.child_min_y,
        &node.child_max_y,
        d.y < 0.0,
        scale.y,
        offset.y,
    );
    let (tmin_z, tmax_z) = axis(
        &node.child_min_z,
        &node.child_max_z,
        d.z < 0.0,
        scale.z,
        offset.z,
    );
    let tmin = _mm256_max_ps(tmin_x, _mm256_max_ps(tmin_y, tmin_z));
    let tmax = _mm256_min_ps(tmax_x, _mm256_min_ps(tmax_y, tmax_z));
    let tmin = _mm256_max_ps(tmin, _mm256_set1_ps(BOX_T_MIN));
    let tmax = _mm256_min_ps(tmax, _mm256_set1_ps(ray.tmax));
    _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(tmin, tmax)) as u32
}

/// Closest hit: `intersect` gives the distance to primitive `id` (in the BVH's primitive
/// order) below the ray's current `tmax`, or infinity, and keeps what it needs of the hit;
/// the ray's `tmax` shrinks to each hit found (`CwBvh::ray_traverse`).
#[inline]
pub fn closest(bvh: &CwBvh, ray: Ray, mut intersect: impl FnMut(&Ray, usize) -> f32) {
    let mut traverse_ray = ray;
    let mut state = bvh.new_traversal(ray.direction);
    let mut node;
    obvhs::traverse!(
        bvh,
        node,
        state,
        node_hits(node, &traverse_ray, state.oct_inv4),
        {
            let t = intersect(&traverse_ray, state.primitive_id as usize);
            if t < traverse_ray.tmax {
                traverse_ray.tmax = t;
            }
        }
    );
}

/// Calls `visit` with every primitive whose box the ray's segment meets
/// (`CwBvh::ray_traverse_anyhit`).
#[inline]
pub fn every(bvh: &CwBvh, ray: Ray, mut visit: impl FnMut(&Ray, usize)) {
    let mut state = bvh.new_traversal(ray.direction);
    let mut node;
    obvhs::traverse!(bvh, node, state, node_hits(node, &ray, state.oct_inv4), {
        visit(&ray, state.primitive_id as usize);
    });
}

/// True when no primitive is hit: stops at the first `intersect` below `ray.tmax`
/// (`CwBvh::ray_traverse_miss`).
#[inline]
pub fn misses(bvh: &CwBvh, ray: Ray, mut intersect: impl FnMut(&Ray, usize) -> f32) -> bool {
    let mut state = bvh.new_traversal(ray.direction);
    let mut node;
    let mut miss = true;
    'outer: {
        obvhs::traverse!(bvh, node, state, node_hits(node, &ray, state.oct_inv4), {
            if intersect(&ray, state.primitive_id as usize) < ray.tmax {
                miss = false;
                break 'outer;
            }
        });
    }
    miss
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sampler::Pcg32;
    use glam::vec3a;
    use obvhs::{triangle::Triangle, BvhBuildParams};

    /// Every node's hit mask equals obvhs' own test's, for random rays (some axis-parallel,
    /// some with a short segment) through a soup of random triangles.
    #[test]
    fn node_test_matches_obvhs() {
        let mut rng = Pcg32::new(7, 3, 1);
        let mut point = |s: f32| {
            vec3a(
                (rng.next_1d() - 0.5) * s,
                (rng.next_1d() - 0.5) * s,
                (rng.next_1d() - 0.5) * s,
            )
        };
        let tris: Vec<Triangle> = (0..3000)
            .map(|_| {
                let c = point(10.0);
                Triangle {
                    v0: c + point(0.5),
                    v1: c + point(0.5),
                    v2: c + point(0.5),
                }
            })
            .collect();
        let bvh = crate::geometry::wide_bvh::build(&tris, BvhBuildParams::medium_build());
        let mut differing = 0;
        for k in 0..2000 {
            let origin = point(14.0);
            let mut dir = point(2.0).normalize();
            if k % 7 == 0 {
                dir.y = 0.0;
                dir = dir.normalize();
            }
            let t_max = if k % 3 == 0 { 2.0 } else { f32::INFINITY };
            let ray = Ray::new(origin, dir, 0.0, t_max);
            let oct = bvh.new_traversal(ray.direction).oct_inv4;
            for node in &bvh.nodes {
                if node_hits(node, &ray, oct) != node.intersect_ray(&ray, oct) {
                    differing += 1;
                }
            }
        }
        assert_eq!(differing, 0);
    }
}
