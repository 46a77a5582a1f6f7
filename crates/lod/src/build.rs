//! Building the vertex tree: validation, welding of coincident vertices,
//! Garland–Heckbert edge collapses, a spatial merge of the remaining
//! components, then the per-node data (spheres, luminance, masks, subtris).

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use glam::{DVec3, Vec3};

use crate::normal_mask::{NormalCone, NormalMask};
use crate::quadric::Quadric;
use crate::sphere::DSphere;
use crate::tree::{VertexTree, NONE};
use crate::LodError;

/// Limits checked before anything is allocated.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BuildOptions {
    /// Default 2²⁶ (67 M vertices; the tree then needs about 13 GB).
    pub max_vertices: usize,
    /// Default 2²⁷.
    pub max_triangles: usize,
}

impl Default for BuildOptions {
    fn default() -> Self {
        Self {
            max_vertices: 1 << 26,
            max_triangles: 1 << 27,
        }
    }
}

/// Weight of the plane perpendicular to a boundary edge, per squared edge
/// length (Garland & Heckbert's boundary preservation; a face plane weighs
/// its area, about half a squared edge, so this is ~20× stronger).
const BOUNDARY_WEIGHT: f64 = 10.0;

#[derive(Clone, Copy)]
struct Candidate {
    cost: f64,
    x: u32,
    partner: u32,
}

impl PartialEq for Candidate {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o) == Ordering::Equal
    }
}
impl Eq for Candidate {}
impl PartialOrd for Candidate {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Candidate {
    /// Reversed so `BinaryHeap` pops the cheapest; ties by ids (determinism).
    fn cmp(&self, o: &Self) -> Ordering {
        o.cost
            .total_cmp(&self.cost)
            .then_with(|| o.x.cmp(&self.x))
            .then_with(|| o.partner.cmp(&self.partner))
    }
}

/// Per-cluster lists of the live triangles touching it (singly linked,
/// with tails for O(1) concatenation; dead entries are dropped lazily when
/// a walk meets them).
struct Incidence {
    next: Vec<u32>,
    head: Vec<u32>,
    tail: Vec<u32>,
    stamp: Vec<u32>,
    walk: u32,
    /// Current cluster of each triangle corner.
    wc: Vec<[u32; 3]>,
    alive: Vec<bool>,
}

impl Incidence {
    /// c's list := a's list followed by b's.
    fn concat(&mut self, c: u32, a: u32, b: u32) {
        let (ci, ai, bi) = (c as usize, a as usize, b as usize);
        if self.head[ai] == NONE {
            self.head[ci] = self.head[bi];
            self.tail[ci] = self.tail[bi];
        } else {
            self.head[ci] = self.head[ai];
            self.next[self.tail[ai] as usize] = self.head[bi];
            self.tail[ci] = if self.head[bi] == NONE {
                self.tail[ai]
            } else {
                self.tail[bi]
            };
        }
    }

