//! A light tree for next-event estimation (Conty Estevez and Kulla 2018, "Importance Sampling
//! of Many Lights with Adaptive Tree Splitting"): a binary hierarchy over the bounded lights
//! (emissive triangles, point and spot lights), each node holding the union of its lights'
//! spatial bounds, orientation cone and power. A shading point descends from the root,
//! choosing each child in proportion to its *importance* there: an estimate of the irradiance
//! the child's lights could deliver, from their power, distance and orientation and the
//! point's normal. The probability of having chosen a given light (for MIS when a BSDF ray
//! hits it) is the product of the same choices along its path from the root, which each light
//! stores as a bit trail.
//!
//! Importances are in irradiance units (W/m^2 of luminance), so that the caller can compare a
//! node with the distant lights (the sun, the world) whose importance is their irradiance.

use glam::{Vec3, Vec4};

/// Bounds of one light or of a set of lights (the node of the tree).
///
/// `phi` is the peak radiant intensity (luminance, W/sr): `L * A` for a Lambertian emitter of
/// radiance L and area A, I for a point or spot light. The emitters' normals lie in the cone
/// of half-angle `theta_o` around `axis`, and each emits up to `theta_e` beyond its normal
/// (pi/2 for a Lambertian surface, 0 for a point light whose "normal cone" is the sphere).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightBounds {
    pub lo: Vec3,
    pub hi: Vec3,
    pub phi: f32,
    pub axis: Vec3,
    pub cos_theta_o: f32,
    pub cos_theta_e: f32,
}

/// Where a light is chosen from: a point and, for surfaces that only reflect, the normal of
/// the side that can receive light (lights wholly behind it get no importance). `None` for
/// surfaces that transmit and for media.
#[derive(Clone, Copy, Debug)]
pub struct ShadingContext {
    pub p: Vec3,
    pub n: Option<Vec3>,
    /// The path's shutter time: where moving emitters are sampled.
    pub time: f32,
}

/// cos(max(0, a - b)) from the sines and cosines of a and b (angles in [0, pi]).
#[inline]
fn cos_sub_clamped(sin_a: f32, cos_a: f32, sin_b: f32, cos_b: f32) -> f32 {
    if cos_a > cos_b {
        1.0
    } else {
        cos_a * cos_b + sin_a * sin_b
    }
}

/// sin(max(0, a - b)).
#[inline]
fn sin_sub_clamped(sin_a: f32, cos_a: f32, sin_b: f32, cos_b: f32) -> f32 {
    if cos_a > cos_b {
        0.0
    } else {
        sin_a * cos_b - cos_a * sin_b
    }
}

#[inline]
fn sin_from_cos(c: f32) -> f32 {
    (1.0 - c * c).max(0.0).sqrt()
}

/// See `LightBounds::fixed`.
#[derive(Clone, Copy, Debug)]
struct FixedTerms {
    centroid: Vec3,
    radius2: f32,
    sin_o: f32,
}

impl LightBounds {
    pub fn centroid(&self) -> Vec3 {
        0.5 * (self.lo + self.hi)
    }

    /// The smallest bounds holding both (Conty Estevez and Kulla 2018, section 4.1: the cone
    /// of the union covers both cones; theta_e is the larger).
    pub fn union(&self, b: &LightBounds) -> LightBounds {
        if self.phi <= 0.0 {
            return *b;
        }
        if b.phi <= 0.0 {
            return *self;
        }
        let (axis, cos_theta_o) = cone_union(self.axis, self.cos_theta_o, b.axis, b.cos_theta_o);
        LightBounds {
            lo: self.lo.min(b.lo),
            hi: self.hi.max(b.hi),
            phi: self.phi + b.phi,
            axis,
            cos_theta_o,
            cos_theta_e: self.cos_theta_e.min(b.cos_theta_e),
        }
    }

