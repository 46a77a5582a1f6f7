//! View-dependent selection: which nodes of the tree to fold for a view,
//! applied to a [`Cut`] incrementally.
//!
//! Every mode first decides, top-down from the root, which nodes must be
//! unfolded; that decision depends only on the view, never on the cut's
//! current state. The cut is then reconciled with it in the same walk
//! (unfold what must unfold, fold what may), so the result after any
//! sequence of views equals the result of a fresh, fully unfolded cut given
//! the last view.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use foveation::degradation;
use foveation::perceptibility::ThresholdTable;
use glam::{DVec3, Vec3};

use crate::cut::{Cut, ACTIVE, EXPANDED};
use crate::sphere::Sphere;
use crate::threshold::MonotoneThreshold;
use crate::tree::{NodeId, VertexTree};
use crate::LodError;

/// What the viewer sees from where.
#[derive(Debug, Clone, Copy)]
pub struct View<'a> {
    /// Eye position, world mm (same frame as the mesh).
    pub eye_mm: Vec3,
    /// The 3-D point of regard, world mm; `None` without gaze tracking
    /// (then every node is treated as foveal, eccentricity 0).
    pub gaze_point_mm: Option<Vec3>,
    /// The perceptual model (Luebke & Hallen §3.2, §6.1).
    pub thresholds: &'a ThresholdTable,
    /// Michelson contrast between the brightest and darkest things in the
    /// scene, background included (the silhouette contrast, §5.2), in [0, 1].
    pub scene_contrast: f64,
}

/// Murphy & Duchowski default: the largest angular extent (degrees) a
/// folded node may have at levels 1 (coarse) … 5 (fine). Level 5 is the
/// original mesh (nothing with any extent folds); each coarser level doubles
/// the allowed size from 0.5°, as each quadtree level of the paper halves
/// the triangles (§5.3).
pub const MD_DEFAULT_LEVEL_ANGLE_DEG: [f64; 5] = [4.0, 2.0, 1.0, 0.5, 0.0];

/// How to choose the cut.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Mode {
    /// Luebke & Hallen §5.2: fold every node whose fold is judged
    /// imperceptible, top-down.
    Imperceptible,
    /// Luebke & Hallen §5.3: greedy unfolding, most perceptible fold first,
    /// while the triangle count stays within `triangles`.
    Budget {
        /// Most triangles the cut may draw.
        triangles: usize,
    },
    /// Murphy & Duchowski §5.4 and Table 1: a node may stay folded while
    /// its angular extent is at most `level_angle_deg[level − 1]`, the
    /// level coming from `foveation::degradation::level_for` at the node's
    /// eccentricity. Angles must be finite, ≥ 0 and non-increasing from
    /// level 1 to level 5.
    MurphyDuchowski {
        /// Largest angular extent (degrees) a folded node may have at
        /// each resolution level, levels 1 to 5.
        level_angle_deg: [f64; 5],
    },
    /// [`Mode::MurphyDuchowski`] with another degradation table of Table
    /// 1's shape (a participant's, `foveation::degradation::DegradationTable`;
    /// `foveation::degradation::level_in`) in place of Table 1. Extents
    /// must be finite and ≥ 0.
    MurphyDuchowskiTable {
        /// As in [`Mode::MurphyDuchowski`].
        level_angle_deg: [f64; 5],
        /// Rows = depths 0..=4, columns = levels 5 … 1: each level's
        /// eccentricity extent, degrees.
        extents_deg: [[f64; 5]; 5],
    },
}

impl Mode {
    /// [`Mode::MurphyDuchowski`] with [`MD_DEFAULT_LEVEL_ANGLE_DEG`].
    pub fn murphy_duchowski() -> Mode {
        Mode::MurphyDuchowski {
            level_angle_deg: MD_DEFAULT_LEVEL_ANGLE_DEG,
        }
    }

