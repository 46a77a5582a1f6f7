//! A 4-wide BVH collapsed from the binary one: each node holds its (up to)
//! four children's boxes in structure-of-arrays form, so one SIMD pass tests
//! all four. This is what the CPU caster traverses (the binary BVH remains
//! the layout the GPU core uploads, and the path for rays with a zero
//! direction component, which need the exact slab test).

use glam::{Vec3A, Vec4};

use super::bvh::Bvh;
use crate::ray::Ray;

/// Marks an unused child slot.
pub const EMPTY: u32 = u32::MAX;

/// 128 bytes: four child boxes (SoA), child references, leaf triangle counts.
/// `count[i] > 0`: leaf with triangles `child[i] .. child[i] + count[i]`;
/// `count[i] == 0`: interior node `child[i]` (or an empty slot if `EMPTY`).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bvh4Node {
    /// Lower corners of the four child boxes: `min[axis][child]`, world mm.
    pub min: [[f32; 4]; 3],
    /// Upper corners of the four child boxes: `max[axis][child]`, world mm.
    pub max: [[f32; 4]; 3],
    /// Per slot: the first triangle of a leaf, an interior node's index, or [`EMPTY`].
    pub child: [u32; 4],
    /// Per slot: the leaf's triangle count; 0 for an interior node or an empty slot.
    pub count: [u32; 4],
}

/// The 4-wide BVH: the binary [`Bvh`] collapsed so that each node tests four boxes at once.
#[derive(Debug, Clone, Default)]
pub struct Bvh4 {
    /// The nodes; node 0 is the root.
    pub nodes: Vec<Bvh4Node>,
    /// Bounds of everything: a ray that misses them costs one box test and
    /// no traversal set-up.
    pub bounds: Option<crate::ray::Aabb>,
}

impl Bvh4 {
    /// Collapses a binary BVH: each wide node takes the binary node's
    /// children and keeps opening the largest interior one (by surface area)
    /// until it has four children or only leaves.
    pub fn collapse(bin: &Bvh) -> Self {
        let mut out = Bvh4 {
            nodes: Vec::with_capacity(bin.nodes.len() / 2 + 1),
            bounds: None,
        };
        if bin.order.is_empty() {
            return out; // no triangles: the binary root is a placeholder
        }
        out.bounds = Some(bin.nodes[0].aabb());
        out.build(bin, 0);
        out
    }

    fn build(&mut self, bin: &Bvh, node: u32) -> u32 {
        let me = self.nodes.len() as u32;
        self.nodes.push(Bvh4Node {
            min: [[0.0; 4]; 3],
            max: [[0.0; 4]; 3],
            child: [EMPTY; 4],
            count: [0; 4],
        });
        let n = &bin.nodes[node as usize];
        let mut kids: Vec<u32> = if n.count > 0 {
            vec![node]
        } else {
            vec![n.left_or_first, n.left_or_first + 1]
        };
        while kids.len() < 4 {
            let open = kids
                .iter()
                .enumerate()
                .filter(|(_, &k)| bin.nodes[k as usize].count == 0)
                .max_by(|a, b| {
                    let area = |k: u32| bin.nodes[k as usize].aabb().surface_area();
                    area(*a.1).total_cmp(&area(*b.1))
                })
                .map(|(i, _)| i);
            let Some(i) = open else { break };
            let k = kids.swap_remove(i);
            let l = bin.nodes[k as usize].left_or_first;
            kids.extend([l, l + 1]);
        }
        let mut wide = self.nodes[me as usize];
        for (slot, &k) in kids.iter().enumerate() {
            let c = &bin.nodes[k as usize];
            for a in 0..3 {
                wide.min[a][slot] = c.min[a];
                wide.max[a][slot] = c.max[a];
            }
            if c.count > 0 {
                wide.child[slot] = c.left_or_first;
                wide.count[slot] = c.count;
            } else {
                wide.child[slot] = self.build(bin, k);
            }
        }
        self.nodes[me as usize] = wide;
        me
    }

    /// Visits, near to far, the leaves whose box the ray enters before the
    /// current `t_max`; `visit(first, count, t_max)` returns the new `t_max`.
    /// The ray must have no zero direction component (see `Ray::is_parallel`).
    #[inline]
    pub fn traverse(&self, ray: &Ray, t_max: f32, visit: impl FnMut(u32, u32, f32) -> f32) -> f32 {
        self.traverse_counting(ray, t_max, || {}, visit)
    }