    /// Walks c's list: remaps corners a, b → c (pass `NONE` to remap
    /// nothing), drops triangles that degenerate (exactly those spanning a
    /// and b) and dead ones, and collects c's distinct neighbours.
    fn walk(&mut self, c: u32, a: u32, b: u32, out: &mut Vec<u32>) {
        out.clear();
        self.walk = self.walk.wrapping_add(1);
        if self.walk == 0 {
            self.stamp.fill(0);
            self.walk = 1;
        }
        let ci = c as usize;
        let mut prev = NONE;
        let mut s = self.head[ci];
        while s != NONE {
            let t = (s / 3) as usize;
            let nxt = self.next[s as usize];
            let mut keep = self.alive[t];
            if keep {
                let tri = &mut self.wc[t];
                for x in tri.iter_mut() {
                    if *x == a || *x == b {
                        *x = c;
                    }
                }
                if !distinct(tri) {
                    self.alive[t] = false;
                    keep = false;
                } else {
                    for &x in tri.iter() {
                        if x != c && self.stamp[x as usize] != self.walk {
                            self.stamp[x as usize] = self.walk;
                            out.push(x);
                        }
                    }
                }
            }
            if keep {
                prev = s;
            } else {
                if prev == NONE {
                    self.head[ci] = nxt;
                } else {
                    self.next[prev as usize] = nxt;
                }
                if nxt == NONE {
                    self.tail[ci] = prev;
                }
            }
            s = nxt;
        }
    }
}

fn validate(
    positions: &[Vec3],
    normals: &[Vec3],
    luminance: &[f32],
    triangles: &[[u32; 3]],
    options: &BuildOptions,
) -> Result<(), LodError> {
    let n = positions.len();
    if n == 0 {
        return Err(LodError::EmptyMesh);
    }
    if n > options.max_vertices || n > (u32::MAX / 2) as usize {
        return Err(LodError::TooLarge {
            what: "vertices",
            field: "max_vertices",
            count: n,
            max: options.max_vertices.min((u32::MAX / 2) as usize),
        });
    }
    if triangles.len() > options.max_triangles || triangles.len() > (u32::MAX / 3) as usize {
        return Err(LodError::TooLarge {
            what: "triangles",
            field: "max_triangles",
            count: triangles.len(),
            max: options.max_triangles.min((u32::MAX / 3) as usize),
        });
    }
    for (what, len) in [("normals", normals.len()), ("luminance", luminance.len())] {
        if len != n {
            return Err(LodError::LengthMismatch {
                what,
                expected: n,
                got: len,
            });
        }
    }
    for (what, arr) in [("position", positions), ("normal", normals)] {
        if let Some((i, p)) = arr.iter().enumerate().find(|(_, p)| !p.is_finite()) {
            return Err(LodError::NonFinite {
                what,
                index: i,
                value: format!("{p}"),
            });
        }
    }
    for (i, &l) in luminance.iter().enumerate() {
        if !l.is_finite() {
            return Err(LodError::NonFinite {
                what: "luminance",
                index: i,
                value: format!("{l}"),
            });
        }
        if l < 0.0 {
            return Err(LodError::NegativeLuminance { index: i, value: l });
        }
    }
    for (t, tri) in triangles.iter().enumerate() {
        for (corner, &index) in tri.iter().enumerate() {
            if index as usize >= n {
                return Err(LodError::IndexOutOfRange {
                    triangle: t,
                    corner,
                    index,
                    vertex_count: n,
                });
            }
        }
    }
    Ok(())
}

fn distinct(t: &[u32; 3]) -> bool {
    t[0] != t[1] && t[1] != t[2] && t[0] != t[2]
}

/// Working state of the merge phase.
struct Merger {
    parent: Vec<u32>,
    children: Vec<[u32; 2]>,
    proxy: Vec<Vec3>,
    quadric: Vec<Quadric>,
}

impl Merger {
    fn new_node(&mut self, a: u32, b: u32, pos: Vec3) -> u32 {
        let c = self.parent.len() as u32;
        self.parent.push(NONE);
        self.children.push([a, b]);
        self.proxy.push(pos);
        let q = Quadric::sum(&self.quadric[a as usize], &self.quadric[b as usize]);
        self.quadric.push(q);
        self.parent[a as usize] = c;
        self.parent[b as usize] = c;
        c
    }

