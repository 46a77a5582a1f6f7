//! The active cut through a vertex tree and its incrementally maintained
//! triangle list (VDS's "active nodes" and "active triangles", Luebke &
//! Hallen 2001 §5.1).
//!
//! Every node is in one of three states. **Active** nodes form the cut:
//! each leaf has exactly one active ancestor-or-self, whose proxy stands in
//! for it. **Expanded** nodes lie above the cut (unfolded), **collapsed**
//! ones below it (inside a folded node). A triangle is drawn iff the node
//! where it degenerates ([`VertexTree::vanishing_node`]) is expanded: then
//! its three corners have three different active representatives.

use glam::Vec3;

use crate::tree::{NodeId, VertexTree, NONE};
use crate::LodError;

pub(crate) const EXPANDED: u8 = 0;
pub(crate) const ACTIVE: u8 = 1;
pub(crate) const COLLAPSED: u8 = 2;

/// The state of one node in a [`Cut`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NodeState {
    /// Above the cut: unfolded.
    Expanded,
    /// On the cut: its proxy is drawn for all the leaves below it.
    Active,
    /// Below the cut: inside a folded ancestor.
    Collapsed,
}

/// A cut through a [`VertexTree`] with the triangles it draws.
///
/// Costs: [`Cut::fold`] and [`Cut::unfold`] are O(subtris + leaves below
/// the node) (the leaves' representative is a contiguous range, one memset);
/// [`Cut::fold_subtree`] is O(expanded nodes below + their subtris + leaves
/// below). Selection (see [`crate::select`]) defers the representative
/// update to one pass over the nodes that became active, so a frame costs
/// O(nodes visited + triangles added or removed + leaves under changed
/// nodes).
#[derive(Debug, Clone)]
pub struct Cut<'t> {
    pub(crate) tree: &'t VertexTree,
    pub(crate) state: Vec<u8>,
    /// Per DFS leaf position: the active node holding that leaf.
    pub(crate) rep: Vec<NodeId>,
    pub(crate) active: Vec<u32>,
    /// Per triangle: its index in `active`, or `NONE`.
    pub(crate) slot: Vec<u32>,
    pub(crate) active_nodes: usize,
    // Selection scratch, kept to avoid per-frame allocation.
    pub(crate) stack: Vec<NodeId>,
    pub(crate) stack2: Vec<NodeId>,
    pub(crate) fresh: Vec<NodeId>,
    pub(crate) mark: Vec<u32>,
    pub(crate) stamp: u32,
}

impl<'t> Cut<'t> {
    /// The fully unfolded cut: every leaf active, the original mesh exactly
    /// (every triangle with three distinct indices, at the input positions).
    pub fn new(tree: &'t VertexTree) -> Self {
        let count = tree.node_count();
        let n = tree.leaf_count();
        let mut state = vec![EXPANDED; count];
        let mut rep = vec![0; n];
        for (vertex, &p) in tree.leaf_pos.iter().enumerate() {
            let leaf = tree.leaf_of[vertex];
            rep[p as usize] = leaf;
            state[leaf as usize] = ACTIVE;
        }
        let mut active = Vec::with_capacity(tree.drawable_triangle_count());
        let mut slot = vec![NONE; tree.triangles.len()];
        for (t, &v) in tree.vanishes_at.iter().enumerate() {
            if v != NONE {
                slot[t] = active.len() as u32;
                active.push(t as u32);
            }
        }
        Self {
            tree,
            state,
            rep,
            active,
            slot,
            active_nodes: n,
            stack: Vec::new(),
            stack2: Vec::new(),
            fresh: Vec::new(),
            mark: Vec::new(),
            stamp: 0,
        }
    }