    fn validate(&self) -> Result<(), LodError> {
        if let Mode::MurphyDuchowskiTable { extents_deg, .. } = self {
            for (d, row) in extents_deg.iter().enumerate() {
                if let Some((k, x)) = row
                    .iter()
                    .enumerate()
                    .find(|(_, x)| !(x.is_finite() && **x >= 0.0))
                {
                    return Err(LodError::InvalidMode {
                        field: "extents_deg",
                        value: format!("{x} at depth {d}, level {}", 5 - k),
                        reason: "extents must be finite and ≥ 0",
                    });
                }
            }
        }
        if let Mode::MurphyDuchowski { level_angle_deg: a }
        | Mode::MurphyDuchowskiTable {
            level_angle_deg: a, ..
        } = self
        {
            for (i, &x) in a.iter().enumerate() {
                if !x.is_finite() || x < 0.0 {
                    return Err(LodError::InvalidMode {
                        field: "level_angle_deg",
                        value: format!("{x} at level {}", i + 1),
                        reason: "angles must be finite and ≥ 0",
                    });
                }
                if i > 0 && x > a[i - 1] {
                    return Err(LodError::InvalidMode {
                        field: "level_angle_deg",
                        value: format!("{x} at level {} > {} at level {}", i + 1, a[i - 1], i),
                        reason: "a finer level cannot allow larger nodes (monotone error)",
                    });
                }
            }
        }
        Ok(())
    }
}

/// Why the budget greedy stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BudgetStop {
    /// Unfolding the next node would exceed the triangle budget.
    Budget,
    /// Every fold left is imperceptible at its current distance.
    Imperceptible,
    /// Nothing left to unfold: the original mesh.
    Exhausted,
}

/// What the budget greedy achieved (Luebke & Hallen §5.3: "the system can
/// report the distance at which that simplification should be
/// imperceptible").
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BudgetOutcome {
    /// Why the greedy stopped.
    pub stopped_by: BudgetStop,
    /// δ* of the most perceptible fold left: the eye-to-node distance (mm)
    /// beyond which that fold, and so every fold left, is imperceptible. 0
    /// when nothing is left folded.
    pub imperceptible_distance_mm: f64,
    /// That δ* over the node's current distance: how many times farther
    /// the viewer would have to be (≤ 1: already imperceptible). 0 when
    /// nothing is left folded.
    pub distance_factor: f64,
}

/// Counts from one [`Cut::select`].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SelectionReport {
    /// Nodes the reconciling walk popped (leaves included).
    pub nodes_visited: usize,
    /// Perceptual evaluations (fold tests or budget keys).
    pub nodes_evaluated: usize,
    /// Nodes that went from unfolded to folded.
    pub folds: usize,
    /// Nodes that went from folded to unfolded.
    pub unfolds: usize,
    /// Triangles drawn afterwards.
    pub triangles: usize,
    /// Nodes on the cut afterwards.
    pub active_nodes: usize,
    /// Budget mode only.
    pub budget: Option<BudgetOutcome>,
    /// Murphy–Duchowski mode only: the Table 1 row used.
    pub md_depth_row: Option<usize>,
}

/// Everything the perceptual test computes for one node (for inspection
/// and tests; selection computes the same things).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NodeJudgement {
    /// The eye is inside the node's bounding sphere: never fold.
    pub eye_inside: bool,
    /// Eye to sphere centre, mm.
    pub distance_mm: f64,
    /// θ = 2·asin(r/d), degrees.
    pub angular_extent_deg: f64,
    /// Worst-case frequency 1/(2θ), cpd (§3.1).
    pub frequency_cpd: f64,
    /// Angle from the gaze direction to the nearest point of the sphere.
    pub eccentricity_deg: f64,
    /// The normal mask meets both the might-be-front and might-be-back
    /// sets, or the node is on the mesh's open border
    /// ([`VertexTree::on_outline`]).
    pub silhouette: bool,
    /// The fold contrast, or max(scene, fold) contrast for a silhouette.
    pub contrast: f64,
    /// Folding this node would be perceptible (L&H test, monotone table).
    pub perceptible: bool,
    /// δ* (mm), the budget key before division by the distance.
    pub imperceptible_distance_mm: f64,
}

/// The view-dependent quantities of one sphere.
struct Geometry {
    eye_inside: bool,
    d: f64,
    r: f64,
    axis: DVec3,
    sin_a: f64,
    cos_a: f64,
    theta_deg: f64,
    ecc_deg: f64,
}

/// A validated view with its precomputed pieces.
struct Frame {
    eye: DVec3,
    gaze: Option<DVec3>,
    env: MonotoneThreshold,
    scene_contrast: f64,
}

fn bad_view(field: &'static str, value: impl std::fmt::Display, reason: &'static str) -> LodError {
    LodError::InvalidView {
        field,
        value: value.to_string(),
        reason,
    }
}