    /// (sin, cos) of the half-angle of a cone around `dir` (unit, from `p` towards the centre)
    /// that contains the bounds as seen from `p`; cos = -1 for "all directions".
    fn subtended_half_angle(&self, p: Vec3, dir: Vec3, d2: f32, radius2: f32) -> (f32, f32) {
        if radius2 <= 0.0 {
            return (0.0, 1.0);
        }
        // Far from the bounds (beyond four bounding radii, a cone under 15 degrees) the
        // bounding sphere's cone is nearly as tight as the corners' and much cheaper.
        if d2 > 16.0 * radius2 {
            let sin2 = radius2 / d2;
            return (sin2.sqrt(), (1.0 - sin2).sqrt());
        }
        if p.cmpge(self.lo).all() && p.cmple(self.hi).all() {
            return (0.0, -1.0);
        }
        // The eight corners k (x from bit 0, y bit 1, z bit 2) as two groups of four lanes,
        // so the square roots and divisions run four at a time (the same operations, in the
        // same order, per corner as a scalar loop: the same bits).
        let (lo, hi) = (self.lo - p, self.hi - p);
        let x = Vec4::new(lo.x, hi.x, lo.x, hi.x);
        let y = Vec4::new(lo.y, lo.y, hi.y, hi.y);
        let mut cos_min = 1.0f32;
        for z in [Vec4::splat(lo.z), Vec4::splat(hi.z)] {
            let len2 = x * x + y * y + z * z;
            if len2.cmple(Vec4::ZERO).any() {
                return (0.0, -1.0);
            }
            let cos = (x * dir.x + y * dir.y + z * dir.z) / len2.sqrt();
            cos_min = cos_min.min(cos.min_element());
        }
        if cos_min <= 0.0 {
            return (0.0, -1.0);
        }
        // Never wider than the bounding sphere's cone when the point is outside the sphere.
        if d2 > radius2 {
            let cos_sphere = (1.0 - radius2 / d2).max(0.0).sqrt();
            cos_min = cos_min.max(cos_sphere);
        }
        (sin_from_cos(cos_min), cos_min)
    }

    /// Estimated irradiance at `ctx` from the lights inside these bounds: phi cos(theta') /
    /// d^2 times cos(theta_i') at the receiver, where theta' is the smallest angle between an
    /// emitter normal in the cone and the direction to the point, over every point of the
    /// bounds (Conty Estevez and Kulla 2018, eq. 3; the bounds' extent as seen from the point
    /// widens both angles by the half-angle theta_b of their bounding sphere). Zero only if no
    /// light inside can send light to the point's receiving side.
    pub fn importance(&self, ctx: &ShadingContext) -> f32 {
        self.importance_with(&self.fixed(), ctx)
    }

    /// The parts of `importance` that depend on the bounds alone.
    fn fixed(&self) -> FixedTerms {
        FixedTerms {
            centroid: self.centroid(),
            radius2: 0.25 * (self.hi - self.lo).length_squared(),
            sin_o: sin_from_cos(self.cos_theta_o),
        }
    }

    /// `importance` with `fixed` = `self.fixed()` (stored per tree node: the same values, so
    /// the same importance to the bit, without recomputing them at every shading point).
    #[inline]
    fn importance_with(&self, fixed: &FixedTerms, ctx: &ShadingContext) -> f32 {
        if self.phi <= 0.0 {
            return 0.0;
        }
        let to_point = ctx.p - fixed.centroid;
        let d2_true = to_point.length_squared();
        let radius2 = fixed.radius2;
        // Inside the bounding sphere the distance is unknown: use its radius (and a floor for
        // point lights) so the estimate stays finite.
        let d2 = d2_true.max(radius2).max(1e-8);
        let wi = if d2_true > 0.0 {
            to_point / d2_true.sqrt()
        } else {
            Vec3::Z
        };
        // Half-angle of the cone around `-wi` that holds the box as seen from the point: the
        // largest angle to a corner (the cone of half-angle <= pi/2 through the corners holds
        // their convex hull; wider counts as every direction, as does a point inside the box).
        // Much tighter than the bounding sphere for points near a large, flat node (Cycles
        // measures the corners too).
        let (sin_b, cos_b) = self.subtended_half_angle(ctx.p, -wi, d2_true, radius2);
        // Emission side: theta' = max(0, theta_w - theta_o - theta_b).
        let cos_w = self.axis.dot(wi);
        let sin_w = sin_from_cos(cos_w);
        let sin_o = fixed.sin_o;
        let cos_x = cos_sub_clamped(sin_w, cos_w, sin_o, self.cos_theta_o);
        let sin_x = sin_sub_clamped(sin_w, cos_w, sin_o, self.cos_theta_o);
        let cos_p = if cos_b <= -1.0 {
            1.0
        } else {
            cos_sub_clamped(sin_x, cos_x, sin_b, cos_b)
        };
        if cos_p <= self.cos_theta_e {
            return 0.0;
        }
        let mut importance = self.phi * cos_p / d2;
        // Receiving side: theta_i' = max(0, theta_i - theta_b).
        if let Some(n) = ctx.n {
            let cos_i = -n.dot(wi);
            let cos_ip = if cos_b <= -1.0 {
                1.0
            } else {
                cos_sub_clamped(sin_from_cos(cos_i), cos_i, sin_b, cos_b)
            };
            if cos_ip <= 0.0 {
                return 0.0;
            }
            importance *= cos_ip;
        }
        importance.max(0.0)
    }
}

