//! A bounding volume hierarchy over world-space triangles: binned SAH build
//! (16 bins, leaves of at most 4 triangles), stored flat — 32-byte nodes in
//! depth-first order, children adjacent — so the GPU core can upload it as is.

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use crate::ray::{Aabb, Ray};

/// One node. Interior: `count == 0`, children at `left_or_first` and
/// `left_or_first + 1`. Leaf: triangles `left_or_first .. + count` of the
/// reordered triangle list.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct BvhNode {
    /// Lower corner of the node's box, world mm.
    pub min: [f32; 3],
    /// Interior: index of the left child (the right one follows it). Leaf:
    /// index of the first triangle in the reordered list.
    pub left_or_first: u32,
    /// Upper corner of the node's box, world mm.
    pub max: [f32; 3],
    /// Triangles in the leaf; 0 for an interior node.
    pub count: u32,
}

impl BvhNode {
    /// The node's box.
    pub fn aabb(&self) -> Aabb {
        Aabb {
            min: Vec3::from(self.min),
            max: Vec3::from(self.max),
        }
    }
}

const BINS: usize = 16;
const MAX_LEAF: usize = 4;
/// Traversal stack depth; the builder never exceeds it (see `build`).
pub const MAX_DEPTH: usize = 64;

/// A built hierarchy: nodes, and the order in which triangles must be stored.
#[derive(Debug, Clone)]
pub struct Bvh {
    /// The nodes, depth-first; node 0 is the root.
    pub nodes: Vec<BvhNode>,
    /// `order[i]` = original index of the i-th triangle in leaf order.
    pub order: Vec<u32>,
}

impl Bvh {
    /// Builds over triangle bounds. Depth is capped at `MAX_DEPTH - 2`
    /// (deeper splits become larger leaves), so traversal never overflows.
    pub fn build(bounds: &[Aabb]) -> Self {
        let centres: Vec<Vec3> = bounds.iter().map(Aabb::centre).collect();
        let mut order: Vec<u32> = (0..bounds.len() as u32).collect();
        let mut nodes = vec![BvhNode::zeroed()];
        if bounds.is_empty() {
            return Self { nodes, order };
        }
        // (node index, first, count, depth)
        let mut work = vec![(0usize, 0usize, bounds.len(), 0usize)];
        while let Some((node, first, count, depth)) = work.pop() {
            let items = &order[first..first + count];
            let mut bb = Aabb::EMPTY;
            let mut cb = Aabb::EMPTY;
            for &i in items {
                bb = bb.union(&bounds[i as usize]);
                cb.grow(centres[i as usize]);
            }
            let split = if count <= MAX_LEAF || depth >= MAX_DEPTH - 2 {
                None
            } else {
                best_split(items, bounds, &centres, &cb, &bb)
            };
            let Some((axis, pos)) = split else {
                nodes[node] = leaf(&bb, first, count);
                continue;
            };
            // Partition by centroid.
            let slice = &mut order[first..first + count];
            let mut l = 0;
            for k in 0..slice.len() {
                if centres[slice[k] as usize][axis] < pos {
                    slice.swap(l, k);
                    l += 1;
                }
            }
            if l == 0 || l == count {
                nodes[node] = leaf(&bb, first, count);
                continue;
            }
            let left = nodes.len();
            nodes.push(BvhNode::zeroed());
            nodes.push(BvhNode::zeroed());
            nodes[node] = BvhNode {
                min: bb.min.into(),
                left_or_first: left as u32,
                max: bb.max.into(),
                count: 0,
            };
            work.push((left + 1, first + l, count - l, depth + 1));
            work.push((left, first, l, depth + 1));
        }
        Self { nodes, order }
    }