    /// Where merging `a` and `b` puts the proxy, and the quadric error
    /// there: the quadric optimum when A is well conditioned and the optimum
    /// stays near the pair, else the best point on the segment between the
    /// two proxies (Garland & Heckbert §4; midpoint when flat).
    fn placement(&self, a: u32, b: u32) -> (Vec3, f64) {
        let q = Quadric::sum(&self.quadric[a as usize], &self.quadric[b as usize]);
        let pa = self.proxy[a as usize].as_dvec3();
        let pb = self.proxy[b as usize].as_dvec3();
        let mid = (pa + pb) * 0.5;
        let reach = 2.0 * pa.distance(pb);
        let x = match q.optimum() {
            Some(x) if x.distance(mid) <= reach => x,
            _ => q.segment_optimum(pa, pb),
        };
        let pos = x.as_vec3();
        (pos, q.error(pos.as_dvec3()))
    }
}

fn face_normal_area(p: [DVec3; 3]) -> (DVec3, f64) {
    let cross = (p[1] - p[0]).cross(p[2] - p[0]);
    let len = cross.length();
    let scale = (p[1] - p[0])
        .length_squared()
        .max((p[2] - p[0]).length_squared());
    if len > 1e-12 * scale && len > 0.0 {
        (cross / len, 0.5 * len)
    } else {
        (DVec3::ZERO, 0.0)
    }
}

impl VertexTree {
    /// Builds the tree with [`BuildOptions::default`]. `positions` in world
    /// millimetres, `normals` one per vertex (they only feed the proxy
    /// normals; facing uses the triangles' own normals), `luminance` one per
    /// vertex in cd/m² (≥ 0), `triangles` as vertex indices. Cost
    /// O(m log m) time, O(n + m) memory.
    pub fn build(
        positions: &[Vec3],
        normals: &[Vec3],
        luminance: &[f32],
        triangles: &[[u32; 3]],
    ) -> Result<VertexTree, LodError> {
        Self::build_with(
            positions,
            normals,
            luminance,
            triangles,
            &BuildOptions::default(),
        )
    }