/// The union of two direction cones (axis, cos half-angle): the smallest cone holding both.
fn cone_union(a: Vec3, cos_a: f32, b: Vec3, cos_b: f32) -> (Vec3, f32) {
    if cos_a <= -1.0 || cos_b <= -1.0 {
        return (a, -1.0);
    }
    let theta_a = cos_a.clamp(-1.0, 1.0).acos();
    let theta_b = cos_b.clamp(-1.0, 1.0).acos();
    let theta_d = a.dot(b).clamp(-1.0, 1.0).acos();
    if (theta_d + theta_b).min(std::f32::consts::PI) <= theta_a {
        return (a, cos_a);
    }
    if (theta_d + theta_a).min(std::f32::consts::PI) <= theta_b {
        return (b, cos_b);
    }
    let theta_o = 0.5 * (theta_a + theta_d + theta_b);
    if theta_o >= std::f32::consts::PI {
        return (a, -1.0);
    }
    // Rotate a towards b by theta_o - theta_a about their common normal.
    let rotation = theta_o - theta_a;
    let w = a.cross(b);
    if w.length_squared() < 1e-12 {
        return (a, -1.0);
    }
    let axis = glam::Quat::from_axis_angle(w.normalize(), rotation) * a;
    (axis.normalize(), theta_o.cos())
}

/// Node of the tree: a leaf holds one light, an interior node its two children (the first
/// directly after it in the array).
#[derive(Clone, Copy, Debug)]
struct Node {
    bounds: LightBounds,
    /// `bounds.fixed()`.
    fixed: FixedTerms,
    /// Leaf: the light's index (in the caller's numbering). Interior: the second child.
    index: u32,
    leaf: bool,
}

/// Where a light sits in the tree: the branch taken at each level below the top cut
/// (bit k = depth k below it, 1 = second child) and which top-cut node it is under.
#[derive(Clone, Copy, Debug, Default)]
struct Trail {
    bits: u64,
    cut: u8,
}

impl Node {
    #[inline]
    fn importance(&self, ctx: &ShadingContext) -> f32 {
        self.bounds.importance_with(&self.fixed, ctx)
    }
}

pub struct LightTree {
    nodes: Vec<Node>,
    /// A cut of the tree near its root (the nodes at depth `CUT_DEPTH`, or leaves above it):
    /// the first choice is made among these, which estimates the tree's importance much
    /// better than the root's single bounds when the lights are spread out.
    cut: Vec<u32>,
    trails: Vec<Trail>,
}

/// Depth of the top cut: up to 8 nodes.
const CUT_DEPTH: u32 = 3;
/// Buckets of the split search per axis.
const BUCKETS: usize = 12;
/// Deeper than this, lights are split by count, which bounds the depth (< 64 bits of trail).
const MAX_COST_SPLIT_DEPTH: u32 = 40;

impl LightTree {
    /// Builds the tree over `lights` (`lights[i]` is light i's bounds; lights without power are
    /// left out and get probability 0). `None` if no light has power.
    pub fn build(lights: &[LightBounds]) -> Option<LightTree> {
        let mut items: Vec<(u32, LightBounds)> = lights
            .iter()
            .enumerate()
            .filter(|(_, b)| b.phi > 0.0 && b.phi.is_finite())
            .map(|(i, b)| (i as u32, *b))
            .collect();
        if items.is_empty() {
            return None;
        }
        let mut tree = LightTree {
            nodes: Vec::with_capacity(2 * items.len()),
            cut: Vec::new(),
            trails: vec![Trail::default(); lights.len()],
        };
        tree.build_node(&mut items, 0);
        tree.collect_cut(0, 0);
        let cut = tree.cut.clone();
        for (ci, &node) in cut.iter().enumerate() {
            tree.assign_trails(node, ci as u8, 0, 0);
        }
        Some(tree)
    }

