//! The vertex tree (Luebke & Hallen 2001 §5.1, Luebke's VDS, their refs. 18 and 20):
//! flat per-node arrays in depth-first pre-order. See the crate docs for what each
//! field means and where it comes from.

use glam::Vec3;

use crate::normal_mask::{NormalCone, NormalMask};
use crate::sphere::Sphere;

/// Index of a node, in depth-first pre-order: the root is 0, a node's first
/// child is the next id, and the subtree of `n` is the contiguous range
/// `n .. n + 2·leaves_below(n) − 1`. So a parent's id is always smaller
/// than its children's. [`VertexTree::leaf`] maps an input vertex to its
/// leaf.
pub type NodeId = u32;

/// "No node" in the flat arrays.
pub(crate) const NONE: u32 = u32::MAX;

/// A hierarchy of vertex merges over a triangle mesh. Immutable once built;
/// any number of [`crate::Cut`]s can share it. Accessors taking a
/// [`NodeId`] (or a vertex or triangle index) panic when it is out of range,
/// like slice indexing; `Cut::fold`/`unfold` return
/// [`crate::LodError::NoSuchNode`] instead.
#[derive(Debug, Clone)]
pub struct VertexTree {
    pub(crate) leaf_count: u32,
    pub(crate) root: NodeId,
    pub(crate) parent: Vec<NodeId>,
    pub(crate) children: Vec<[NodeId; 2]>,
    pub(crate) depth: Vec<u32>,
    pub(crate) max_depth: u32,
    /// Leaves below a node occupy DFS positions `range[n][0]..range[n][1]`.
    pub(crate) range: Vec<[u32; 2]>,
    /// DFS position (among the leaves) of each input vertex's leaf.
    pub(crate) leaf_pos: Vec<u32>,
    /// Vertex → its leaf node; node → its vertex (`NONE` for internal nodes).
    pub(crate) leaf_of: Vec<NodeId>,
    pub(crate) vertex_of: Vec<u32>,
    pub(crate) proxy: Vec<Vec3>,
    pub(crate) proxy_normal: Vec<Vec3>,
    pub(crate) proxy_luminance: Vec<f32>,
    pub(crate) sphere: Vec<Sphere>,
    pub(crate) luminance_min: Vec<f32>,
    pub(crate) luminance_max: Vec<f32>,
    pub(crate) fold_contrast: Vec<f32>,
    pub(crate) mask: Vec<NormalMask>,
    pub(crate) cone: Vec<NormalCone>,
    /// The node supports a vertex of the mesh's open border (see
    /// [`VertexTree::on_outline`]); OR of the children.
    pub(crate) outline: Vec<bool>,
    /// CSR: the subtris of node n are `subtris[subtri_start[n]..subtri_start[n+1]]`.
    pub(crate) subtri_start: Vec<u32>,
    pub(crate) subtris: Vec<u32>,
    /// Input triangles (vertex indices), and per triangle the node whose
    /// fold makes it vanish (`NONE` for a triangle with a repeated index,
    /// which is dropped).
    pub(crate) triangles: Vec<[u32; 3]>,
    pub(crate) vanishes_at: Vec<NodeId>,
    /// Corners as DFS positions (what a cut's representative array is
    /// indexed by).
    pub(crate) corner_pos: Vec<[u32; 3]>,
    pub(crate) drawable_triangles: u32,
    pub(crate) welded_groups: u32,
    pub(crate) forest_roots: u32,
    /// Internal nodes in the order they were merged (welds, then quadric
    /// edge collapses cheapest first, then spatial merges).
    pub(crate) merge_order: Vec<NodeId>,
}

impl VertexTree {
    /// The internal nodes in the order the build merged them: welds, then
    /// Garland–Heckbert edge collapses cheapest first, then the spatial
    /// merges of what was left. Every node comes after its children, so
    /// folding a prefix of this list, in order, is always possible and
    /// gives the mesh greedy quadric simplification reaches after that
    /// many collapses ([`crate::Cut::fold_to_triangles`]).
    pub fn merge_order(&self) -> &[NodeId] {
        &self.merge_order
    }

    /// Number of nodes: `2·leaf_count() − 1` (every merge is binary and the
    /// tree has one root).
    pub fn node_count(&self) -> usize {
        self.parent.len()
    }

    /// Number of leaves = number of input vertices.
    pub fn leaf_count(&self) -> usize {
        self.leaf_count as usize
    }

    /// The single root (the whole mesh merged into one vertex).
    pub fn root(&self) -> NodeId {
        self.root
    }

    /// Whether `node` is a leaf (an input vertex; it has no children).
    pub fn is_leaf(&self, node: NodeId) -> bool {
        self.children[node as usize][0] == NONE
    }

    /// The leaf of input vertex `vertex`.
    pub fn leaf(&self, vertex: u32) -> NodeId {
        self.leaf_of[vertex as usize]
    }

    /// The input vertex of a leaf; `None` for an internal node.
    pub fn vertex(&self, node: NodeId) -> Option<u32> {
        let v = self.vertex_of[node as usize];
        (v != NONE).then_some(v)
    }

