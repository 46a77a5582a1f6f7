//! Mesh level of detail for gaze-contingent rendering: simplifies a
//! triangle mesh into a tree of vertex merges and chooses, for each view,
//! which of its levels to draw where, by a perceptual model.
//!
//! Pure geometry, no GPU. A triangle mesh becomes a **vertex tree** of
//! vertex merges ([`VertexTree`]); a **cut** through it ([`Cut`]) is the mesh
//! actually drawn, kept up to date incrementally as nodes fold and unfold;
//! **selection** ([`Cut::select`]) chooses the cut for a view with one of
//! three models:
//!
//! - Luebke & Hallen 2001 (`shared/seeds/luebke-hallen-2001-…`, "L&H")
//!   §5.2 *imperceptible* simplification: fold a node only if the
//!   worst-case grating its fold can cause is below threshold
//!   ([`Mode::Imperceptible`]);
//! - L&H §5.3 *best effort*: a triangle budget, most perceptible fold
//!   undone first ([`Mode::Budget`]);
//! - Murphy & Duchowski 2001 ("M&D") §5.4 and Table 1: resolution level by
//!   eccentricity ([`Mode::MurphyDuchowski`]).
//!
//! Units: world millimetres, degrees, cycles per degree (cpd), luminance
//! in cd/m², Michelson contrast in [0, 1].
//!
//! ```
//! use glam::Vec3;
//! use foveation::{perceptibility::ThresholdTable, GeislerPerry};
//! use lod::{Cut, Mode, VertexTree, View};
//!
//! // One quad, two triangles.
//! let p = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0), Vec3::Y].map(|v| v * 10.0);
//! let tree = VertexTree::build(&p, &[Vec3::Z; 4], &[40.0, 42.0, 41.0, 40.5], &[[0, 1, 2], [0, 2, 3]])?;
//! let mut cut = Cut::new(&tree); // the original mesh
//! let table = ThresholdTable::from_model(&GeislerPerry::default());
//! let view = View {
//!     eye_mm: Vec3::new(5.0, 5.0, 5000.0),
//!     gaze_point_mm: None,
//!     thresholds: &table,
//!     scene_contrast: 0.8,
//! };
//! let report = cut.select(&view, &Mode::Imperceptible)?;
//! assert_eq!(report.triangles, cut.active_triangle_count());
//! let _triangles: Vec<[Vec3; 3]> = cut.triangles();
//! # Ok::<(), lod::LodError>(())
//! ```
//!
//! ## The vertex tree (L&H §5.1–§5.2; Luebke's VDS, L&H refs. 18 and 20)
//!
//! Leaves are the input vertices ([`VertexTree::leaf`]); every internal node
//! merges exactly two children, and there is a single root, so a tree over n
//! vertices has 2n − 1 nodes. Storage is flat per-node arrays (no per-node
//! allocation); node ids are in depth-first pre-order (root 0), so a
//! subtree is a contiguous id range and the selection walk reads memory
//! front to back. Building is O(m log m); about 0.2 s for 70 k triangles
//! in release on the development machine.
//!
//! Merges are formed in this order:
//!
//! 1. **Welding.** Vertices at bit-identical positions (−0 = +0) are merged
//!    first, in balanced groups, proxy = that position (quadric error 0).
//!    This handles duplicated vertices (UV/normal seams, unwelded STL
//!    soups). Near-but-not-identical positions are not welded.
//! 2. **Edge collapses** ordered by Garland–Heckbert quadric error (GH97,
//!    L&H ref. 11): each vertex starts with the sum of the planes of
//!    its triangles, weighted by area; boundary edges (one triangle) add a
//!    plane through the edge perpendicular to the face, weight 10·|e|², so
//!    open borders hold their shape. Each collapse merges the quadrics; the
//!    cheapest pair goes first (a heap holding each cluster's cheapest pair,
//!    which is the same greedy order; ties by id, so builds are
//!    deterministic). Non-manifold edges need no special case.
//! 3. **Spatial merge of what is left.** When no triangle connects the
//!    remaining clusters (disconnected pieces, isolated vertices, or a
//!    piece whose last triangles vanished), they are merged by recursive
//!    median splits along the longest axis of their proxies: a balanced
//!    top of the tree. *Decision:* always one root, never a forest.
//!
//! **Proxy** (the merged vertex): the quadric optimum (solving A·x = −b),
//! unless A is singular or ill-conditioned (|det A| ≤ 10⁻⁹·(tr A/3)³, flat
//! or linear regions, isolated points) or the optimum lies farther than
//! twice the pair's distance from its midpoint; then the quadric's minimum
//! on the segment between the two proxies (the midpoint when the quadric is
//! flat along it). Proxy normal: normalised sum of the leaf normals below;
//! proxy luminance: their mean.
//!
//! **Per node** (each monotone up the tree by construction):
//!
//! - *Bounding sphere* of the region of support: all original triangles
//!   touching any leaf below (L&H §5.1 "supports"). A leaf's sphere holds
//!   its 1-ring triangles (centre of their bounding box, radius to the
//!   farthest corner); a parent's is the smallest sphere holding both
//!   children's spheres, grown to hold its proxy, then by a relative 2⁻²⁰
//!   for f32 rounding. So parent ⊇ child, which makes the angular extent
//!   monotone.
//! - *Luminance range* [min, max] of the leaves below and the **fold
//!   contrast** (Michelson, L&H §2): `(max − min)/(max + min)`, 0 when both
//!   are 0. *Gap decision* (SEED-NOTES §2.5, reading (a)): the proxy's
//!   luminance is the mean of the leaves, inside the range, so the Michelson
//!   contrast of "supported vertices ∪ proxy" is that of the range: an
//!   upper bound on the change at the vertices, and Gouraud extremes are at
//!   vertices (§5.2). The 1-ring neighbours' luminances are not included
//!   (§5.2 footnote 1, "not found necessary").
//! - *Normal mask*: 384 bits, 6 cube faces × 8×8 cells (L&H §5.2, the
//!   paper's 48 bytes; layout in [`NormalMask`]); a leaf holds the cells of
//!   its triangles' face normals (zero-area triangles set none); parents OR
//!   their children.
//! - *Outline flag*: the node supports a vertex of the open border (an end
//!   of an edge of exactly one live triangle of the welded mesh); parents
//!   OR their children.
//! - *Subtris* (VDS): the triangles that vanish when the node folds, i.e.
//!   those whose deepest pairwise lowest common ancestor of corners is this
//!   node. Every drawable triangle is the subtri of exactly one node.
//!
//! **Input rules.** Validated before anything is allocated: ≥ 1 vertex,
//! one normal and one luminance per vertex, finite positions and normals,
//! finite luminance ≥ 0, indices in range, sizes within [`BuildOptions`]
//! (errors name the entry, e.g. "triangle 12 has index 99 ≥ 50 vertices").
//! Triangles with a repeated index draw nothing and are dropped (never
//! drawn, [`VertexTree::vanishing_node`] is `None`); zero-area triangles
//! with three distinct indices are kept.
//!
//! ## The cut ([`Cut`])
//!
//! Node states: *active* (on the cut: its proxy stands for every leaf
//! below), *expanded* (above, unfolded), *collapsed* (below, inside a folded
//! node). A triangle is drawn iff its vanishing node is expanded; its
//! corners are the active nodes holding its three leaves. A fresh cut is
//! the original mesh exactly. `fold(n)` requires both children active
//! (leaves-upward, as in VDS) and removes n's subtris; `fold_subtree(n)`
//! folds an expanded node whatever lies below; `unfold(n)` requires n
//! active and adds its subtris back. The triangle list is a dense array
//! with per-triangle slots (swap-remove), updated only by the subtris of
//! the nodes that change; each leaf's representative is a contiguous range
//! (DFS leaf order) written once per change. Order of the list is
//! unspecified; unfolding everything restores the original set exactly.
//!
//! ## Selection ([`Cut::select`])
//!
//! A top-down walk from the root decides, per node and from the view only,
//! whether it must be unfolded; the same walk unfolds folded nodes it must
//! open and folds (with their subtrees) expanded ones where it stops. So the
//! cost is O(nodes visited + triangles changed), and the cut after any
//! sequence of views equals a fresh cut's after the last view (tested).
//! A bad view (NaN or infinite eye or gaze, gaze at the eye, contrast
//! outside [0, 1]) is an error and leaves the cut unchanged.
//!
//! **Per node, from the eye** (sphere centre c, radius r, distance d):
//!
//! - Eye inside the sphere (d ≤ r): never fold (a fold could change
//!   anything in view).
//! - Angular extent θ = 2·asin(r/d) (*Gap decision*: the exact extent of a
//!   sphere, not the small-angle 2r/d); worst-case frequency f = 1/(2θ) cpd
//!   (L&H §3.1, Fig. 5).
//! - Eccentricity: the angle between the gaze direction (eye → point of
//!   regard) and the direction to the sphere's nearest point, i.e.
//!   max(0, β − asin(r/d)) with β the angle to the centre (*Gap decision*:
//!   the conservative reading; 0 when the gaze ray meets the sphere). No
//!   gaze: 0 everywhere (everything foveal). β uses atan2(|g×w|, g·w).
//! - Silhouette (L&H §5.2 "Determining Silhouette Nodes"): the view
//!   directions to the sphere form a cone (axis eye → c, half-angle
//!   α = asin(r/d)). A cell of normals (a cap of radius ρ) might face front
//!   iff its angle to the axis exceeds 90° − α − ρ, back iff it is below
//!   90° + α + ρ; the node is a silhouette node iff its mask has a cell of
//!   each. *Gap decision*: this evaluates L&H's might-be-front /
//!   might-be-back masks for each node's own view cone, which is how
//!   perspective is handled (the paper gives no rule); cells near the
//!   view-perpendicular plane count as both. A cone bounding the mask
//!   skips the bit loop where it cannot change the answer.
//!   *Gap decision* (open meshes): a node that supports a vertex of the
//!   mesh's open border — an end of an edge only one triangle uses, after
//!   welding ([`VertexTree::on_outline`]) — is a silhouette node from every
//!   view, whatever its normals. L&H's test assumes closed meshes, where
//!   the outline is where the normals turn; an open mesh's outline is its
//!   border, and folding it uncovers the background. Without this a flat
//!   object facing the viewer (one triangle, a quad, a planar polygon) has
//!   only front-facing normals and zero interior contrast, and its root
//!   folded: the object vanished.
//! - Contrast: the fold contrast, or for a silhouette node
//!   max(scene contrast, fold contrast) (L&H §3.1, §5.2: the background may
//!   be exposed; *decision*: the scene's full contrast as given in
//!   [`View::scene_contrast`], never less than the node's own).
//!
//! **Imperceptible** ([`Mode::Imperceptible`]): fold iff the contrast is
//! below threshold at (f, eccentricity) (L&H §3, §5.2). *Monotone error*
//! (L&H §5.3 footnote 2; *decision*): θ, contrast and the silhouette flag
//! never decrease and the eccentricity never increases from a child to its
//! parent (sphere, range and mask containment), and the threshold used is
//! the table's monotone lower envelope T*(f, e) = min over f′ ≥ f, e′ ≥ e
//! (interpolated like the table, in ln T). So a parent is never foldable
//! while a child would be perceptible, and the top-down walk never hides a
//! perceptible fold. T* ≤ T (never less conservative); for a table already
//! non-decreasing in f and e — the Geisler–Perry table of
//! `ThresholdTable::from_model` — T* = T and the test is exactly
//! `!is_perceptible(contrast, f, e)` (tested).
//!
//! **Budget** ([`Mode::Budget`], L&H §5.3, VDS triangle budget): a priority
//! queue of boundary nodes from the root; pop the node with the largest key,
//! unfold it, push its children; stop when unfolding the top would exceed
//! the budget, when the top fold is already imperceptible, or when nothing
//! is left. Key: δ*/d, with δ* = `imperceptible_distance_mm(contrast, 2r,
//! eccentricity)` (the viewing distance at which the fold becomes
//! imperceptible) and d the node's current distance. *Decision*: the ratio
//! rather than δ* itself, because nodes lie at different distances under
//! perspective (L&H's nodes all sit on one screen at one distance, where
//! ordering by δ* and by δ*/d agree); δ*/d ≤ 1 means imperceptible now.
//! The report ([`BudgetOutcome`]) gives δ* and δ*/d of the most perceptible
//! fold left: the distance beyond which the whole simplification should be
//! imperceptible (§5.3). Eccentricity is held fixed (SEED-NOTES §2.5). δ*
//! is `ThresholdTable::imperceptible_distance_mm`'s inversion (flat-extent
//! formula, tan rather than sin: < 1 % apart below 10°) applied to the
//! monotone envelope T*, so keys are monotone down the tree too; for the
//! Geisler–Perry table it equals the table's own answer (tested), found by
//! bisection instead of a column scan.
//!
//! **Murphy–Duchowski** ([`Mode::MurphyDuchowski`]): the level comes from
//! `foveation::degradation::level_for(eccentricity, depth_row)` (Table 1,
//! reading B, coarsest level beyond every extent). *Depth row decision*:
//! M&D's depths 0–4 are the distances at which their object subtended 26°,
//! 24°, 22°, 20°, 18° (§6.2), so the row is the one nearest the angular
//! extent of the whole tree (root sphere) from the eye, clamped to 0–4 (one
//! row per tree per frame). *Level decision*: level L allows a folded node
//! up to `level_angle_deg[L − 1]` degrees of angular extent; a node unfolds
//! when θ exceeds its level's allowance (so the tree stands in for M&D's
//! quadtree levels). Default [`MD_DEFAULT_LEVEL_ANGLE_DEG`]: level 5 = the
//! original mesh, levels 4…1 = 0.5°, 1°, 2°, 4° (each coarser level doubles
//! the size, as each M&D subdivision halves it). Allowances must not grow
//! with the level, which keeps the error monotone (level_for never gives a
//! finer level farther out). Eccentricity as above (nearest point, the
//! analogue of M&D's "any vertex within range"). *Out of scope*: M&D's own
//! multiresolution construction (Voronoi tiling, harmonic maps, quadtree
//! remeshing, §5.1–§5.3); only their degradation function drives this tree.
//! [`Mode::MurphyDuchowskiTable`] reads another table of Table 1's shape
//! (`foveation::degradation::level_in`), e.g. one measured by `gazecast
//! thresholds degradation`; such a table need not be monotone in
//! eccentricity, and the error is monotone down the tree only when it is.
//!
//! ## Not handled
//!
//! Dynamic lighting (luminance is per vertex and static, as in L&H §8.2),
//! temporal contrast and popping (§8.3), geomorphs, frustum and back-face
//! culling (the caller's renderer does those), several viewers.

#![warn(missing_docs)]

mod build;
mod cut;
mod error;
mod normal_mask;
mod quadric;
pub mod select;
mod sphere;
mod threshold;
mod tree;

pub use build::BuildOptions;
pub use cut::{Cut, NodeState};
pub use error::LodError;
pub use normal_mask::NormalMask;
pub use select::{
    judge, BudgetOutcome, BudgetStop, Mode, NodeJudgement, SelectionReport, View,
    MD_DEFAULT_LEVEL_ANGLE_DEG,
};
pub use sphere::Sphere;
pub use tree::{NodeId, VertexTree};