impl Frame {
    fn new(view: &View<'_>) -> Result<Self, LodError> {
        if !view.eye_mm.is_finite() {
            return Err(bad_view("eye_mm", view.eye_mm, "must be finite"));
        }
        let eye = view.eye_mm.as_dvec3();
        let gaze = match view.gaze_point_mm {
            None => None,
            Some(g) if !g.is_finite() => {
                return Err(bad_view("gaze_point_mm", g, "must be finite (or None)"))
            }
            Some(g) => {
                let dir = (g.as_dvec3() - eye).normalize_or_zero();
                if dir == DVec3::ZERO || !dir.is_finite() {
                    return Err(bad_view(
                        "gaze_point_mm",
                        g,
                        "coincides with the eye: no gaze direction",
                    ));
                }
                Some(dir)
            }
        };
        let c = view.scene_contrast;
        if !c.is_finite() || !(0.0..=1.0).contains(&c) {
            return Err(bad_view(
                "scene_contrast",
                c,
                "must be a Michelson contrast in [0, 1]",
            ));
        }
        Ok(Self {
            eye,
            gaze,
            env: MonotoneThreshold::new(view.thresholds),
            scene_contrast: c,
        })
    }

    /// θ, eccentricity and the view cone of a sphere (§5.2, §3.1).
    fn geometry(&self, s: &Sphere) -> Geometry {
        let c = s.center.as_dvec3();
        let r = f64::from(s.radius);
        let to = c - self.eye;
        let d = to.length();
        if d <= r {
            return Geometry {
                eye_inside: true,
                d,
                r,
                axis: DVec3::Z,
                sin_a: 1.0,
                cos_a: 0.0,
                theta_deg: 180.0,
                ecc_deg: 0.0,
            };
        }
        let axis = to / d;
        let sin_a = r / d;
        let cos_a = (1.0 - sin_a * sin_a).max(0.0).sqrt();
        let alpha = sin_a.asin();
        let ecc_deg = match self.gaze {
            None => 0.0,
            Some(g) => {
                let beta = g.cross(axis).length().atan2(g.dot(axis));
                (beta - alpha).max(0.0).to_degrees()
            }
        };
        Geometry {
            eye_inside: false,
            d,
            r,
            axis,
            sin_a,
            cos_a,
            theta_deg: (2.0 * alpha).to_degrees(),
            ecc_deg,
        }
    }

    fn frequency(theta_deg: f64) -> f64 {
        if theta_deg > 0.0 {
            0.5 / theta_deg
        } else {
            f64::INFINITY
        }
    }

    /// A silhouette node (§5.2): its fold may expose the background. Either
    /// its normals may face both ways from its view cone, or it holds part
    /// of the mesh's open border ([`VertexTree::on_outline`]): an open
    /// mesh's outline is its border, whatever the normals, so a flat object
    /// facing the viewer is a silhouette there (without this, folding it
    /// away was judged by its interior contrast alone and the object
    /// vanished).
    fn silhouette(tree: &VertexTree, node: NodeId, g: &Geometry) -> bool {
        let v = node as usize;
        tree.outline[v]
            || tree.cone[v].may_be_silhouette(g.axis, g.sin_a, g.cos_a)
                && tree.mask[v].is_silhouette(g.axis, g.sin_a, g.cos_a)
    }

    /// Luebke & Hallen: would folding `node` be perceptible? The silhouette
    /// test (the costly part) runs only when it decides: when the node is
    /// visible at silhouette contrast but not at its fold contrast.
    fn lh_perceptible(&self, tree: &VertexTree, node: NodeId) -> bool {
        let g = self.geometry(&tree.sphere[node as usize]);
        if g.eye_inside {
            return true;
        }
        let f = Self::frequency(g.theta_deg);
        // One table lookup serves both contrasts (compared as logarithms).
        let log_t = self.env.log_threshold(f, g.ecc_deg);
        let fold = f64::from(tree.fold_contrast[node as usize]);
        let sil = self.scene_contrast.max(fold);
        if sil.ln() < log_t {
            return false;
        }
        if fold.ln() >= log_t {
            return true;
        }
        Self::silhouette(tree, node, &g)
    }

