//! Binary BVH -> compressed 8-wide BVH collapse, parallel over subtrees.
//!
//! The method is that of Ylitie, Karras & Laine 2017, "Efficient Incoherent Ray Traversal on
//! GPUs Through Compressed Wide BVHs" (HPG 2017):
//!
//! 1. A bottom-up dynamic program over (binary node n, sibling slots i) gives the SAH cost
//!    C(n, i) of representing n's subtree with at most i children of the wide parent:
//!    C(n, 1) = min(C_leaf(n), C_internal(n)), C(n, i) = min(C(n, i - 1), C_distribute(n, i))
//!    for i = 2..7, with C_leaf(n) = A(n) p(n) c_prim (p(n) primitives, at most the leaf
//!    limit), C_internal(n) = C_distribute(n, 8) + A(n) c_node and C_distribute(n, j) the
//!    cheapest split of j slots between n's two children (A: half area, c_prim = 0.3,
//!    c_node = 1).
//! 2. Top-down, every wide node takes the binary descendants that step 1 chose as its up to
//!    8 children, assigns them to slots so that the slot order sorts them along each of the 8
//!    ray octants (the paper's child ordering, with a greedy assignment instead of the
//!    auction), and quantises their boxes to 8 bits per plane relative to the node's origin
//!    with power-of-two scales.
//!
//! The output is obvhs' [`CwBvh`], node for node the tree that
//! `obvhs::cwbvh::bvh2_to_cwbvh::bvh2_to_cwbvh(bvh2, leaf_limit, true, false)` makes from the
//! same binary BVH: same cost constants and tie-breaking (the first minimum wins, a leaf only
//! when strictly cheaper), same slot assignment, same quantisation arithmetic and the same
//! depth-first memory layout (a node's children contiguous, allocated when the node is
//! written, its leaf children's primitives contiguous). obvhs' traversal therefore works on
//! it unchanged, and `tests/wide_bvh.rs` compares the two trees exactly.
//!
//! What differs is the cost of getting there. obvhs keeps a 12-byte decision for each of the
//! 7 slot counts of every binary node (17 MB for 100k triangles, mostly page faults) and runs
//! on one thread. Here:
//! * a binary node's 7 decisions pack into one `u32`, stored only for interior nodes
//!   (leaves' decisions follow from their box), and the cost tables travel up the recursion
//!   by value;
//! * the passes walk the binary tree depth-first, in an order unrelated to its memory layout,
//!   so a streaming pass first copies the 8 bytes per node they need (half area, first child
//!   or leaf primitive) out of the 48-byte nodes; only the wide children's boxes are read
//!   from the nodes themselves, all of a node's at once so their cache misses overlap;
//! * selections (split and slot choices) use selects instead of unpredictable branches;
//! * both passes split into rayon tasks: the cost pass over the upper binary levels, the
//!   emission over wide subtrees with many primitives, each emitted into its own vectors
//!   with subtree-relative indices and relocated when they are concatenated;
//! * past a few hundred levels (chains of coincident primitives) the walks use explicit
//!   stacks, so degenerate input cannot overflow the thread's stack.

use std::sync::atomic::{AtomicU32, Ordering::Relaxed};

use glam::Vec3A;
use obvhs::{
    aabb::Aabb,
    bvh2::{node::Bvh2Node, Bvh2},
    cwbvh::{node::CwBvhNode, CwBvh},
    Boundable, BvhBuildParams,
};
use rayon::prelude::*;

/// SAH cost of intersecting one primitive, relative to one wide-node test (c_node = 1).
const PRIM_COST: f32 = 0.3;
/// Children of a wide node.
const WIDTH: usize = 8;
/// Slot counts a binary subtree can be given inside its wide parent (1..=7, stored at 0..=6).
const SLOT_COUNTS: usize = WIDTH - 1;
/// A 3-bit field that holds no split: `C(n, i)` kept `C(n, i - 1)`'s choice.
const NO_SPLIT: u32 = 7;
/// Binary subtrees with at least this many primitives emit their wide children as separate
/// tasks; smaller ones are emitted sequentially by one task.
const PARALLEL_PRIMS: u32 = 2048;
/// Recursion depth (binary levels) from which the passes use explicit stacks instead.
const DEEP: u32 = 256;
/// Wide levels below which the emission may fork (a bound on its recursion).
const EMIT_FORK_DEPTH: u32 = 12;
/// Below this many primitives everything runs on the calling thread.
const SEQUENTIAL_BELOW: usize = 8192;
/// The cost pass forks at binary depths below this (up to 2^depth tasks; rayon's work
/// stealing balances them).
const COST_FORK_DEPTH: u32 = 10;