    fn build_node(&mut self, items: &mut [(u32, LightBounds)], depth: u32) -> usize {
        let index = self.nodes.len();
        let bounds = items
            .iter()
            .skip(1)
            .fold(items[0].1, |acc, (_, b)| acc.union(b));
        if items.len() == 1 {
            self.nodes.push(Node {
                bounds,
                fixed: bounds.fixed(),
                index: items[0].0,
                leaf: true,
            });
            return index;
        }
        self.nodes.push(Node {
            bounds,
            fixed: bounds.fixed(),
            index: 0,
            leaf: false,
        });
        let mid = split(items, &bounds, depth);
        let (left, right) = items.split_at_mut(mid);
        self.build_node(left, depth + 1);
        let second = self.build_node(right, depth + 1);
        self.nodes[index].index = second as u32;
        index
    }

    fn collect_cut(&mut self, node: u32, depth: u32) {
        let n = self.nodes[node as usize];
        if n.leaf || depth == CUT_DEPTH {
            self.cut.push(node);
        } else {
            self.collect_cut(node + 1, depth + 1);
            self.collect_cut(n.index, depth + 1);
        }
    }

    fn assign_trails(&mut self, node: u32, cut: u8, bits: u64, depth: u32) {
        let n = self.nodes[node as usize];
        if n.leaf {
            self.trails[n.index as usize] = Trail { bits, cut };
        } else {
            self.assign_trails(node + 1, cut, bits, depth + 1);
            self.assign_trails(n.index, cut, bits | (1 << depth), depth + 1);
        }
    }

    /// Importances of the top cut's nodes at `ctx` (what the caller's first choice uses).
    pub fn cut_importances(&self, ctx: &ShadingContext, out: &mut [f32; 8]) -> usize {
        for (o, &node) in out.iter_mut().zip(&self.cut) {
            *o = self.nodes[node as usize].importance(ctx);
        }
        self.cut.len()
    }

    /// Descends from top-cut node `cut` with `u` in [0, 1): the light and the probability of
    /// choosing it below the cut. `None` if no light there can reach `ctx`.
    pub fn sample_below(&self, cut: usize, ctx: &ShadingContext, mut u: f32) -> Option<(u32, f32)> {
        let mut node = self.cut[cut] as usize;
        let mut pmf = 1.0f32;
        loop {
            let n = &self.nodes[node];
            if n.leaf {
                return (pmf > 0.0).then_some((n.index, pmf));
            }
            let (c0, c1) = (node + 1, n.index as usize);
            let i0 = self.nodes[c0].importance(ctx);
            let i1 = self.nodes[c1].importance(ctx);
            if !(i0 + i1 > 0.0) {
                return None;
            }
            let p0 = i0 / (i0 + i1);
            if u < p0 {
                node = c0;
                u = (u / p0).min(ONE_MINUS_EPSILON);
                pmf *= p0;
            } else {
                node = c1;
                u = ((u - p0) / (1.0 - p0)).clamp(0.0, ONE_MINUS_EPSILON);
                pmf *= 1.0 - p0;
            }
        }
    }

    /// The top-cut node light `light` is under and the probability that `sample_below` from
    /// there chooses it at `ctx` (0 if the light has no power).
    pub fn pmf_below(&self, light: u32, ctx: &ShadingContext) -> (usize, f32) {
        let Some(trail) = self.trails.get(light as usize) else {
            return (0, 0.0);
        };
        let mut node = self.cut[trail.cut as usize] as usize;
        let mut pmf = 1.0f32;
        let mut depth = 0;
        loop {
            let n = &self.nodes[node];
            if n.leaf {
                return if n.index == light {
                    (trail.cut as usize, pmf)
                } else {
                    (0, 0.0)
                };
            }
            let (c0, c1) = (node + 1, n.index as usize);
            let i0 = self.nodes[c0].importance(ctx);
            let i1 = self.nodes[c1].importance(ctx);
            if !(i0 + i1 > 0.0) {
                return (0, 0.0);
            }
            let p0 = i0 / (i0 + i1);
            if trail.bits >> depth & 1 == 0 {
                node = c0;
                pmf *= p0;
            } else {
                node = c1;
                pmf *= 1.0 - p0;
            }
            depth += 1;
        }
    }

    pub fn cut_len(&self) -> usize {
        self.cut.len()
    }
}

const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