    /// [`Bvh4::traverse`], calling `on_node` at every interior node it
    /// tests (for counting traversal steps: `Scene::traversal_steps`).
    #[inline]
    pub fn traverse_counting(
        &self,
        ray: &Ray,
        mut t_max: f32,
        mut on_node: impl FnMut(),
        mut visit: impl FnMut(u32, u32, f32) -> f32,
    ) -> f32 {
        match self.bounds {
            Some(b) if b.hit(ray, t_max).is_some() => {}
            _ => return t_max,
        }
        let o: Vec3A = ray.origin.into();
        let inv = ray.inv_dir;
        let (ox, oy, oz) = (Vec4::splat(o.x), Vec4::splat(o.y), Vec4::splat(o.z));
        let (ix, iy, iz) = (Vec4::splat(inv.x), Vec4::splat(inv.y), Vec4::splat(inv.z));
        let grow = 1.0 + 2.0 * f32::EPSILON;
        let mut stack = Stack::new();
        while let Some((r, count, t_entry)) = stack.pop() {
            if t_entry > t_max {
                continue;
            }
            if count > 0 {
                t_max = visit(r, count, t_max);
                continue;
            }
            on_node();
            let n = &self.nodes[r as usize];
            let t1x = (Vec4::from(n.min[0]) - ox) * ix;
            let t2x = (Vec4::from(n.max[0]) - ox) * ix;
            let t1y = (Vec4::from(n.min[1]) - oy) * iy;
            let t2y = (Vec4::from(n.max[1]) - oy) * iy;
            let t1z = (Vec4::from(n.min[2]) - oz) * iz;
            let t2z = (Vec4::from(n.max[2]) - oz) * iz;
            let near = t1x
                .min(t2x)
                .max(t1y.min(t2y))
                .max(t1z.min(t2z))
                .max(Vec4::ZERO);
            let far =
                (t1x.max(t2x).min(t1y.max(t2y)).min(t1z.max(t2z)) * grow).min(Vec4::splat(t_max));
            let hit = near.cmple(far).bitmask();
            // Push hit children far to near, so the nearest is popped first.
            let mut order = [(0f32, 0usize); 4];
            let mut k = 0;
            for slot in 0..4 {
                if hit & (1 << slot) != 0 && n.child[slot] != EMPTY {
                    order[k] = (near[slot], slot);
                    k += 1;
                }
            }
            let order = &mut order[..k];
            // Far to near by insertion (at most four entries; the order of
            // `sort_unstable_by` on them, without its call).
            for i in 1..order.len() {
                let mut j = i;
                while j > 0 && order[j - 1].0.total_cmp(&order[j].0).is_lt() {
                    order.swap(j - 1, j);
                    j -= 1;
                }
            }
            for &(t, slot) in order.iter() {
                stack.push((n.child[slot], n.count[slot], t));
            }
        }
        t_max
    }
}

/// Rays a packet holds ([`Bvh4::traverse_packet`]): eight neighbouring
/// pixels of a row.
pub const PACKET: usize = 8;

/// The lanes set in `mask`, lowest first.
#[inline]
pub(crate) fn lanes(mut mask: u32) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        (mask != 0).then(|| {
            let i = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            i
        })
    })
}