/// One interior binary node's decisions, packed:
/// * bit 0: with one slot, the node becomes a wide internal node (1) or a leaf (0);
/// * bits 1..4: the split k of the 8 slots of the node as a wide node: its left child gets
///   k + 1 slots, its right child 7 - k;
/// * bits 4 + 3 (i - 1)..: for i + 1 = 2..7 slots, the split k (left k + 1 slots, right i - k)
///   if distributing beats C(n, i) (the paper's C_distribute), else [`NO_SPLIT`];
/// * bit 31: the subtree has at least [`PARALLEL_PRIMS`] primitives.
#[derive(Clone, Copy)]
struct Decision(u32);

impl Decision {
    const INTERNAL: u32 = 1;
    const LARGE: u32 = 1 << 31;

    fn is_internal(self) -> bool {
        self.0 & Self::INTERNAL != 0
    }

    fn is_large(self) -> bool {
        self.0 & Self::LARGE != 0
    }

    /// How the node's 8 slots split between its children when it is a wide node.
    fn wide_split(self) -> (usize, usize) {
        let k = ((self.0 >> 1) & 7) as usize;
        (k, SLOT_COUNTS - 1 - k)
    }

    /// With `slots` + 1 slots (`slots` in 0..7): the split between the children if the node
    /// distributes its slots to them, None if it takes one slot itself. A count that kept
    /// the choice of the count below inherits it.
    fn distribution(self, slots: usize) -> Option<(usize, usize)> {
        (1..=slots).rev().find_map(|i| {
            let k = (self.0 >> (4 + 3 * (i - 1))) & 7;
            // `then`, not `then_some`: the pair must not be computed for NO_SPLIT (it underflows).
            (k != NO_SPLIT).then(|| (k as usize, i - 1 - k as usize))
        })
    }
}

/// Builds a binary BVH with obvhs' PLOC builder and reinsertion optimiser, as
/// `obvhs::cwbvh::builder::build_cwbvh` does with the same `params`, and collapses it with
/// [`collapse`]: the same tree as `build_cwbvh`, built faster.
pub fn build<T: Boundable>(primitives: &[T], params: BvhBuildParams) -> CwBvh {
    let mut bvh2 = obvhs::ploc::PlocBuilder::with_capacity(primitives.len()).build(
        params.ploc_search_distance,
        primitives,
        (0..primitives.len() as u32).collect(),
        params.sort_precision,
        params.search_depth_threshold,
    );
    obvhs::bvh2::reinsertion::ReinsertionOptimizer::default().run(
        &mut bvh2,
        params.reinsertion_batch_ratio,
        None,
    );
    collapse(&bvh2, params.max_prims_per_leaf.clamp(1, 3))
}