    /// The tree this cut goes through.
    pub fn tree(&self) -> &'t VertexTree {
        self.tree
    }

    /// Whether `node` is above, on or below the cut.
    pub fn state(&self, node: NodeId) -> NodeState {
        match self.state[node as usize] {
            EXPANDED => NodeState::Expanded,
            ACTIVE => NodeState::Active,
            _ => NodeState::Collapsed,
        }
    }

    /// Whether `node` is on the cut (its proxy is drawn).
    pub fn is_active(&self, node: NodeId) -> bool {
        self.state[node as usize] == ACTIVE
    }

    /// Number of nodes on the cut.
    pub fn active_node_count(&self) -> usize {
        self.active_nodes
    }

    /// The nodes on the cut, in id order. O(node count).
    pub fn active_nodes(&self) -> Vec<NodeId> {
        (0..self.state.len() as u32)
            .filter(|&v| self.state[v as usize] == ACTIVE)
            .collect()
    }

    /// Number of triangles the cut draws.
    pub fn active_triangle_count(&self) -> usize {
        self.active.len()
    }

    /// Ids (indices into [`VertexTree::triangles`]) of the drawn triangles,
    /// in an unspecified order that changes as the cut changes.
    pub fn active_triangle_ids(&self) -> &[u32] {
        &self.active
    }

    /// The active node standing in for input vertex `vertex`.
    pub fn representative(&self, vertex: u32) -> NodeId {
        self.rep[self.tree.leaf_pos[vertex as usize] as usize]
    }

    /// The corners of drawn triangle `t` as active nodes (same winding as
    /// the input triangle).
    pub fn corner_nodes(&self, t: u32) -> [NodeId; 3] {
        self.tree.corner_pos[t as usize].map(|p| self.rep[p as usize])
    }

    /// The drawn triangles as proxy positions, in
    /// [`Self::active_triangle_ids`] order.
    pub fn triangles(&self) -> Vec<[Vec3; 3]> {
        let mut out = Vec::with_capacity(self.active.len());
        self.triangles_into(&mut out);
        out
    }

    /// [`Self::triangles`] into a reused buffer (cleared first).
    pub fn triangles_into(&self, out: &mut Vec<[Vec3; 3]>) {
        out.clear();
        let proxy = &self.tree.proxy;
        out.extend(
            self.active
                .iter()
                .map(|&t| self.corner_nodes(t).map(|v| proxy[v as usize])),
        );
    }

    /// Per-vertex (proxy) normals of the drawn triangles, same order as
    /// [`Self::triangles`].
    pub fn normals_into(&self, out: &mut Vec<[Vec3; 3]>) {
        out.clear();
        let nrm = &self.tree.proxy_normal;
        out.extend(
            self.active
                .iter()
                .map(|&t| self.corner_nodes(t).map(|v| nrm[v as usize])),
        );
    }

    /// Folds `node`, whose two children must both be active: VDS's
    /// leaves-upward fold. The children leave the cut, `node` joins it, and
    /// its subtris vanish. Use [`Self::fold_subtree`] to fold a node whose
    /// subtree is partly unfolded.
    pub fn fold(&mut self, node: NodeId) -> Result<(), LodError> {
        self.tree.check_node(node)?;
        let err = |reason| LodError::InvalidOperation {
            op: "fold",
            node,
            reason,
        };
        let Some([a, b]) = self.tree.children(node) else {
            return Err(err("it is a leaf"));
        };
        match self.state[node as usize] {
            ACTIVE => return Err(err("it is already folded")),
            COLLAPSED => return Err(err("an ancestor is folded")),
            _ => {}
        }
        if self.state[a as usize] != ACTIVE || self.state[b as usize] != ACTIVE {
            return Err(err(
                "a child is unfolded; fold the children first or use fold_subtree",
            ));
        }
        self.remove_subtris(node);
        self.state[a as usize] = COLLAPSED;
        self.state[b as usize] = COLLAPSED;
        self.state[node as usize] = ACTIVE;
        self.active_nodes -= 1;
        self.fill_rep(node);
        Ok(())
    }

    /// Folds `node` and everything below it; returns the number of folds
    /// (expanded nodes that collapsed). 0 if `node` is already active.
    pub fn fold_subtree(&mut self, node: NodeId) -> Result<usize, LodError> {
        self.tree.check_node(node)?;
        match self.state[node as usize] {
            ACTIVE => Ok(0),
            COLLAPSED => Err(LodError::InvalidOperation {
                op: "fold_subtree",
                node,
                reason: "an ancestor is folded",
            }),
            _ => {
                let folds = self.collapse(node);
                self.fill_rep(node);
                Ok(folds)
            }
        }
    }

    /// Unfolds active internal `node`: its children join the cut and its
    /// subtris reappear.
    pub fn unfold(&mut self, node: NodeId) -> Result<(), LodError> {
        self.tree.check_node(node)?;
        let err = |reason| LodError::InvalidOperation {
            op: "unfold",
            node,
            reason,
        };
        let Some([a, b]) = self.tree.children(node) else {
            return Err(err("it is a leaf"));
        };
        match self.state[node as usize] {
            EXPANDED => return Err(err("it is already unfolded")),
            COLLAPSED => return Err(err("an ancestor is folded; unfold that first")),
            _ => {}
        }
        self.expand(node);
        self.fill_rep(a);
        self.fill_rep(b);
        Ok(())
    }

    /// A level of detail by quadric simplification (Garland & Heckbert, as
    /// Lee 2009 §7.3 builds its levels): from the original mesh, folds the
    /// tree's merges in [`VertexTree::merge_order`] until at most
    /// `triangles` remain (0 folds everything that can be). Returns the
    /// folds made. The cut is reset to the original mesh first.
    pub fn fold_to_triangles(&mut self, triangles: usize) -> usize {
        self.unfold_all();
        let mut folds = 0;
        for &node in self.tree.merge_order() {
            if self.active_triangle_count() <= triangles {
                break;
            }
            // Children come first in the order, so both are active.
            if self.fold(node).is_ok() {
                folds += 1;
            }
        }
        folds
    }

    /// Back to the original mesh.
    pub fn unfold_all(&mut self) {
        *self = Cut::new(self.tree);
    }

    /// Everything folded into the root (no triangles).
    pub fn fold_all(&mut self) {
        let root = self.tree.root;
        if self.state[root as usize] == EXPANDED {
            self.collapse(root);
            self.fill_rep(root);
        }
    }

    // --- internals, shared with selection ---

    /// Active `node` → expanded; children active; subtris added. Does not
    /// touch `rep`.
    pub(crate) fn expand(&mut self, node: NodeId) {
        let [a, b] = self.tree.children[node as usize];
        self.state[node as usize] = EXPANDED;
        self.state[a as usize] = ACTIVE;
        self.state[b as usize] = ACTIVE;
        self.active_nodes += 1;
        let tree = self.tree;
        for &t in tree.subtris(node) {
            self.slot[t as usize] = self.active.len() as u32;
            self.active.push(t);
        }
    }

    /// Expanded `node` → active, everything expanded below → collapsed
    /// (subtris removed), the cut below → collapsed. Returns the folds.
    /// Does not touch `rep`.
    pub(crate) fn collapse(&mut self, node: NodeId) -> usize {
        let mut folds = 0;
        let mut stack = std::mem::take(&mut self.stack2);
        stack.clear();
        stack.push(node);
        while let Some(x) = stack.pop() {
            match self.state[x as usize] {
                EXPANDED => {
                    self.remove_subtris(x);
                    folds += 1;
                    self.state[x as usize] = COLLAPSED;
                    stack.extend_from_slice(&self.tree.children[x as usize]);
                }
                ACTIVE => {
                    self.state[x as usize] = COLLAPSED;
                    self.active_nodes -= 1;
                }
                _ => debug_assert!(false, "a child of an expanded node is collapsed"),
            }
        }
        self.stack2 = stack;
        self.state[node as usize] = ACTIVE;
        self.active_nodes += 1;
        folds
    }

    fn remove_subtris(&mut self, node: NodeId) {
        let tree = self.tree;
        for &t in tree.subtris(node) {
            let i = self.slot[t as usize];
            debug_assert_ne!(i, NONE, "subtri {t} of expanded node {node} is not drawn");
            self.active.swap_remove(i as usize);
            if let Some(&moved) = self.active.get(i as usize) {
                self.slot[moved as usize] = i;
            }
            self.slot[t as usize] = NONE;
        }
    }

    /// Points every leaf below `node` at it.
    pub(crate) fn fill_rep(&mut self, node: NodeId) {
        let [lo, hi] = self.tree.range[node as usize];
        self.rep[lo as usize..hi as usize].fill(node);
    }
}