    fn judge(&self, tree: &VertexTree, node: NodeId) -> NodeJudgement {
        let g = self.geometry(&tree.sphere[node as usize]);
        let f = Self::frequency(g.theta_deg);
        let fold = f64::from(tree.fold_contrast[node as usize]);
        let silhouette = g.eye_inside || Self::silhouette(tree, node, &g);
        let contrast = if silhouette {
            self.scene_contrast.max(fold)
        } else {
            fold
        };
        let dstar = if g.eye_inside {
            f64::INFINITY
        } else {
            self.env
                .imperceptible_distance_mm(contrast, 2.0 * g.r, g.ecc_deg)
        };
        NodeJudgement {
            eye_inside: g.eye_inside,
            distance_mm: g.d,
            angular_extent_deg: g.theta_deg,
            frequency_cpd: f,
            eccentricity_deg: g.ecc_deg,
            silhouette,
            contrast,
            perceptible: self.lh_perceptible(tree, node),
            imperceptible_distance_mm: dstar,
        }
    }

    /// Budget key (§5.3): δ* from the (monotone) table's inverse at the
    /// node's contrast, extent 2r and eccentricity, and δ*/d.
    fn budget_key(&self, tree: &VertexTree, node: NodeId) -> (f64, f64) {
        let g = self.geometry(&tree.sphere[node as usize]);
        if g.eye_inside {
            return (f64::INFINITY, f64::INFINITY);
        }
        let fold = f64::from(tree.fold_contrast[node as usize]);
        let sil = self.scene_contrast.max(fold);
        let contrast = if sil > fold && Self::silhouette(tree, node, &g) {
            sil
        } else {
            fold
        };
        let dstar = self
            .env
            .imperceptible_distance_mm(contrast, 2.0 * g.r, g.ecc_deg);
        (dstar / g.d, dstar)
    }

    /// The Table 1 row: Murphy & Duchowski's depths 0–4 are the distances
    /// at which their object subtended 26°, 24°, 22°, 20° and 18° (§6.2), so
    /// the row is the one nearest the whole tree's angular extent from the
    /// eye, clamped to 0–4.
    fn md_depth_row(&self, tree: &VertexTree) -> usize {
        let g = self.geometry(&tree.sphere[tree.root as usize]);
        ((26.0 - g.theta_deg) / 2.0).round().clamp(0.0, 4.0) as usize
    }

    fn md_unfold(
        &self,
        tree: &VertexTree,
        node: NodeId,
        row: usize,
        angles: &[f64; 5],
        extents_deg: &[[f64; 5]; 5],
    ) -> bool {
        let g = self.geometry(&tree.sphere[node as usize]);
        if g.eye_inside {
            return true;
        }
        let level = degradation::level_in(extents_deg, g.ecc_deg, row).unwrap_or(5);
        g.theta_deg > angles[usize::from(level.clamp(1, 5)) - 1]
    }
}

/// The perceptual test of one node for `view` (validated as in
/// [`Cut::select`]).
pub fn judge(tree: &VertexTree, view: &View<'_>, node: NodeId) -> Result<NodeJudgement, LodError> {
    tree.check_node(node)?;
    Ok(Frame::new(view)?.judge(tree, node))
}

#[derive(Clone, Copy)]
struct Entry {
    key: f64,
    dstar: f64,
    node: NodeId,
}
impl PartialEq for Entry {
    fn eq(&self, o: &Self) -> bool {
        self.cmp(o) == Ordering::Equal
    }
}
impl Eq for Entry {}
impl PartialOrd for Entry {
    fn partial_cmp(&self, o: &Self) -> Option<Ordering> {
        Some(self.cmp(o))
    }
}
impl Ord for Entry {
    /// Largest key first; ties to the smaller id (determinism).
    fn cmp(&self, o: &Self) -> Ordering {
        self.key
            .total_cmp(&o.key)
            .then_with(|| o.node.cmp(&self.node))
    }
}