    /// The node `node` was merged into; `None` for the root.
    pub fn parent(&self, node: NodeId) -> Option<NodeId> {
        let p = self.parent[node as usize];
        (p != NONE).then_some(p)
    }

    /// The two children of an internal node; `None` for a leaf.
    pub fn children(&self, node: NodeId) -> Option<[NodeId; 2]> {
        (!self.is_leaf(node)).then(|| self.children[node as usize])
    }

    /// Edges from the root (root = 0).
    pub fn depth(&self, node: NodeId) -> u32 {
        self.depth[node as usize]
    }

    /// The largest depth of any node (edges from the root).
    pub fn max_depth(&self) -> u32 {
        self.max_depth
    }

    /// Number of leaves below (or at) `node`.
    pub fn leaves_below(&self, node: NodeId) -> usize {
        let [lo, hi] = self.range[node as usize];
        (hi - lo) as usize
    }

    /// Does `node` support input vertex `vertex` (is its leaf at or below
    /// `node`)? O(1).
    pub fn supports(&self, node: NodeId, vertex: u32) -> bool {
        let [lo, hi] = self.range[node as usize];
        let p = self.leaf_pos[vertex as usize];
        lo <= p && p < hi
    }

    /// The proxy vertex: the input vertex for a leaf, the quadric-optimal
    /// merge position otherwise.
    pub fn proxy_position(&self, node: NodeId) -> Vec3 {
        self.proxy[node as usize]
    }

    /// The input normal for a leaf; the normalised sum of the leaf normals
    /// below otherwise.
    pub fn proxy_normal(&self, node: NodeId) -> Vec3 {
        self.proxy_normal[node as usize]
    }

    /// Mean luminance (cd/m²) of the leaves below.
    pub fn proxy_luminance(&self, node: NodeId) -> f32 {
        self.proxy_luminance[node as usize]
    }

    /// A sphere holding every original triangle that touches a leaf below
    /// `node` (its region of support) and the proxy; it also holds the
    /// children's spheres.
    pub fn bounding_sphere(&self, node: NodeId) -> Sphere {
        self.sphere[node as usize]
    }

    /// (min, max) luminance of the leaves below.
    pub fn luminance_range(&self, node: NodeId) -> (f32, f32) {
        (
            self.luminance_min[node as usize],
            self.luminance_max[node as usize],
        )
    }

    /// Interior fold contrast: Michelson `(max − min)/(max + min)` of
    /// [`Self::luminance_range`], 0 when both are 0.
    pub fn fold_contrast(&self, node: NodeId) -> f32 {
        self.fold_contrast[node as usize]
    }

    /// Normal-cube cells of the supported triangles' normals.
    pub fn normal_mask(&self, node: NodeId) -> &NormalMask {
        &self.mask[node as usize]
    }

    /// Does `node` support a vertex on the mesh's open border, an end of an
    /// edge that only one triangle uses (after welding)? Such a node's fold
    /// moves the border, which is the object's outline against whatever is
    /// behind it from every view, so selection treats it as a silhouette
    /// node whatever its normals (a flat object facing the viewer has no
    /// back-facing normal, yet folding its border removes it). Monotone: a
    /// parent is on the outline when a child is.
    pub fn on_outline(&self, node: NodeId) -> bool {
        self.outline[node as usize]
    }

    /// Triangles that vanish when `node` folds: those whose deepest pairwise
    /// lowest common ancestor of corners is `node` (VDS "subtris").
    pub fn subtris(&self, node: NodeId) -> &[u32] {
        let s = self.subtri_start[node as usize] as usize;
        let e = self.subtri_start[node as usize + 1] as usize;
        &self.subtris[s..e]
    }

    /// The input triangles, as given.
    pub fn triangles(&self) -> &[[u32; 3]] {
        &self.triangles
    }

    /// The node whose fold removes triangle `t`; `None` for a triangle with
    /// a repeated vertex index (dropped at build, never drawn).
    pub fn vanishing_node(&self, t: u32) -> Option<NodeId> {
        let n = self.vanishes_at[t as usize];
        (n != NONE).then_some(n)
    }

    /// Triangles with three distinct indices: what a fully unfolded cut draws.
    pub fn drawable_triangle_count(&self) -> usize {
        self.drawable_triangles as usize
    }

    /// Groups of ≥ 2 input vertices at bit-identical positions, merged first.
    pub fn welded_groups(&self) -> usize {
        self.welded_groups as usize
    }

    /// Roots the edge collapses left: at least one per connected piece
    /// (isolated vertices count), more where a piece's last triangles
    /// vanished before it was one vertex. The spatial merge joined them
    /// under the single root.
    pub fn forest_roots(&self) -> usize {
        self.forest_roots as usize
    }

    pub(crate) fn check_node(&self, node: NodeId) -> Result<(), crate::LodError> {
        if (node as usize) < self.node_count() {
            Ok(())
        } else {
            Err(crate::LodError::NoSuchNode {
                node,
                node_count: self.node_count(),
            })
        }
    }
}