/// The split cost of a group of lights (Conty Estevez and Kulla 2018, eq. 2: "SAOH"): power x
/// the orientation measure of its cone x the surface area of its box.
fn orientation_measure(b: &LightBounds) -> f32 {
    use std::f32::consts::PI;
    let theta_o = b.cos_theta_o.clamp(-1.0, 1.0).acos();
    let theta_e = b.cos_theta_e.clamp(-1.0, 1.0).acos();
    let theta_w = (theta_o + theta_e).min(PI);
    let (sin_o, cos_o) = theta_o.sin_cos();
    2.0 * PI * (1.0 - cos_o)
        + PI / 2.0
            * (2.0 * theta_w * sin_o - (theta_o - 2.0 * theta_w).cos() - 2.0 * theta_o * sin_o
                + cos_o)
}

fn surface_area(lo: Vec3, hi: Vec3) -> f32 {
    let d = (hi - lo).max(Vec3::ZERO);
    2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
}

fn cost(b: &LightBounds) -> f32 {
    // Points have zero area: a small floor keeps their costs comparable by power.
    b.phi * orientation_measure(b) * (surface_area(b.lo, b.hi) + 1e-6)
}

/// Reorders `items` and returns where the second child starts (1..len).
fn split(items: &mut [(u32, LightBounds)], bounds: &LightBounds, depth: u32) -> usize {
    let n = items.len();
    let (clo, chi) = items.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), (_, b)| (lo.min(b.centroid()), hi.max(b.centroid())),
    );
    let extent = chi - clo;
    if depth >= MAX_COST_SPLIT_DEPTH || extent.max_element() <= 0.0 {
        // By count along the widest axis (or in order when all centroids coincide).
        let axis = extent.max_position();
        items.sort_by(|a, b| a.1.centroid()[axis].total_cmp(&b.1.centroid()[axis]));
        return n / 2;
    }
    let box_extent = (bounds.hi - bounds.lo).max(Vec3::splat(1e-12));
    let mut best = (f32::INFINITY, 0usize, 0usize);
    for axis in 0..3 {
        if extent[axis] <= 0.0 {
            continue;
        }
        let bucket_of = |b: &LightBounds| -> usize {
            let t = (b.centroid()[axis] - clo[axis]) / extent[axis];
            ((t * BUCKETS as f32) as usize).min(BUCKETS - 1)
        };
        let mut buckets: [Option<LightBounds>; BUCKETS] = [None; BUCKETS];
        for (_, b) in items.iter() {
            let k = bucket_of(b);
            buckets[k] = Some(buckets[k].map_or(*b, |acc| acc.union(b)));
        }
        // Regularisation for long thin boxes (the paper's K_r).
        let k_r = box_extent.max_element() / box_extent[axis];
        for s in 1..BUCKETS {
            let merge = |range: std::ops::Range<usize>| {
                buckets[range]
                    .iter()
                    .flatten()
                    .fold(None::<LightBounds>, |acc, b| {
                        Some(acc.map_or(*b, |a| a.union(b)))
                    })
            };
            let (Some(l), Some(r)) = (merge(0..s), merge(s..BUCKETS)) else {
                continue;
            };
            let c = k_r * (cost(&l) + cost(&r));
            if c < best.0 {
                best = (c, axis, s);
            }
        }
    }
    if !best.0.is_finite() {
        let axis = extent.max_position();
        items.sort_by(|a, b| a.1.centroid()[axis].total_cmp(&b.1.centroid()[axis]));
        return n / 2;
    }
    let (_, axis, s) = best;
    let threshold = clo[axis] + extent[axis] * s as f32 / BUCKETS as f32;
    // Partition by bucket (the same arithmetic as above, so the split matches the cost).
    let bucket_of = |b: &LightBounds| -> usize {
        let t = (b.centroid()[axis] - clo[axis]) / extent[axis];
        ((t * BUCKETS as f32) as usize).min(BUCKETS - 1)
    };
    let _ = threshold;
    let mut mid = 0;
    for i in 0..n {
        if bucket_of(&items[i].1) < s {
            items.swap(i, mid);
            mid += 1;
        }
    }
    if mid == 0 || mid == n {
        n / 2
    } else {
        mid
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn point(p: Vec3, phi: f32) -> LightBounds {
        LightBounds {
            lo: p,
            hi: p,
            phi,
            axis: Vec3::Z,
            // An isotropic emitter: every direction is a "normal" (theta_o = pi) and
            // theta_e = pi/2, as for Lambertian surfaces.
            cos_theta_o: -1.0,
            cos_theta_e: 0.0,
        }
    }

    #[test]
    fn point_importance_is_its_irradiance() {
        let b = point(Vec3::new(0.0, 0.0, 2.0), 8.0);
        let ctx = ShadingContext {
            p: Vec3::ZERO,
            n: Some(Vec3::Z),
            time: 0.5,
        };
        assert!((b.importance(&ctx) - 2.0).abs() < 1e-5);
        // Behind a reflecting surface: nothing.
        let below = ShadingContext {
            p: Vec3::ZERO,
            n: Some(-Vec3::Z),
            time: 0.5,
        };
        assert_eq!(b.importance(&below), 0.0);
        // A transmitting surface receives from both sides.
        let both = ShadingContext {
            p: Vec3::ZERO,
            n: None,
            time: 0.5,
        };
        assert!((b.importance(&both) - 2.0).abs() < 1e-5);
    }

    #[test]
    fn one_sided_emitter_is_dark_behind() {
        // A Lambertian emitter facing +z at the origin.
        let b = LightBounds {
            lo: Vec3::splat(-0.1),
            hi: Vec3::splat(0.1),
            phi: 1.0,
            axis: Vec3::Z,
            cos_theta_o: 1.0,
            cos_theta_e: 0.0,
        };
        let front = ShadingContext {
            p: Vec3::new(0.0, 0.0, 3.0),
            n: None,
            time: 0.5,
        };
        let behind = ShadingContext {
            p: Vec3::new(0.0, 0.0, -3.0),
            n: None,
            time: 0.5,
        };
        assert!(b.importance(&front) > 0.0);
        assert_eq!(b.importance(&behind), 0.0);
    }

    #[test]
    fn cone_union_holds_both_cones() {
        let a = Vec3::Z;
        let b = Vec3::X;
        let (axis, cos) = cone_union(a, 1.0, b, 1.0);
        assert!((cos - std::f32::consts::FRAC_PI_4.cos()).abs() < 1e-5);
        assert!((axis.dot(a) - cos).abs() < 1e-4 && (axis.dot(b) - cos).abs() < 1e-4);
        assert_eq!(cone_union(a, 1.0, -a, 1.0).1, -1.0);
    }

    #[test]
    fn pmfs_sum_to_one_and_match_sampling() {
        let mut lights = Vec::new();
        for i in 0..37 {
            let f = i as f32;
            lights.push(point(
                Vec3::new((f * 1.7).sin() * 5.0, (f * 0.3).cos() * 3.0, 1.0 + f * 0.1),
                1.0 + (f * 2.1).sin().abs() * 10.0,
            ));
        }
        let tree = LightTree::build(&lights).unwrap();
        let ctx = ShadingContext {
            p: Vec3::new(0.3, -0.2, 0.0),
            n: Some(Vec3::Z),
            time: 0.5,
        };
        let mut cut = [0f32; 8];
        let k = tree.cut_importances(&ctx, &mut cut);
        let total: f32 = cut[..k].iter().sum();
        let pmf = |i: u32| {
            let (c, p) = tree.pmf_below(i, &ctx);
            cut[c] / total * p
        };
        let sum: f32 = (0..lights.len() as u32).map(pmf).sum();
        assert!((sum - 1.0).abs() < 1e-4, "{sum}");
        // Sampling with stratified u reproduces the pmf.
        let n = 200_000;
        let mut counts = vec![0u32; lights.len()];
        for j in 0..n {
            let u = (j as f32 + 0.5) / n as f32;
            // First choice among the cut, then below it.
            let mut acc = 0.0;
            let mut chosen = k - 1;
            let mut u_rest = 0.0;
            for (c, &w) in cut[..k].iter().enumerate() {
                let p = w / total;
                if u < acc + p {
                    chosen = c;
                    u_rest = (u - acc) / p;
                    break;
                }
                acc += p;
            }
            let (light, _) = tree
                .sample_below(chosen, &ctx, u_rest.min(0.999_999))
                .unwrap();
            counts[light as usize] += 1;
        }
        for (i, &c) in counts.iter().enumerate() {
            let want = pmf(i as u32);
            let got = c as f32 / n as f32;
            assert!(
                (got - want).abs() < 2e-3 + 0.02 * want,
                "light {i}: {got} vs {want}"
            );
        }
    }
}