    /// Visits, near to far, the leaves whose box the ray enters before
    /// `t_max`; `visit(first, count, t_max)` returns the new `t_max`.
    #[inline]
    pub fn traverse(
        &self,
        ray: &Ray,
        mut t_max: f32,
        mut visit: impl FnMut(u32, u32, f32) -> f32,
    ) -> f32 {
        // Far children wait on the stack with their entry distance, so a pop
        // skips them without a second box test once a closer hit is known.
        if self.nodes[0].aabb().hit(ray, t_max).is_none() {
            return t_max;
        }
        let mut stack = [(0u32, 0f32); MAX_DEPTH];
        let mut sp = 0;
        let mut node = 0u32;
        loop {
            let n = &self.nodes[node as usize];
            if n.count > 0 {
                t_max = visit(n.left_or_first, n.count, t_max);
            } else {
                let (a, b) = (n.left_or_first, n.left_or_first + 1);
                let ha = self.nodes[a as usize].aabb().hit(ray, t_max);
                let hb = self.nodes[b as usize].aabb().hit(ray, t_max);
                match (ha, hb) {
                    (Some(ta), Some(tb)) => {
                        let (near, far, t_far) = if ta <= tb { (a, b, tb) } else { (b, a, ta) };
                        stack[sp] = (far, t_far);
                        sp += 1;
                        node = near;
                        continue;
                    }
                    (Some(_), None) => {
                        node = a;
                        continue;
                    }
                    (None, Some(_)) => {
                        node = b;
                        continue;
                    }
                    (None, None) => {}
                }
            }
            // Pop, skipping nodes that start beyond the closest hit.
            loop {
                if sp == 0 {
                    return t_max;
                }
                sp -= 1;
                let (next, t_entry) = stack[sp];
                if t_entry <= t_max {
                    node = next;
                    break;
                }
            }
        }
    }
}

fn leaf(bb: &Aabb, first: usize, count: usize) -> BvhNode {
    BvhNode {
        min: bb.min.into(),
        left_or_first: first as u32,
        max: bb.max.into(),
        count: count as u32,
    }
}

/// Binned SAH (Wald 2007): the cheapest of `BINS - 1` planes per axis, or
/// `None` when no split beats a leaf.
// `axis` indexes vector components, not the slices clippy sees.
#[allow(clippy::needless_range_loop)]
fn best_split(
    items: &[u32],
    bounds: &[Aabb],
    centres: &[Vec3],
    cb: &Aabb,
    bb: &Aabb,
) -> Option<(usize, f32)> {
    let mut best: Option<(f32, usize, f32)> = None;
    for axis in 0..3 {
        let (lo, hi) = (cb.min[axis], cb.max[axis]);
        if hi - lo <= f32::EPSILON * lo.abs().max(hi.abs()).max(1.0) {
            continue;
        }
        let scale = BINS as f32 / (hi - lo);
        let mut bins = [(Aabb::EMPTY, 0u32); BINS];
        for &i in items {
            let b = (((centres[i as usize][axis] - lo) * scale) as usize).min(BINS - 1);
            bins[b].0 = bins[b].0.union(&bounds[i as usize]);
            bins[b].1 += 1;
        }
        // Sweep: areas and counts left of each plane, then right.
        let mut left = [(0.0f32, 0u32); BINS - 1];
        let (mut acc, mut n) = (Aabb::EMPTY, 0);
        for k in 0..BINS - 1 {
            acc = acc.union(&bins[k].0);
            n += bins[k].1;
            left[k] = (acc.surface_area(), n);
        }
        let (mut acc, mut n) = (Aabb::EMPTY, 0);
        for k in (1..BINS).rev() {
            acc = acc.union(&bins[k].0);
            n += bins[k].1;
            let (la, ln) = left[k - 1];
            if ln == 0 || n == 0 {
                continue;
            }
            let cost = la * ln as f32 + acc.surface_area() * n as f32;
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, lo + k as f32 / scale));
            }
        }
    }
    let leaf_cost = bb.surface_area() * items.len() as f32;
    best.filter(|(c, _, _)| *c < leaf_cost || items.len() > 4 * MAX_LEAF)
        .map(|(_, a, p)| (a, p))
}