    /// [`Self::build`] with explicit size limits.
    pub fn build_with(
        positions: &[Vec3],
        normals: &[Vec3],
        luminance: &[f32],
        triangles: &[[u32; 3]],
        options: &BuildOptions,
    ) -> Result<VertexTree, LodError> {
        validate(positions, normals, luminance, triangles, options)?;
        let n = positions.len();
        let m = triangles.len();
        let node_cap = 2 * n - 1;

        let mut mg = Merger {
            parent: Vec::with_capacity(node_cap),
            children: Vec::with_capacity(node_cap),
            proxy: Vec::with_capacity(node_cap),
            quadric: Vec::with_capacity(node_cap),
        };
        mg.parent.resize(n, NONE);
        mg.children.resize(n, [NONE, NONE]);
        mg.proxy.extend_from_slice(positions);
        mg.quadric.resize(n, Quadric::default());

        // 1. Weld bit-identical positions (−0 = +0) into balanced subtrees.
        let key = |v: u32| {
            let p = positions[v as usize] + Vec3::ZERO;
            [p.x.to_bits(), p.y.to_bits(), p.z.to_bits()]
        };
        let mut cluster: Vec<u32> = (0..n as u32).collect();
        let mut welded_groups = 0u32;
        {
            let mut order: Vec<u32> = (0..n as u32).collect();
            order.sort_unstable_by_key(|&v| (key(v), v));
            let mut start = 0;
            while start < n {
                let k = key(order[start]);
                let mut end = start + 1;
                while end < n && key(order[end]) == k {
                    end += 1;
                }
                if end - start > 1 {
                    welded_groups += 1;
                    let pos = positions[order[start] as usize];
                    let mut level: Vec<u32> = order[start..end].to_vec();
                    while level.len() > 1 {
                        level = level
                            .chunks(2)
                            .map(|c| match *c {
                                [a, b] => mg.new_node(a, b, pos),
                                [a] => a,
                                _ => unreachable!("chunks(2)"),
                            })
                            .collect();
                    }
                    for &v in &order[start..end] {
                        cluster[v as usize] = level[0];
                    }
                }
                start = end;
            }
        }

        // 2. Face and boundary quadrics on the welded mesh.
        let pos64 = |v: u32| positions[v as usize].as_dvec3();
        let mut wc: Vec<[u32; 3]> = Vec::with_capacity(m);
        let mut alive: Vec<bool> = Vec::with_capacity(m);
        let mut face_normal: Vec<DVec3> = Vec::with_capacity(m);
        for tri in triangles {
            let c = tri.map(|v| cluster[v as usize]);
            let (nrm, area) = if distinct(tri) {
                face_normal_area(tri.map(pos64))
            } else {
                (DVec3::ZERO, 0.0)
            };
            if area > 0.0 {
                let d = -nrm.dot(pos64(tri[0]));
                let q = Quadric::plane(nrm, d, area);
                for &k in &c {
                    mg.quadric[k as usize].add(&q);
                }
            }
            wc.push(c);
            alive.push(distinct(&c));
            face_normal.push(nrm);
        }
        let mut edges: Vec<(u64, u32)> = Vec::with_capacity(3 * m);
        for (t, c) in wc.iter().enumerate() {
            if !alive[t] {
                continue;
            }
            for k in 0..3 {
                let (a, b) = (c[k], c[(k + 1) % 3]);
                let (lo, hi) = (a.min(b), a.max(b));
                edges.push(((u64::from(lo) << 32) | u64::from(hi), t as u32));
            }
        }
        edges.sort_unstable();
        // Clusters on the mesh's open border (an end of an edge of exactly
        // one live triangle): folding anything above them moves the
        // object's outline against what lies behind it.
        let mut border = vec![false; node_cap];
        let mut i = 0;
        while i < edges.len() {
            let e = edges[i].0;
            let mut j = i + 1;
            while j < edges.len() && edges[j].0 == e {
                j += 1;
            }
            let (a, b) = ((e >> 32) as u32, e as u32);
            if j - i == 1 {
                border[a as usize] = true;
                border[b as usize] = true;
                let t = edges[i].1 as usize;
                let nrm = face_normal[t];
                let (pa, pb) = (
                    mg.proxy[a as usize].as_dvec3(),
                    mg.proxy[b as usize].as_dvec3(),
                );
                let edge = pb - pa;
                let perp = edge.cross(nrm);
                let len = perp.length();
                if len > 0.0 && nrm != DVec3::ZERO {
                    let pn = perp / len;
                    let q =
                        Quadric::plane(pn, -pn.dot(pa), BOUNDARY_WEIGHT * edge.length_squared());
                    mg.quadric[a as usize].add(&q);
                    mg.quadric[b as usize].add(&q);
                }
            }
            i = j;
        }
        drop(face_normal);
        // One heap entry per cluster: its cheapest pair (ties to the smaller
        // partner). Every live pair is covered by the entry of at least one
        // of its ends with a cost no higher than its own, so popping the
        // cheapest entry is Garland–Heckbert's greedy order, with a heap of
        // O(n) instead of O(m) entries.
        let mut best: Vec<(f64, u32)> = vec![(f64::INFINITY, NONE); n.max(mg.parent.len())];
        let mut i = 0;
        while i < edges.len() {
            let e = edges[i].0;
            while i < edges.len() && edges[i].0 == e {
                i += 1;
            }
            let (a, b) = ((e >> 32) as u32, e as u32);
            let (_, cost) = mg.placement(a, b);
            for (x, y) in [(a, b), (b, a)] {
                let slot = &mut best[x as usize];
                if (cost, y) < *slot {
                    *slot = (cost, y);
                }
            }
        }
        drop(edges);
        let mut heap: BinaryHeap<Candidate> = best
            .iter()
            .enumerate()
            .filter(|(_, b)| b.1 != NONE)
            .map(|(x, &(cost, partner))| Candidate {
                cost,
                x: x as u32,
                partner,
            })
            .collect();
        drop(best);

        // 3. Incidence lists: slot 3t+k is corner k of triangle t, linked
        //    into the list of the cluster that corner currently belongs to.
        let mut inc = Incidence {
            next: vec![NONE; 3 * m],
            head: vec![NONE; node_cap],
            tail: vec![NONE; node_cap],
            stamp: vec![0; node_cap],
            walk: 0,
            wc,
            alive,
        };
        for t in 0..m {
            if !inc.alive[t] {
                continue;
            }
            for k in 0..3 {
                let x = inc.wc[t][k] as usize;
                let s = (3 * t + k) as u32;
                inc.next[s as usize] = inc.head[x];
                if inc.head[x] == NONE {
                    inc.tail[x] = s;
                }
                inc.head[x] = s;
            }
        }
        let mut neighbours: Vec<u32> = Vec::new();

        // 4. Edge collapses, cheapest first.
        while let Some(cand) = heap.pop() {
            let (x, p) = (cand.x, cand.partner);
            if mg.parent[x as usize] != NONE {
                continue; // x itself was merged since
            }
            let c = if mg.parent[p as usize] != NONE {
                // The partner was merged: find x's cheapest pair again.
                inc.walk(x, NONE, NONE, &mut neighbours);
                x
            } else {
                let (pos, _) = mg.placement(x, p);
                let c = mg.new_node(x, p, pos);
                inc.concat(c, x, p);
                inc.walk(c, x, p, &mut neighbours);
                c
            };
            let mut best = (f64::INFINITY, NONE);
            for &v in &neighbours {
                let (_, cost) = mg.placement(c, v);
                if (cost, v) < best {
                    best = (cost, v);
                }
            }
            if best.1 != NONE {
                heap.push(Candidate {
                    cost: best.0,
                    x: c,
                    partner: best.1,
                });
            }
        }
        drop((inc, heap));

        // 5. Whatever is left (one root per connected piece, isolated
        //    vertices included) is merged by recursive median splits along
        //    the longest axis of the proxies: a balanced, spatially coherent
        //    top of the tree.
        let mut roots: Vec<u32> = (0..mg.parent.len() as u32)
            .filter(|&v| mg.parent[v as usize] == NONE)
            .collect();
        let forest_roots = roots.len() as u32;
        let root = merge_forest(&mut mg, &mut roots);
        debug_assert_eq!(mg.parent.len(), node_cap);

        finish(
            mg,
            root,
            positions,
            normals,
            luminance,
            triangles,
            &border,
            welded_groups,
            forest_roots,
        )
    }
}

fn merge_forest(mg: &mut Merger, roots: &mut [u32]) -> u32 {
    if roots.len() == 1 {
        return roots[0];
    }
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for &r in roots.iter() {
        lo = lo.min(mg.proxy[r as usize]);
        hi = hi.max(mg.proxy[r as usize]);
    }
    let ext = hi - lo;
    let axis = if ext.x >= ext.y && ext.x >= ext.z {
        0
    } else if ext.y >= ext.z {
        1
    } else {
        2
    };
    let mid = roots.len() / 2;
    roots.select_nth_unstable_by(mid, |&a, &b| {
        mg.proxy[a as usize][axis]
            .total_cmp(&mg.proxy[b as usize][axis])
            .then(a.cmp(&b))
    });
    let (left, right) = roots.split_at_mut(mid);
    let l = merge_forest(mg, left);
    let r = merge_forest(mg, right);
    let (pos, _) = mg.placement(l, r);
    mg.new_node(l, r, pos)
}

#[allow(clippy::too_many_arguments)]
fn finish(
    mg: Merger,
    root: u32,
    positions: &[Vec3],
    normals: &[Vec3],
    luminance: &[f32],
    triangles: &[[u32; 3]],
    border: &[bool],
    welded_groups: u32,
    forest_roots: u32,
) -> Result<VertexTree, LodError> {
    let Merger {
        parent: old_parent,
        children: old_children,
        proxy: old_proxy,
        quadric,
    } = mg;
    drop((quadric, old_parent));
    let n = positions.len();
    let count = old_children.len();

    // Renumber in depth-first pre-order (root 0, first child before the
    // second): selection walks the tree in this order, so its reads are
    // sequential, and every subtree is a contiguous id range.
    let mut new_id = vec![NONE; count];
    let mut order: Vec<u32> = Vec::with_capacity(count);
    {
        let mut stack = vec![root];
        while let Some(x) = stack.pop() {
            new_id[x as usize] = order.len() as u32;
            order.push(x);
            if x as usize >= n {
                let [a, b] = old_children[x as usize];
                stack.push(b);
                stack.push(a);
            }
        }
    }
    let mut parent = vec![NONE; count];
    let mut children = vec![[NONE, NONE]; count];
    let mut proxy = Vec::with_capacity(count);
    let mut vertex_of = vec![NONE; count];
    let mut outline = vec![false; count];
    for (v, &old) in order.iter().enumerate() {
        proxy.push(old_proxy[old as usize]);
        outline[v] = border[old as usize];
        if (old as usize) < n {
            vertex_of[v] = old;
        } else {
            let kids = old_children[old as usize].map(|c| new_id[c as usize]);
            children[v] = kids;
            for k in kids {
                parent[k as usize] = v as u32;
            }
        }
    }
    drop((old_children, old_proxy, order));
    // Nodes were created in merge order (welds, quadric collapses, spatial
    // merges), so an internal node's old id less n is its rank.
    let merge_order: Vec<u32> = new_id[n..].to_vec();
    let leaf_of: Vec<u32> = new_id[..n].to_vec();
    drop(new_id);
    let root = 0u32;
    let is_leaf = |v: usize| children[v][0] == NONE;

    // Depth and DFS leaf ranges, top-down (parents have smaller ids).
    let mut depth = vec![0u32; count];
    let mut leaves = vec![1u32; count];
    for v in (0..count).rev() {
        if !is_leaf(v) {
            let [a, b] = children[v];
            leaves[v] = leaves[a as usize] + leaves[b as usize];
        }
    }
    let mut range = vec![[0u32; 2]; count];
    range[root as usize] = [0, leaves[root as usize]];
    let mut max_depth = 0;
    for v in 0..count {
        if is_leaf(v) {
            continue;
        }
        let [a, b] = children[v];
        let lo = range[v][0];
        let mid = lo + leaves[a as usize];
        range[a as usize] = [lo, mid];
        range[b as usize] = [mid, range[v][1]];
        depth[a as usize] = depth[v] + 1;
        depth[b as usize] = depth[v] + 1;
        max_depth = max_depth.max(depth[v] + 1);
    }
    drop(leaves);
    let leaf_pos: Vec<u32> = leaf_of.iter().map(|&l| range[l as usize][0]).collect();

    // Leaf spheres: every corner of every triangle touching the leaf. Centre
    // = centre of that 1-ring's bounding box, radius = farthest corner.
    let pos64 = |v: u32| positions[v as usize].as_dvec3();
    let mut lo: Vec<DVec3> = positions.iter().map(|p| p.as_dvec3()).collect();
    let mut hi = lo.clone();
    for tri in triangles.iter().filter(|t| distinct(t)) {
        for &v in tri {
            for &w in tri {
                let p = pos64(w);
                lo[v as usize] = lo[v as usize].min(p);
                hi[v as usize] = hi[v as usize].max(p);
            }
        }
    }
    let mut ds: Vec<DSphere> = (0..n)
        .map(|v| {
            let mut s = DSphere {
                c: (lo[v] + hi[v]) * 0.5,
                r: 0.0,
            };
            s.include(pos64(v as u32));
            s
        })
        .collect();
    drop((lo, hi));
    let mut vertex_mask = vec![NormalMask::default(); n];
    for tri in triangles.iter().filter(|t| distinct(t)) {
        let (nrm, area) = face_normal_area(tri.map(pos64));
        for &v in tri {
            for &w in tri {
                ds[v as usize].include(pos64(w));
            }
            if area > 0.0 {
                vertex_mask[v as usize].insert(nrm);
            }
        }
    }

    // Per-node data, leaves from the vertices, then bottom-up (children
    // have larger ids).
    let placeholder = crate::Sphere {
        center: Vec3::ZERO,
        radius: 0.0,
    };
    let mut sphere = vec![placeholder; count];
    let mut mask = vec![NormalMask::default(); count];
    let mut luminance_min = vec![0f32; count];
    let mut luminance_max = vec![0f32; count];
    let mut lum_sum = vec![0f64; count];
    let mut normal_sum = vec![Vec3::ZERO; count];
    let mut proxy_normal = vec![Vec3::ZERO; count];
    for v in 0..n {
        let l = leaf_of[v] as usize;
        sphere[l] = ds[v].to_f32();
        mask[l] = vertex_mask[v];
        luminance_min[l] = luminance[v];
        luminance_max[l] = luminance[v];
        lum_sum[l] = f64::from(luminance[v]);
        normal_sum[l] = normals[v];
        proxy_normal[l] = normals[v];
    }
    drop((ds, vertex_mask));
    for v in (0..count).rev() {
        if is_leaf(v) {
            continue;
        }
        let [a, b] = children[v].map(|c| c as usize);
        let mut s = DSphere::enclose(DSphere::from_f32(&sphere[a]), DSphere::from_f32(&sphere[b]));
        s.include(proxy[v].as_dvec3());
        sphere[v] = s.to_f32();
        let mut mk = mask[a];
        mk.union_with(&mask[b]);
        mask[v] = mk;
        outline[v] |= outline[a] || outline[b];
        luminance_min[v] = luminance_min[a].min(luminance_min[b]);
        luminance_max[v] = luminance_max[a].max(luminance_max[b]);
        lum_sum[v] = lum_sum[a] + lum_sum[b];
        let ns = normal_sum[a] + normal_sum[b];
        normal_sum[v] = ns;
        let len = ns.length();
        proxy_normal[v] = if len > 1e-20 {
            ns / len
        } else {
            proxy_normal[a]
        };
    }
    drop(normal_sum);
    let cone: Vec<NormalCone> = mask.iter().map(NormalCone::of).collect();
    let proxy_luminance: Vec<f32> = lum_sum
        .iter()
        .zip(&range)
        .map(|(s, r)| (s / f64::from(r[1] - r[0])) as f32)
        .collect();
    drop(lum_sum);
    let fold_contrast: Vec<f32> = luminance_min
        .iter()
        .zip(&luminance_max)
        .map(|(&lo, &hi)| michelson(lo, hi))
        .collect();

    // Subtris: the node where a triangle degenerates is the deepest pairwise
    // lowest common ancestor of its corners. Walking up from corner a to the
    // first ancestor holding b or c gives the deeper of LCA(a,b), LCA(a,c);
    // likewise from b; the deeper of the two is the deepest of all three.
    let inside = |node: u32, p: u32| {
        let [lo, hi] = range[node as usize];
        lo <= p && p < hi
    };
    let mut vanishes_at = vec![NONE; triangles.len()];
    let mut corner_pos = Vec::with_capacity(triangles.len());
    let mut drawable = 0u32;
    for (t, tri) in triangles.iter().enumerate() {
        let p = tri.map(|v| leaf_pos[v as usize]);
        corner_pos.push(p);
        if !distinct(tri) {
            continue;
        }
        drawable += 1;
        let up = |start: u32, o1: u32, o2: u32| {
            let mut x = parent[leaf_of[start as usize] as usize];
            while !(inside(x, o1) || inside(x, o2)) {
                x = parent[x as usize];
            }
            x
        };
        let x = up(tri[0], p[1], p[2]);
        let y = up(tri[1], p[0], p[2]);
        vanishes_at[t] = if depth[x as usize] >= depth[y as usize] {
            x
        } else {
            y
        };
    }
    let mut subtri_start = vec![0u32; count + 1];
    for &v in vanishes_at.iter().filter(|&&v| v != NONE) {
        subtri_start[v as usize + 1] += 1;
    }
    for i in 0..count {
        subtri_start[i + 1] += subtri_start[i];
    }
    let mut fill = subtri_start.clone();
    let mut subtris = vec![0u32; drawable as usize];
    for (t, &v) in vanishes_at.iter().enumerate() {
        if v != NONE {
            subtris[fill[v as usize] as usize] = t as u32;
            fill[v as usize] += 1;
        }
    }

    Ok(VertexTree {
        leaf_count: n as u32,
        root,
        parent,
        children,
        depth,
        max_depth,
        range,
        leaf_pos,
        leaf_of,
        vertex_of,
        proxy,
        proxy_normal,
        proxy_luminance,
        sphere,
        luminance_min,
        luminance_max,
        fold_contrast,
        mask,
        cone,
        outline,
        subtri_start,
        subtris,
        triangles: triangles.to_vec(),
        vanishes_at,
        corner_pos,
        drawable_triangles: drawable,
        welded_groups,
        forest_roots,
        merge_order,
    })
}

/// Michelson contrast `(max − min)/(max + min)` (Luebke & Hallen §2), 0
/// when both are 0.
pub(crate) fn michelson(lo: f32, hi: f32) -> f32 {
    let (lo, hi) = (f64::from(lo), f64::from(hi));
    if hi + lo > 0.0 {
        ((hi - lo) / (hi + lo)) as f32
    } else {
        0.0
    }
}