/// Collapses a binary BVH with one primitive per leaf (what PLOC builds) into a compressed
/// wide BVH whose leaves hold at most `max_leaf_prims` (1..=3) primitives, with children
/// ordered for octant-based traversal: equal to obvhs'
/// `bvh2_to_cwbvh(bvh2, max_leaf_prims, true, false)`.
pub fn collapse(bvh2: &Bvh2, max_leaf_prims: u32) -> CwBvh {
    assert!(
        (1..=3).contains(&max_leaf_prims),
        "leaf limit {max_leaf_prims}"
    );
    if bvh2.nodes.is_empty() {
        return CwBvh::default();
    }
    let parallel = bvh2.nodes.len() >= 2 * SEQUENTIAL_BELOW && rayon::current_num_threads() > 1;
    let slim = |n: &Bvh2Node| {
        let link = if n.is_leaf() {
            assert_eq!(n.prim_count, 1, "the collapse needs one primitive per leaf");
            let prim = bvh2.primitive_indices[n.first_index as usize];
            assert_eq!(prim & LEAF, 0, "primitive index {prim} too large");
            LEAF | prim
        } else {
            n.first_index
        };
        Slim {
            link,
            half_area: n.aabb().half_area(),
        }
    };
    let collapser = Collapser {
        nodes: &bvh2.nodes,
        slim: if parallel {
            bvh2.nodes.par_iter().map(slim).collect()
        } else {
            bvh2.nodes.iter().map(slim).collect()
        },
        max_leaf_prims,
        // An interior node's children are nodes[first_index] and nodes[first_index + 1], and
        // every node has one parent, so first_index / 2 differs between interior nodes.
        decisions: (0..bvh2.nodes.len() / 2 + 1)
            .map(|_| AtomicU32::new(0))
            .collect(),
        cost_fork_depth: if parallel { COST_FORK_DEPTH } else { 0 },
    };
    collapser.slot_costs(0, 0);

    let large_root = !collapser.is_leaf(0) && collapser.decision(0).is_large();
    let (nodes, primitive_indices) = if parallel && large_root {
        let top = collapser.emit_parallel(0, bvh2.nodes[0].aabb(), 0);
        let mut nodes = Vec::with_capacity(1 + top.node_count as usize);
        let mut prims = Vec::with_capacity(top.prim_count as usize);
        nodes.push(relocated(top.root, 1, 0));
        top.body.append_to(&mut nodes, &mut prims);
        (nodes, prims)
    } else {
        let mut nodes = vec![CwBvhNode::default()];
        let mut prims = Vec::with_capacity(bvh2.primitive_indices.len());
        nodes[0] = collapser.emit(0, bvh2.nodes[0].aabb(), &mut nodes, &mut prims);
        (nodes, prims)
    };
    CwBvh {
        nodes,
        primitive_indices,
        total_aabb: *bvh2.nodes[0].aabb(),
        exact_node_aabbs: None,
        uses_spatial_splits: bvh2.uses_spatial_splits,
    }
}

/// C(n, 1..=7) of a binary subtree, and its primitive count.
type SubtreeCost = ([f32; SLOT_COUNTS], u32);

struct Collapser<'a> {
    nodes: &'a [Bvh2Node],
    /// What the passes need of each binary node besides child boxes, 8 bytes instead of
    /// 48: the collapse visits the nodes depth-first, in an order unrelated to their memory
    /// layout, and this copy (made in one streaming pass) stays in cache where the nodes
    /// would not.
    slim: Vec<Slim>,
    max_leaf_prims: u32,
    /// Interior node n's [`Decision`] at `nodes[n].first_index / 2`. Atomics so the cost
    /// tasks can write their disjoint entries through a shared reference (relaxed: the joins
    /// order them before the emission reads them).
    decisions: Vec<AtomicU32>,
    cost_fork_depth: u32,
}

/// Ray octant directions in obvhs' slot-ordering convention: bit 2 of the octant flips x,
/// bit 1 y, bit 0 z.
const OCTANT_DIRS: [Vec3A; 8] = {
    let mut dirs = [Vec3A::ZERO; 8];
    let mut s = 0;
    while s < 8 {
        dirs[s] = Vec3A::new(
            if s & 4 != 0 { -1.0 } else { 1.0 },
            if s & 2 != 0 { -1.0 } else { 1.0 },
            if s & 1 != 0 { -1.0 } else { 1.0 },
        );
        s += 1;
    }
    dirs
};

/// A binary node: its half area, and its primitive (leaf, flagged with [`LEAF`]) or its
/// first child (interior: the children are `link` and `link + 1`).
#[derive(Clone, Copy)]
struct Slim {
    link: u32,
    half_area: f32,
}

const LEAF: u32 = 1 << 31;

/// Absent child in a slot list.
const EMPTY: u32 = u32::MAX;