impl Bvh4 {
    /// Traverses the tree once for a packet of up to [`PACKET`] rays (the
    /// lanes set in `active`; lane `i` is `rays[i]`): each node is fetched
    /// once and its four boxes tested against all eight lanes together
    /// (`test_node`: eight lanes an instruction where the processor has
    /// AVX2; the lanes that cannot reach the node are masked off), with
    /// exactly the arithmetic of [`Bvh4::traverse`] per lane (so a
    /// lane enters a box here exactly when it would there, given the same
    /// `t_max`). Children are visited near to far by the nearest lane's
    /// entry. `visit(first, count, lanes, t_max)` tests a leaf's triangles
    /// for the lanes set in `lanes` and lowers their `t_max`. A lane is
    /// dropped from a box only when its own entry distance exceeds its
    /// `t_max`. Every active ray must have no zero direction component.
    #[inline]
    pub fn traverse_packet(
        &self,
        rays: &[Ray],
        active: u32,
        t_max: &mut [f32; PACKET],
        mut visit: impl FnMut(u32, u32, u32, &mut [f32; PACKET]),
    ) {
        let Some(b) = self.bounds else { return };
        let n = rays.len().min(PACKET);
        let mut live = 0u32;
        let mut setup = Lanes8 {
            o: [[0.0; PACKET]; 3],
            inv: [[0.0; PACKET]; 3],
        };
        for i in lanes(active & ((1u32 << n) - 1)) {
            let ray = &rays[i];
            if b.hit(ray, t_max[i]).is_none() {
                continue;
            }
            live |= 1 << i;
            for a in 0..3 {
                setup.o[a][i] = ray.origin[a];
                setup.inv[a][i] = ray.inv_dir[a];
            }
        }
        if live == 0 {
            return;
        }
        let mut stack = PacketStack::new(live);
        while let Some((r, count, mask, t_entry)) = stack.pop() {
            // The lanes that may still meet something in this box: the
            // entry is the nearest lane's, so no lane's own entry is less.
            let mut mask_live = 0u32;
            for i in lanes(mask) {
                if t_entry <= t_max[i] {
                    mask_live |= 1 << i;
                }
            }
            if mask_live == 0 {
                continue;
            }
            if count > 0 {
                visit(r, count, mask_live, t_max);
                continue;
            }
            let n = &self.nodes[r as usize];
            let mut near = [[0f32; PACKET]; 4];
            let hits = test_node(n, &setup, t_max, &mut near);
            let mut child_lanes = [0u32; 4];
            let mut child_near = [f32::INFINITY; 4];
            for slot in 0..4 {
                child_lanes[slot] = hits[slot] & mask_live;
                for i in lanes(child_lanes[slot]) {
                    child_near[slot] = child_near[slot].min(near[slot][i]);
                }
            }
            let mut order = [(0f32, 0usize); 4];
            let mut k = 0;
            for slot in 0..4 {
                if child_lanes[slot] != 0 && n.child[slot] != EMPTY {
                    order[k] = (child_near[slot], slot);
                    k += 1;
                }
            }
            let order = &mut order[..k];
            for i in 1..order.len() {
                let mut j = i;
                while j > 0 && order[j - 1].0.total_cmp(&order[j].0).is_lt() {
                    order.swap(j - 1, j);
                    j -= 1;
                }
            }
            for &(t, slot) in order.iter() {
                stack.push((n.child[slot], n.count[slot], child_lanes[slot], t));
            }
        }
    }
}

/// A packet's rays as structure of arrays: origin and reciprocal
/// direction, per axis, per lane.
struct Lanes8 {
    o: [[f32; PACKET]; 3],
    inv: [[f32; PACKET]; 3],
}

/// `_mm_min_ps(a, b)` on one lane (glam's `Vec4::min`): `b` unless `a < b`,
/// so a NaN gives `b` exactly as the single ray's SIMD test does.
#[inline(always)]
fn min_ps(a: f32, b: f32) -> f32 {
    if a < b {
        a
    } else {
        b
    }
}

/// `_mm_max_ps(a, b)` on one lane (glam's `Vec4::max`).
#[inline(always)]
fn max_ps(a: f32, b: f32) -> f32 {
    if a > b {
        a
    } else {
        b
    }
}

/// A node's four boxes against all eight lanes: per child, the lanes
/// that enter it (bit `i` for lane `i`) and each lane's entry distance in
/// `near`. Per lane, exactly [`Bvh4::traverse`]'s arithmetic and operand
/// order (so the same bits, NaN cases included); written lane-wise so the
/// compiler vectorises across the lanes (eight per instruction where
/// [`test_node`] finds AVX2).
#[inline(always)]
fn test_node_lanes(
    n: &Bvh4Node,
    l: &Lanes8,
    t_max: &[f32; PACKET],
    near: &mut [[f32; PACKET]; 4],
) -> [u32; 4] {
    let grow = 1.0 + 2.0 * f32::EPSILON;
    let mut out = [0u32; 4];
    for slot in 0..4 {
        let mut hit = [false; PACKET];
        for i in 0..PACKET {
            let t1x = (n.min[0][slot] - l.o[0][i]) * l.inv[0][i];
            let t2x = (n.max[0][slot] - l.o[0][i]) * l.inv[0][i];
            let t1y = (n.min[1][slot] - l.o[1][i]) * l.inv[1][i];
            let t2y = (n.max[1][slot] - l.o[1][i]) * l.inv[1][i];
            let t1z = (n.min[2][slot] - l.o[2][i]) * l.inv[2][i];
            let t2z = (n.max[2][slot] - l.o[2][i]) * l.inv[2][i];
            let nr = max_ps(
                max_ps(max_ps(min_ps(t1x, t2x), min_ps(t1y, t2y)), min_ps(t1z, t2z)),
                0.0,
            );
            let fr = min_ps(
                min_ps(min_ps(max_ps(t1x, t2x), max_ps(t1y, t2y)), max_ps(t1z, t2z)) * grow,
                t_max[i],
            );
            near[slot][i] = nr;
            hit[i] = nr <= fr;
        }
        let mut m = 0u32;
        for (i, h) in hit.iter().enumerate() {
            m |= u32::from(*h) << i;
        }
        out[slot] = m;
    }
    out
}