impl Cut<'_> {
    /// Chooses the cut for `view` and `mode`, updating the current cut
    /// incrementally. On an error the cut is unchanged.
    pub fn select(&mut self, view: &View<'_>, mode: &Mode) -> Result<SelectionReport, LodError> {
        let frame = Frame::new(view)?;
        mode.validate()?;
        let tree = self.tree;
        let mut report = SelectionReport::default();
        match *mode {
            Mode::Imperceptible => {
                let mut evaluated = 0;
                self.reconcile(
                    |v| {
                        evaluated += 1;
                        frame.lh_perceptible(tree, v)
                    },
                    &mut report,
                );
                report.nodes_evaluated = evaluated;
            }
            Mode::MurphyDuchowski { level_angle_deg }
            | Mode::MurphyDuchowskiTable {
                level_angle_deg, ..
            } => {
                let extents_deg = match *mode {
                    Mode::MurphyDuchowskiTable { extents_deg, .. } => extents_deg,
                    _ => degradation::TABLE_1_DEG,
                };
                let row = frame.md_depth_row(tree);
                report.md_depth_row = Some(row);
                let mut evaluated = 0;
                self.reconcile(
                    |v| {
                        evaluated += 1;
                        frame.md_unfold(tree, v, row, &level_angle_deg, &extents_deg)
                    },
                    &mut report,
                );
                report.nodes_evaluated = evaluated;
            }
            Mode::Budget { triangles } => {
                let mut mark = std::mem::take(&mut self.mark);
                mark.resize(tree.node_count(), 0);
                self.stamp = self.stamp.wrapping_add(1);
                if self.stamp == 0 {
                    mark.fill(0);
                    self.stamp = 1;
                }
                let stamp = self.stamp;
                let outcome = budget_greedy(&frame, tree, triangles, &mut mark, stamp, &mut report);
                report.budget = Some(outcome);
                self.reconcile(|v| mark[v as usize] == stamp, &mut report);
                self.mark = mark;
            }
        }
        report.triangles = self.active_triangle_count();
        report.active_nodes = self.active_node_count();
        Ok(report)
    }

    /// Walks down from the root through the nodes `wants_unfold` keeps
    /// open, unfolding folded ones it reaches and folding (whole subtrees)
    /// where it stops; then points the leaves of every node that joined the
    /// cut at it (disjoint ranges, each leaf written at most once).
    fn reconcile(
        &mut self,
        mut wants_unfold: impl FnMut(NodeId) -> bool,
        report: &mut SelectionReport,
    ) {
        let tree = self.tree;
        let mut stack = std::mem::take(&mut self.stack);
        let mut fresh = std::mem::take(&mut self.fresh);
        stack.clear();
        fresh.clear();
        stack.push(tree.root);
        while let Some(x) = stack.pop() {
            report.nodes_visited += 1;
            if tree.is_leaf(x) {
                continue;
            }
            if wants_unfold(x) {
                let kids = tree.children[x as usize];
                if self.state[x as usize] == ACTIVE {
                    self.expand(x);
                    report.unfolds += 1;
                    fresh.extend_from_slice(&kids);
                }
                // Second child below the first: pop order = id order, so
                // the walk reads the node arrays front to back.
                stack.push(kids[1]);
                stack.push(kids[0]);
            } else if self.state[x as usize] == EXPANDED {
                report.folds += self.collapse(x);
                fresh.push(x);
            }
        }
        for &v in &fresh {
            if self.state[v as usize] == ACTIVE {
                self.fill_rep(v);
            }
        }
        self.stack = stack;
        self.fresh = fresh;
    }
}

/// Luebke & Hallen §5.3 / VDS triangle-budget simplification: a priority
/// queue of boundary nodes keyed by δ*/d; pop the largest, unfold it (mark),
/// push its children; stop when unfolding the top would exceed the budget,
/// when the top is already imperceptible (δ*/d ≤ 1), or when nothing is
/// left.
fn budget_greedy(
    frame: &Frame,
    tree: &VertexTree,
    budget: usize,
    mark: &mut [u32],
    stamp: u32,
    report: &mut SelectionReport,
) -> BudgetOutcome {
    let mut heap = BinaryHeap::new();
    let push = |heap: &mut BinaryHeap<Entry>, node: NodeId, report: &mut SelectionReport| {
        if !tree.is_leaf(node) {
            report.nodes_evaluated += 1;
            let (key, dstar) = frame.budget_key(tree, node);
            heap.push(Entry { key, dstar, node });
        }
    };
    push(&mut heap, tree.root, report);
    let mut triangles = 0usize;
    loop {
        let Some(&top) = heap.peek() else {
            return BudgetOutcome {
                stopped_by: BudgetStop::Exhausted,
                imperceptible_distance_mm: 0.0,
                distance_factor: 0.0,
            };
        };
        let stop = if top.key <= 1.0 {
            Some(BudgetStop::Imperceptible)
        } else if triangles + tree.subtris(top.node).len() > budget {
            Some(BudgetStop::Budget)
        } else {
            None
        };
        if let Some(stopped_by) = stop {
            return BudgetOutcome {
                stopped_by,
                imperceptible_distance_mm: top.dstar,
                distance_factor: top.key,
            };
        }
        heap.pop();
        mark[top.node as usize] = stamp;
        triangles += tree.subtris(top.node).len();
        for c in tree.children[top.node as usize] {
            push(&mut heap, c, report);
        }
    }
}