impl Collapser<'_> {
    fn decision(&self, node: u32) -> Decision {
        Decision(self.decisions[self.slim[node as usize].link as usize / 2].load(Relaxed))
    }

    fn is_leaf(&self, node: u32) -> bool {
        self.slim[node as usize].link & LEAF != 0
    }

    /// Step 1 for `node`'s subtree: the costs C(node, 1..=7) (at 0..7) and its primitive
    /// count; stores the decisions of its interior nodes. Forks into tasks down to
    /// `cost_fork_depth`, below which [`Self::slot_costs_sequential`] takes over.
    fn slot_costs(&self, node: u32, depth: u32) -> SubtreeCost {
        let Slim { link, half_area } = self.slim[node as usize];
        if depth >= self.cost_fork_depth || link & LEAF != 0 {
            return self.slot_costs_recursive(node, depth);
        }
        let (left, right) = rayon::join(
            || self.slot_costs(link, depth + 1),
            || self.slot_costs(link + 1, depth + 1),
        );
        self.combine(link, half_area, left, right)
    }

    /// [`Self::slot_costs`] on one thread; past [`DEEP`] levels, with an explicit stack.
    fn slot_costs_recursive(&self, node: u32, depth: u32) -> SubtreeCost {
        let Slim { link, half_area } = self.slim[node as usize];
        if link & LEAF != 0 {
            return ([half_area * 1.0 * PRIM_COST; SLOT_COUNTS], 1);
        }
        if depth >= DEEP {
            return self.slot_costs_sequential(node);
        }
        // Leaf children without a call (half of all nodes are leaves).
        let cost = |child: u32| {
            let Slim { link, half_area } = self.slim[child as usize];
            if link & LEAF != 0 {
                ([half_area * 1.0 * PRIM_COST; SLOT_COUNTS], 1)
            } else {
                self.slot_costs_recursive(child, depth + 1)
            }
        };
        let left = cost(link);
        let right = cost(link + 1);
        self.combine(link, half_area, left, right)
    }

    /// [`Self::slot_costs`] on one thread, children before parents with an explicit stack
    /// (degenerate inputs, such as many coincident triangles, make binary trees thousands of
    /// levels deep).
    fn slot_costs_sequential(&self, root: u32) -> SubtreeCost {
        let mut todo = vec![(root, false)];
        let mut done: Vec<SubtreeCost> = Vec::new();
        while let Some((node, children_done)) = todo.pop() {
            let Slim { link, half_area } = self.slim[node as usize];
            if link & LEAF != 0 {
                done.push(([half_area * 1.0 * PRIM_COST; SLOT_COUNTS], 1));
            } else if children_done {
                let right = done.pop().expect("right child's cost");
                let left = done.pop().expect("left child's cost");
                done.push(self.combine(link, half_area, left, right));
            } else {
                todo.extend([(node, true), (link + 1, false), (link, false)]);
            }
        }
        done.pop().expect("root cost")
    }

    /// The dynamic program's step at an interior node (half area `area`, children `first`
    /// and `first + 1`) from its children's results; stores the node's decision.
    fn combine(
        &self,
        first: u32,
        area: f32,
        (left, left_prims): SubtreeCost,
        (right, right_prims): SubtreeCost,
    ) -> SubtreeCost {
        let prims = left_prims + right_prims;
        // Two leaf children (a third of the interior nodes) have constant cost tables: every
        // split costs the same, so only k = 0 can be a strict improvement and the loops
        // below stop there.
        let splits = if prims == 2 { 1 } else { SLOT_COUNTS };

        // One slot: a leaf, or a wide node whose 8 slots its children share (C_internal).
        let mut wide = f32::INFINITY;
        let mut wide_k = 0;
        // (Selects rather than branches: the comparisons are unpredictable.)
        for k in 0..splits {
            let c = left[k] + right[SLOT_COUNTS - 1 - k];
            let better = c < wide;
            wide_k = if better { k as u32 } else { wide_k };
            wide = if better { c } else { wide };
        }
        let as_internal = wide + area;
        let as_leaf = if prims <= self.max_leaf_prims {
            prims as f32 * area * PRIM_COST
        } else {
            f32::INFINITY
        };
        let internal = !(as_leaf < as_internal);
        let mut cost = [0.0; SLOT_COUNTS];
        cost[0] = if internal { as_internal } else { as_leaf };
        let mut bits = internal as u32 | wide_k << 1;

        // i + 1 slots: keep C(n, i) unless distributing them to the children is cheaper.
        for i in 1..SLOT_COUNTS {
            let mut best = cost[i - 1];
            let mut split = NO_SPLIT;
            for k in 0..i.min(splits) {
                let c = left[k] + right[i - 1 - k];
                let better = c < best;
                split = if better { k as u32 } else { split };
                best = if better { c } else { best };
            }
            cost[i] = best;
            bits |= split << (4 + 3 * (i - 1));
        }
        if prims >= PARALLEL_PRIMS {
            bits |= Decision::LARGE;
        }
        self.decisions[first as usize / 2].store(bits, Relaxed);
        (cost, prims)
    }

    /// The binary nodes that become the wide children of `node` (in discovery order).
    fn wide_children(&self, node: u32, out: &mut [u32; WIDTH], count: &mut usize) {
        if self.is_leaf(node) {
            // Only a single-primitive root gets here: the wide root holds it as a leaf.
            out[0] = node;
            *count = 1;
            return;
        }
        let first = self.slim[node as usize].link;
        self.gather(first, self.decision(node).wide_split(), out, count);
    }

    /// Appends the wide children that the binary children `first`, `first + 1` of a node
    /// contribute with `slots.0 + 1` and `slots.1 + 1` slots.
    fn gather(&self, first: u32, slots: (usize, usize), out: &mut [u32; WIDTH], count: &mut usize) {
        for (child, s) in [(first, slots.0), (first + 1, slots.1)] {
            let link = self.slim[child as usize].link;
            let split = if link & LEAF != 0 {
                None
            } else {
                Decision(self.decisions[link as usize / 2].load(Relaxed)).distribution(s)
            };
            match split {
                Some(split) => self.gather(link, split, out, count),
                None => {
                    out[*count] = child;
                    *count += 1;
                }
            }
        }
    }

    /// Is this binary node, taken as a wide child, an internal wide node (else a leaf)?
    fn is_wide_internal(&self, node: u32) -> bool {
        !self.is_leaf(node) && self.decision(node).is_internal()
    }

    /// Assigns children to slots so that, for each ray octant, sorting by the slot index
    /// roughly sorts them front to back (the paper's child ordering): the cost of child c
    /// in slot s is the offset of its centre from the parent's along octant s's diagonal,
    /// and the cheapest free (child, slot) pair is taken until all children are placed.
    /// `children` are the children's boxes; returns each slot's child (position in
    /// `children`) or [`EMPTY`].
    fn assign_slots(parent: &Aabb, children: &[Aabb]) -> [u32; WIDTH] {
        let centre = parent.center();
        let mut cost = [[0.0f32; WIDTH]; WIDTH];
        for (row, b) in cost.iter_mut().zip(children) {
            let offset = b.center() - centre;
            for (v, dir) in row.iter_mut().zip(OCTANT_DIRS) {
                *v = dir.dot(offset);
            }
        }
        // Greedy: repeatedly take the globally cheapest (child, free slot) pair, the first
        // in (child, slot) order on ties. Each child's cheapest free slot is kept, and only
        // the children whose cheapest slot was just taken look again (for the others
        // neither the minimum nor its first position can change). A placed child's minimum
        // becomes f32::MAX, which is never taken. Selects rather than branches: the
        // comparisons are unpredictable.
        let n = children.len();
        let cheapest = |row: &[f32; WIDTH], taken: u8| {
            let mut best = (f32::MAX, usize::MAX);
            for (s, &v) in row.iter().enumerate() {
                let v = if taken & (1 << s) == 0 { v } else { f32::MAX };
                let better = v < best.0;
                best = if better { (v, s) } else { best };
            }
            best
        };
        let mut taken = 0u8;
        let mut row_best = [(f32::MAX, usize::MAX); WIDTH];
        for (best, row) in row_best.iter_mut().zip(&cost).take(n) {
            *best = cheapest(row, taken);
        }
        let mut slot_of = [usize::MAX; WIDTH];
        for _ in 0..n {
            let mut pick = (f32::MAX, usize::MAX);
            for (c, &(v, _)) in row_best.iter().enumerate().take(n) {
                let better = v < pick.0;
                pick = if better { (v, c) } else { pick };
            }
            // No pick: NaN or huge offsets (boxes at infinity); those children fill the free
            // slots in order below.
            let c = pick.1;
            if c == usize::MAX {
                break;
            }
            let s = row_best[c].1;
            slot_of[c] = s;
            taken |= 1 << s;
            row_best[c] = (f32::MAX, usize::MAX);
            for other in 0..n {
                if row_best[other].1 == s {
                    row_best[other] = cheapest(&cost[other], taken);
                }
            }
        }
        let mut slots = [EMPTY; WIDTH];
        for (c, &slot) in slot_of.iter().enumerate().take(n) {
            let s = match slot {
                usize::MAX => {
                    let s = (!taken).trailing_zeros() as usize;
                    taken |= 1 << s;
                    s
                }
                s => s,
            };
            slots[s] = c as u32;
        }
        slots
    }

    /// Appends the primitives of a leaf wide child (a binary subtree of at most 3
    /// primitives) in depth-first order; returns how many.
    fn push_leaf_prims(&self, node: u32, prims: &mut Vec<u32>) -> u32 {
        let link = self.slim[node as usize].link;
        if link & LEAF != 0 {
            prims.push(link & !LEAF);
            1
        } else {
            self.push_leaf_prims(link, prims) + self.push_leaf_prims(link + 1, prims)
        }
    }

    /// The wide node for binary node `node` whose internal children will be stored from
    /// `child_base` on; appends its leaf children's primitives to `prims` (whose length is
    /// the node's primitive base). Returns the node and its internal children (binary node
    /// ids) in slot order, which is also their storage order.
    fn wide_node(
        &self,
        node: u32,
        bounds: &Aabb,
        child_base: u32,
        prims: &mut Vec<u32>,
    ) -> (CwBvhNode, [(u32, Aabb); WIDTH], usize) {
        let mut found = [EMPTY; WIDTH];
        let mut count = 0;
        self.wide_children(node, &mut found, &mut count);
        // All child boxes in one go, so that their cache misses overlap.
        let mut boxes = [Aabb::empty(); WIDTH];
        for (b, &c) in boxes.iter_mut().zip(&found[..count]) {
            *b = *self.nodes[c as usize].aabb();
        }
        let slots = Self::assign_slots(bounds, &boxes[..count]);

        // Quantisation frame (the paper's compressed node): origin at the box minimum, per
        // axis a power-of-two step 2^e with 255 steps covering the box, child planes rounded
        // outwards to whole steps.
        let origin = bounds.min;
        let step = ((bounds.max - bounds.min).max(Vec3A::splat(1e-20)) * (1.0 / 255.0))
            .log2()
            .ceil()
            .exp2();
        let inv_step = 1.0 / step;
        let exponent = |s: f32| (s.to_bits() >> 23) as u8;
        let mut wide = CwBvhNode {
            p: origin.into(),
            e: [exponent(step.x), exponent(step.y), exponent(step.z)],
            child_base_idx: child_base,
            primitive_base_idx: prims.len() as u32,
            ..Default::default()
        };
        let mut internal = [(EMPTY, Aabb::empty()); WIDTH];
        let mut internal_count = 0;
        let mut prim_offset = 0u32;
        for (slot, &c) in slots.iter().enumerate() {
            if c == EMPTY {
                continue;
            }
            let (child, b) = (found[c as usize], &boxes[c as usize]);
            let lo = ((b.min - origin) * inv_step)
                .floor()
                .clamp(Vec3A::ZERO, Vec3A::splat(255.0));
            let hi = ((b.max - origin) * inv_step)
                .ceil()
                .clamp(Vec3A::ZERO, Vec3A::splat(255.0));
            wide.child_min_x[slot] = lo.x as u8;
            wide.child_min_y[slot] = lo.y as u8;
            wide.child_min_z[slot] = lo.z as u8;
            wide.child_max_x[slot] = hi.x as u8;
            wide.child_max_y[slot] = hi.y as u8;
            wide.child_max_z[slot] = hi.z as u8;
            if self.is_wide_internal(child) {
                // Internal child: high bits 001, low bits 24 + slot.
                wide.imask |= 1 << slot;
                wide.child_meta[slot] = 0b0010_0000 | (24 + slot as u8);
                internal[internal_count] = (child, *b);
                internal_count += 1;
            } else {
                // Leaf child: primitive count in unary in the high 3 bits, offset from the
                // node's primitive base in the low 5.
                let n = self.push_leaf_prims(child, prims);
                debug_assert!((1..=3).contains(&n));
                wide.child_meta[slot] = (((1u8 << n) - 1) << 5) | prim_offset as u8;
                prim_offset += n;
            }
        }
        (wide, internal, internal_count)
    }

    /// Writes the descendants of binary node `node` as a wide node depth-first: its
    /// children block at the end of `nodes`, then each internal child's descendants.
    /// Returns `node`'s own wide node.
    fn emit(
        &self,
        node: u32,
        bounds: &Aabb,
        nodes: &mut Vec<CwBvhNode>,
        prims: &mut Vec<u32>,
    ) -> CwBvhNode {
        // An explicit stack of (binary node, its box, where its wide node goes): trees of
        // degenerate inputs can be very deep. Children are pushed in reverse so that each is
        // written, with all its descendants, before the next: the recursive order.
        let mut stack = vec![(node, *bounds, usize::MAX)];
        let mut root = CwBvhNode::default();
        while let Some((node, bounds, at)) = stack.pop() {
            let base = nodes.len();
            let (wide, internal, count) = self.wide_node(node, &bounds, base as u32, prims);
            match nodes.get_mut(at) {
                Some(slot) => *slot = wide,
                None => root = wide,
            }
            nodes.resize(base + count, CwBvhNode::default());
            let children = internal[..count].iter().enumerate().rev();
            stack.extend(children.map(|(j, &(child, b))| (child, b, base + j)));
        }
        root
    }

    /// [`Self::emit`] as a tree of tasks: a subtree with many primitives emits each internal
    /// child's descendants in its own task. Indices are relative to the start of `node`'s
    /// descendants (node and primitive arrays).
    fn emit_parallel(&self, node: u32, bounds: &Aabb, depth: u32) -> Subtree {
        if depth >= EMIT_FORK_DEPTH || !self.decision(node).is_large() {
            let mut nodes = Vec::new();
            let mut prims = Vec::new();
            let root = self.emit(node, bounds, &mut nodes, &mut prims);
            return Subtree {
                root,
                node_count: nodes.len() as u32,
                prim_count: prims.len() as u32,
                body: Body::Flat { nodes, prims },
            };
        }
        let mut prims = Vec::new();
        let (root, internal, count) = self.wide_node(node, bounds, 0, &mut prims);
        let parts: Vec<Subtree> = internal[..count]
            .par_iter()
            .map(|(child, b)| self.emit_parallel(*child, b, depth + 1))
            .collect();
        let mut block = Vec::with_capacity(count);
        let (mut node_count, mut prim_count) = (count as u32, prims.len() as u32);
        for part in &parts {
            block.push(relocated(part.root, node_count, prim_count));
            node_count += part.node_count;
            prim_count += part.prim_count;
        }
        Subtree {
            root,
            node_count,
            prim_count,
            body: Body::Split {
                block,
                prims,
                parts,
            },
        }
    }
}

