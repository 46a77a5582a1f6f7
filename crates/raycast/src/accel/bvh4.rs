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
    pub min: [[f32; 4]; 3],
    pub max: [[f32; 4]; 3],
    pub child: [u32; 4],
    pub count: [u32; 4],
}

#[derive(Debug, Clone, Default)]
pub struct Bvh4 {
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
    pub fn traverse(
        &self,
        ray: &Ray,
        mut t_max: f32,
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
        // (reference, triangle count or 0 for a node, entry distance)
        let mut stack = [(0u32, 0u32, 0f32); 4 * super::bvh::MAX_DEPTH];
        let mut sp = 1;
        while sp > 0 {
            sp -= 1;
            let (r, count, t_entry) = stack[sp];
            if t_entry > t_max {
                continue;
            }
            if count > 0 {
                t_max = visit(r, count, t_max);
                continue;
            }
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
            order.sort_unstable_by(|a, b| b.0.total_cmp(&a.0));
            for &(t, slot) in order.iter() {
                stack[sp] = (n.child[slot], n.count[slot], t);
                sp += 1;
            }
        }
        t_max
    }
}