/// [`test_node_lanes`] compiled with AVX2 enabled.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn test_node_avx2(
    n: &Bvh4Node,
    l: &Lanes8,
    t_max: &[f32; PACKET],
    near: &mut [[f32; PACKET]; 4],
) -> [u32; 4] {
    test_node_lanes(n, l, t_max, near)
}

/// [`test_node_lanes`], with AVX2 where the processor has it.
#[inline(always)]
fn test_node(
    n: &Bvh4Node,
    l: &Lanes8,
    t_max: &[f32; PACKET],
    near: &mut [[f32; PACKET]; 4],
) -> [u32; 4] {
    #[cfg(target_arch = "x86_64")]
    if std::arch::is_x86_feature_detected!("avx2") {
        // SAFETY: the processor has AVX2 (checked just above), the only
        // requirement of a `target_feature(enable = "avx2")` function.
        return unsafe { test_node_avx2(n, l, t_max, near) };
    }
    test_node_lanes(n, l, t_max, near)
}

/// A packet traversal's stack: (reference, triangle count or 0 for a
/// node, lanes, nearest lane's entry distance), inline up to
/// [`STACK_INLINE`] entries, then spilling to the heap.
struct PacketStack {
    inline: [(u32, u32, u32, f32); STACK_INLINE],
    len: usize,
    spill: Vec<(u32, u32, u32, f32)>,
}

impl PacketStack {
    #[inline]
    fn new(lanes: u32) -> Self {
        let mut s = Self {
            inline: [(0, 0, 0, 0.0); STACK_INLINE],
            len: 1,
            spill: Vec::new(),
        };
        s.inline[0] = (0, 0, lanes, 0.0); // the root
        s
    }

    #[inline]
    fn push(&mut self, e: (u32, u32, u32, f32)) {
        if self.len < STACK_INLINE {
            self.inline[self.len] = e;
            self.len += 1;
        } else {
            self.spill.push(e);
        }
    }

    #[inline]
    fn pop(&mut self) -> Option<(u32, u32, u32, f32)> {
        if let Some(e) = self.spill.pop() {
            return Some(e);
        }
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        Some(self.inline[self.len])
    }
}

/// Entries the traversal stack holds in place; a deeper stack spills to the
/// heap. Each level of a 4-wide node pushes at most three entries more than
/// it pops, so 64 cover a tree 21 levels deep; the builder's depth cap
/// (`MAX_DEPTH`) allows more, which the spill handles.
const STACK_INLINE: usize = 64;

/// One traversal's stack: (reference, triangle count or 0 for a node,
/// entry distance). The inline part is small so that setting it up costs
/// little per ray (a 4·`MAX_DEPTH` array zeroed per ray was 6–10 % of a
/// frame's time).
struct Stack {
    inline: [(u32, u32, f32); STACK_INLINE],
    len: usize,
    spill: Vec<(u32, u32, f32)>,
}

impl Stack {
    #[inline]
    fn new() -> Self {
        let mut s = Self {
            inline: [(0, 0, 0.0); STACK_INLINE],
            len: 1,
            spill: Vec::new(),
        };
        s.inline[0] = (0, 0, 0.0); // the root
        s
    }

    #[inline]
    fn push(&mut self, e: (u32, u32, f32)) {
        if self.len < STACK_INLINE {
            self.inline[self.len] = e;
            self.len += 1;
        } else {
            self.spill.push(e);
        }
    }

    #[inline]
    fn pop(&mut self) -> Option<(u32, u32, f32)> {
        if let Some(e) = self.spill.pop() {
            return Some(e);
        }
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        Some(self.inline[self.len])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_stack_is_last_in_first_out_past_its_inline_part() {
        let mut s = Stack::new();
        assert_eq!(s.pop(), Some((0, 0, 0.0)), "the root comes first");
        assert_eq!(s.pop(), None);
        let n = 3 * STACK_INLINE + 7;
        for i in 0..n as u32 {
            s.push((i, i + 1, i as f32));
        }
        assert!(!s.spill.is_empty(), "the test reaches the spill");
        // Interleaved pops and pushes across the boundary keep the order.
        for i in (n as u32 - 10..n as u32).rev() {
            assert_eq!(s.pop(), Some((i, i + 1, i as f32)));
        }
        s.push((9999, 0, 1.0));
        assert_eq!(s.pop(), Some((9999, 0, 1.0)));
        for i in (0..n as u32 - 10).rev() {
            assert_eq!(s.pop(), Some((i, i + 1, i as f32)));
        }
        assert_eq!(s.pop(), None);
    }
}