/// A wide node and its descendants, emitted by [`Collapser::emit_parallel`].
struct Subtree {
    /// The node itself; indices relative to the start of its descendants.
    root: CwBvhNode,
    /// Descendant nodes and their primitives.
    node_count: u32,
    prim_count: u32,
    body: Body,
}

/// The descendants of a [`Subtree`], in layout order.
enum Body {
    /// Emitted by one task; indices relative to the start of these vectors.
    Flat {
        nodes: Vec<CwBvhNode>,
        prims: Vec<u32>,
    },
    /// The node's children block and its leaf children's primitives (indices relative to
    /// their start), then each internal child's descendants.
    Split {
        block: Vec<CwBvhNode>,
        prims: Vec<u32>,
        parts: Vec<Subtree>,
    },
}

impl Body {
    /// Appends these descendants at the end of `nodes` and `prims`, relocating indices.
    fn append_to(&self, nodes: &mut Vec<CwBvhNode>, prims: &mut Vec<u32>) {
        let (node_base, prim_base) = (nodes.len() as u32, prims.len() as u32);
        match self {
            Body::Flat { nodes: n, prims: p } => {
                nodes.extend(n.iter().map(|&w| relocated(w, node_base, prim_base)));
                prims.extend_from_slice(p);
            }
            Body::Split {
                block,
                prims: p,
                parts,
            } => {
                nodes.extend(block.iter().map(|&w| relocated(w, node_base, prim_base)));
                prims.extend_from_slice(p);
                for part in parts {
                    part.body.append_to(nodes, prims);
                }
            }
        }
    }
}

fn relocated(mut node: CwBvhNode, node_offset: u32, prim_offset: u32) -> CwBvhNode {
    node.child_base_idx += node_offset;
    node.primitive_base_idx += prim_offset;
    node
}
