//! The ray mask: where rays are cast for one point of regard, and the
//! intermediate mesh that connects them (Murphy 2007 §4.4.4, Fig. 4.3/4.4).
//!
//! Layout: a contiguous disc of one ray per pixel centre around the POR, out
//! to the radius where the allowed spacing first exceeds one pixel; then
//! concentric rings. Ring `k` has radius `r_k` and `n_k` points per full turn
//! at angles `2πi/n_k`. Consecutive rings are joined into a strip of quads
//! where their angles line up and triangles where the point counts differ, so
//! the mesh has no gaps and no overlaps. Only the parts of rings that can
//! touch the screen are generated.
//!
//! Spacing: both the radial step `r_{k+1} - r_k` and the tangential step
//! `2π r_k / n_k` are at most the allowed spacing (see [`SamplingModel`]),
//! taken as the minimum over the visible part of the ring and over the step.
//! The allowed spacing depends on where the POR is (the eye sees the screen
//! obliquely away from its normal), so a mask belongs to one POR; building one
//! takes a few milliseconds (see the `mask` benchmark).
//!
//! Cost: a mask costs what is on the screen, wherever the POR is. The fovea
//! scan and the rings start at the first radius that can reach the screen
//! (the distance from the POR to the nearest point of the screen rectangle),
//! and both loops run a number of times bounded by the screen diagonal, so a
//! POR far off the screen costs no more than one on it (see the `mask_far`
//! benchmark). For a POR on the screen that distance is 0 and nothing changes.
//!
//! A POR off the screen: no fovea disc reaches the screen unless the allowed
//! spacing at the nearest screen points is still one pixel; the rings are
//! arcs that sweep across the screen from its nearest point to its farthest
//! corner, only where they can touch it. A POR farther than [`FAR_POR_PX`]
//! from the screen is replaced by its stand-in at that distance, in the same
//! direction from the nearest screen point (see [`stand_in_por`]); the mask,
//! including [`RayMask::por_px`], is the stand-in's. There the rings are
//! straight across the screen to well under a pixel and the allowed spacing
//! has converged: the lines of sight to the POR and to its stand-in differ by
//! about (eye distance + screen diagonal, in pixels) / `FAR_POR_PX` radians,
//! under 10⁻⁴ rad (0.005°) on the shipped displays. Every f64 beyond ~10¹⁷ px would
//! otherwise be out of reach anyway: `r + step` no longer changes `r` there.
//! A non-finite POR is an error.

mod arcs;

use std::collections::HashMap;
use std::f64::consts::{PI, TAU};
use std::hash::{BuildHasherDefault, Hasher};

use serde::{Deserialize, Serialize};

pub use arcs::{ArcSet, ScreenFromPor};

use crate::error::ParamError;
use crate::sampling::{PorSampler, SamplingModel, Spacing};
use crate::ScreenGeometry;

/// Which ring layout to build.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Layout {
    /// The fewest rays that meet the Nyquist spacing: real-valued radii and
    /// spacings, a per-ring point count (kept from ring to ring while it
    /// still meets the bound, so most cells are quads).
    #[default]
    Nyquist,
    /// The dissertation's layout (Murphy 2007 §4.4.4): integer pixel spacing
    /// that grows where the CSF allows, and one constant angular step for
    /// every ring, taken from the outermost ring.
    Seed,
}

impl Layout {
    /// The layout's name in files and on the command line (`nyquist`, `seed`).
    pub fn name(self) -> &'static str {
        match self {
            Layout::Nyquist => "nyquist",
            Layout::Seed => "seed",
        }
    }
}

impl std::str::FromStr for Layout {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "nyquist" => Ok(Layout::Nyquist),
            "seed" => Ok(Layout::Seed),
            other => Err(format!(
                "unknown layout `{other}`: expected `nyquist` or `seed`"
            )),
        }
    }
}

/// Distance from the screen, pixels, beyond which a POR is replaced by its
/// stand-in at this distance (see [`stand_in_por`]): 10⁸ px, 26 km at a
/// 0.26 mm pitch. Chosen so the farthest ring (this plus a screen diagonal of
/// at most 23,170 px) needs fewer than 2³⁰ points per turn at the finest
/// spacing of one pixel, which keeps the mesh's index arithmetic within
/// `u32`/`i64`, while the allowed spacing on the screen has long converged.
pub const FAR_POR_PX: f64 = 1e8;

/// Where the mask for `por_px` is built around on a `width_px × height_px`
/// screen: the POR itself when it is within [`FAR_POR_PX`] of the screen
/// rectangle (to a relative 10⁻⁹, so a stand-in stands in for itself), else
/// the point at `FAR_POR_PX` from the nearest screen point towards it.
/// Finite input gives finite output; non-finite input is returned as is.
pub fn stand_in_por(por_px: [f64; 2], width_px: f64, height_px: f64) -> [f64; 2] {
    if !(por_px[0].is_finite() && por_px[1].is_finite()) {
        return por_px;
    }
    let near = [
        por_px[0].clamp(0.0, width_px),
        por_px[1].clamp(0.0, height_px),
    ];
    let d = [por_px[0] - near[0], por_px[1] - near[1]];
    // Scaled by the larger component, so ±f64::MAX cannot overflow.
    let scale = d[0].abs().max(d[1].abs());
    if scale == 0.0 {
        return por_px; // on the screen
    }
    let unit = [d[0] / scale, d[1] / scale];
    let len = unit[0].hypot(unit[1]); // in [1, √2]
    if scale * len <= FAR_POR_PX * (1.0 + 1e-9) {
        return por_px;
    }
    let k = FAR_POR_PX / len;
    [near[0] + unit[0] * k, near[1] + unit[1] * k]
}

/// Marks the missing fourth corner of a triangular cell.
pub const NO_VERTEX: u32 = u32::MAX;

/// A row of contiguous fovea pixels `[x_start, x_end)` on row `y`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PixelSpan {
    /// Screen row, pixels from the top.
    pub y: u32,
    /// First pixel of the span (inclusive).
    pub x_start: u32,
    /// One past the last pixel of the span (exclusive).
    pub x_end: u32,
}

/// One ring of the mask.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ring {
    /// Distance of the ring from the POR, pixels.
    pub radius_px: f64,
    /// Points on a full turn (only the visible part is materialised).
    pub points_per_turn: u32,
    /// Radial step to the next ring, pixels.
    pub radial_step_px: f64,
    /// The tightest allowed spacing found on the ring, with its eccentricity
    /// and local pixels-per-degree (used to plot the layout against the CSF).
    pub tightest: Spacing,
}

/// A ray mask for one POR.
#[derive(Debug, Clone)]
pub struct RayMask {
    /// The layout the mask was built with.
    pub layout: Layout,
    /// The POR the mask was built for: as given, or its stand-in when it is
    /// farther than [`FAR_POR_PX`] from the screen (see [`stand_in_por`]).
    pub por_px: [f64; 2],
    /// Screen width, pixels.
    pub width_px: u32,
    /// Screen height, pixels.
    pub height_px: u32,
    /// Pixel centres within this distance of the POR are cast one per pixel.
    /// Off the screen the fovea scan starts just short of the screen, so
    /// this is at least `d_min − 1` (`d_min` the POR's distance to the
    /// screen) even when no fovea pixel is on the screen.
    pub fovea_radius_px: f64,
    /// The fovea disc, clipped to the screen.
    pub fovea: Vec<PixelSpan>,
    /// The rings outside the fovea, innermost first.
    pub rings: Vec<Ring>,
    /// Intermediate-mesh vertices in screen pixels. Those on the screen are
    /// rays; the others lie just outside and only close cells at the edge.
    pub vertices: Vec<[f32; 2]>,
    /// Intermediate-mesh cells: four vertex indices (quads) or three and
    /// [`NO_VERTEX`] (triangles), in ring order.
    pub cells: Vec<[u32; 4]>,
    /// The two rings' vertex slots the mesh walk uses, kept so that a
    /// rebuild in place allocates nothing once they have grown.
    slots: [RingSlots; 2],
}

impl RayMask {
    /// Rays in the fovea disc.
    pub fn fovea_rays(&self) -> usize {
        self.fovea
            .iter()
            .map(|s| (s.x_end - s.x_start) as usize)
            .sum()
    }

    fn on_screen(&self, v: [f32; 2]) -> bool {
        let (x, y) = (f64::from(v[0]), f64::from(v[1]));
        x >= 0.0 && x < f64::from(self.width_px) && y >= 0.0 && y < f64::from(self.height_px)
    }

    /// Mesh vertices on the screen (each is a ray).
    pub fn ring_rays(&self) -> usize {
        self.vertices.iter().filter(|v| self.on_screen(**v)).count()
    }

    /// Rays inside the screen for this POR: fovea pixels plus on-screen mesh vertices.
    pub fn rays(&self) -> usize {
        self.fovea_rays() + self.ring_rays()
    }

    /// Mesh vertices that lie off the screen (needed only to close edge cells).
    pub fn off_screen_vertices(&self) -> usize {
        self.vertices.len() - self.ring_rays()
    }

    /// Every ray position on the screen: fovea pixel centres, then mesh vertices.
    pub fn ray_positions(&self) -> impl Iterator<Item = [f64; 2]> + '_ {
        let fovea = self.fovea.iter().flat_map(|s| {
            (s.x_start..s.x_end).map(move |x| [f64::from(x) + 0.5, f64::from(s.y) + 0.5])
        });
        let rings = self
            .vertices
            .iter()
            .filter(|v| self.on_screen(**v))
            .map(|v| [f64::from(v[0]), f64::from(v[1])]);
        fovea.chain(rings)
    }

    /// The corners of cell `i` (3 or 4).
    pub fn cell_corners(&self, i: usize) -> Vec<[f64; 2]> {
        self.cells[i]
            .iter()
            .filter(|&&v| v != NO_VERTEX)
            .map(|&v| {
                let p = self.vertices[v as usize];
                [f64::from(p[0]), f64::from(p[1])]
            })
            .collect()
    }

    /// Number of quads and triangles.
    pub fn cell_counts(&self) -> (usize, usize) {
        let tris = self.cells.iter().filter(|c| c[3] == NO_VERTEX).count();
        (self.cells.len() - tris, tris)
    }
}

/// Samples per full turn when taking the minimum spacing over a ring.
const SAMPLES_PER_TURN: f64 = 16.0;
/// Most points a ring may have per turn, 2³⁰: [`ladder`] keeps it at most
/// 2³⁰, and the strip walk's products `(i + 1)·n` (i < 2n + 2) stay below
/// 2⁶² in `i64`. Rings within [`FAR_POR_PX`] plus a screen diagonal need at
/// most 2π·1.0003·10⁸ ≈ 6.3·10⁸ points at a spacing of one pixel.
const MAX_POINTS_PER_TURN: f64 = (1u32 << 30) as f64;
/// A ring keeps the previous ring's point count (so the strip is all quads)
/// while that count is at least this fraction of what it needs.
const KEEP_COUNT_FRACTION: f64 = 0.8;

/// Builds the ray mask for `por_px` (any finite point, on or off the screen;
/// see the module docs for a POR off the screen). Errors: a non-finite POR
/// (`gaze.x`, `gaze.y`), or a model whose screen exceeds the size limits of
/// [`screen_geometry::check_resolution`] (`resolution_px…`), which
/// [`Display::geometry`](crate::Display::geometry) already refuses.
pub fn build(
    model: &SamplingModel,
    layout: Layout,
    por_px: [f64; 2],
) -> Result<RayMask, ParamError> {
    let mut mask = RayMask {
        layout,
        por_px,
        width_px: 0,
        height_px: 0,
        fovea_radius_px: 0.0,
        fovea: Vec::new(),
        rings: Vec::new(),
        vertices: Vec::new(),
        cells: Vec::new(),
        slots: Default::default(),
    };
    rebuild(&mut mask, model, layout, por_px)?;
    Ok(mask)
}

/// Rebuilds `mask` in place for a new POR (or model, or layout), reusing its
/// buffers, for a caller that keeps one mask across gazes (the renderers
/// call [`build`] per frame today). On error the mask is left unchanged.
pub fn rebuild(
    mask: &mut RayMask,
    model: &SamplingModel,
    layout: Layout,
    por_px: [f64; 2],
) -> Result<(), ParamError> {
    if !por_px[0].is_finite() {
        return Err(ParamError::new(
            "gaze.x",
            por_px[0],
            "the point of regard must be finite",
        ));
    }
    if !por_px[1].is_finite() {
        return Err(ParamError::new(
            "gaze.y",
            por_px[1],
            "the point of regard must be finite",
        ));
    }
    // Defence in depth: a hand-made geometry must not size the work either.
    screen_geometry::check_resolution(model.geometry.width_px, model.geometry.height_px)?;
    let [w, h] = model.geometry.size_px();
    let por_px = stand_in_por(por_px, w, h);
    let screen = ScreenFromPor::new(por_px, w, h);
    let sampler = RingSampler {
        at_por: model.from_por(por_px),
        screen,
        por: por_px,
        cache: Default::default(),
    };
    mask.layout = layout;
    mask.por_px = por_px;
    mask.width_px = model.geometry.width_px;
    mask.height_px = model.geometry.height_px;
    mask.fovea_radius_px = sampler.fovea_radius(layout);
    if model.inset_deg > 0.0 {
        let limit = screen.max_distance_px + 1.0;
        let inset = inset_radius_px(&model.geometry, por_px, 0.5 * model.inset_deg, limit);
        mask.fovea_radius_px = mask.fovea_radius_px.max(inset);
    }
    fovea_spans(
        &mut mask.fovea,
        por_px,
        mask.fovea_radius_px,
        mask.width_px,
        mask.height_px,
    );
    sampler.rings(&mut mask.rings, layout, mask.fovea_radius_px);
    mesh_strips(mask, &screen);
    Ok(())
}

/// Directions [`inset_radius_px`] searches along.
const INSET_DIRECTIONS: usize = 64;

/// The radius (px) of the disc around `por_px` that holds every screen
/// point within `half_deg` of it at the eye: along each of
/// [`INSET_DIRECTIONS`] directions (and a margin of one pixel, for the
/// directions between them) the distance at which the eccentricity
/// reaches `half_deg`, by bisection (eccentricity grows monotonically
/// along a ray from the POR below 90°); the largest of them, at most
/// `limit` (an inset wider than the screen makes the whole screen the
/// disc). Bounded work: 64 directions × 48 bisection steps.
fn inset_radius_px(geometry: &ScreenGeometry, por_px: [f64; 2], half_deg: f64, limit: f64) -> f64 {
    let ecc = |r: f64, (c, s): (f64, f64)| {
        geometry.eccentricity_deg(por_px, [por_px[0] + r * c, por_px[1] + r * s])
    };
    let mut best: f64 = 0.0;
    for k in 0..INSET_DIRECTIONS {
        let a = std::f64::consts::TAU * k as f64 / INSET_DIRECTIONS as f64;
        let dir = (a.cos(), a.sin());
        if ecc(limit, dir) <= half_deg {
            return limit;
        }
        let (mut lo, mut hi) = (0.0, limit);
        for _ in 0..48 {
            let mid = 0.5 * (lo + hi);
            if ecc(mid, dir) <= half_deg {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        best = best.max(hi);
    }
    (best + 1.0).min(limit)
}

struct RingSampler {
    at_por: PorSampler,
    screen: ScreenFromPor,
    por: [f64; 2],
    /// The last radius evaluated and its result: the predictor step of one
    /// ring is usually the next ring's radius.
    cache: std::cell::Cell<Option<(f64, Spacing)>>,
}

impl RingSampler {
    /// The tightest allowed spacing on the visible part of the circle of
    /// radius `r` (the whole circle if none of it is visible).
    fn tightest(&self, r: f64) -> Spacing {
        if let Some((cached_r, s)) = self.cache.get() {
            if cached_r == r {
                return s;
            }
        }
        let s = self.tightest_uncached(r);
        self.cache.set(Some((r, s)));
        s
    }

    fn tightest_uncached(&self, r: f64) -> Spacing {
        if r <= 0.0 {
            return self.at_por.spacing_at(self.por);
        }
        let arcs = match self.screen.visible_arcs(r) {
            set if set.is_empty() => ArcSet::Full,
            set => set,
        };
        let mut best: Option<Spacing> = None;
        for (a, b) in arcs.intervals() {
            let n = ((b - a) / TAU * SAMPLES_PER_TURN).ceil().max(2.0) as usize;
            for k in 0..=n {
                let phi = a + (b - a) * k as f64 / n as f64;
                let p = [self.por[0] + r * phi.cos(), self.por[1] + r * phi.sin()];
                let s = self.at_por.spacing_at(p);
                if best.is_none_or(|b| s.spacing_px < b.spacing_px) {
                    best = Some(s);
                }
            }
        }
        best.unwrap_or_else(|| self.at_por.spacing_at(self.por))
    }

    /// Allowed step from radius `r`: the tightest spacing at `r` and at the
    /// radius one step out (a predictor step, so the bound holds across the
    /// whole step, not only at its inner end).
    fn step(&self, r: f64) -> Spacing {
        let here = self.tightest(r);
        let there = self.tightest_uncached(r + here.spacing_px);
        self.cache.set(Some((r + here.spacing_px, there)));
        if there.spacing_px < here.spacing_px {
            there
        } else {
            here
        }
    }

    /// Radius of the one-ray-per-pixel disc: where the allowed spacing first
    /// exceeds one pixel (nyquist) or first reaches two whole pixels (seed:
    /// the first intersection of Fig. 4.4). At least 1 px; at most the
    /// farthest screen corner.
    ///
    /// The scan goes out in whole pixels from the last whole radius short of
    /// the screen, `1 + ⌊max(d_min − 1, 0)⌋` (1 for a POR on the screen, so
    /// nothing changes there): smaller circles miss the screen and cannot
    /// put a fovea pixel on it. It ends by `max_distance + 1`, at most a
    /// screen diagonal plus 2 steps later; `r` is a whole number below 2⁵³
    /// (the POR is within [`FAR_POR_PX`]), so each step adds exactly 1.
    fn fovea_radius(&self, layout: Layout) -> f64 {
        let limit = self.screen.max_distance_px + 1.0;
        let exceeds = |r: f64| match layout {
            Layout::Nyquist => self.tightest(r).spacing_px > 1.0,
            Layout::Seed => self.tightest(r).spacing_px >= 2.0,
        };
        let start = 1.0 + (self.screen.min_distance_px - 1.0).max(0.0).floor();
        let mut r = start;
        while r < limit && !exceeds(r) {
            r += 1.0;
        }
        if layout == Layout::Seed || r <= start || r >= limit {
            return r.min(limit);
        }
        // Refine between r - 1 (does not exceed) and r (exceeds).
        let (mut lo, mut hi) = (r - 1.0, r);
        for _ in 0..24 {
            let mid = 0.5 * (lo + hi);
            if exceeds(mid) {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        hi
    }

    /// The rings from the fovea edge, or from the nearest screen point if
    /// that is farther, out past the farthest screen corner.
    ///
    /// Start: `r_0 = max(fovea radius, d_min)`, `d_min` the distance from the
    /// POR to the screen rectangle. The cells outside ring k reach in to its
    /// chords at `r_k·cos(π/n_k) ≤ r_k`, so a first ring at `d_min` already
    /// closes every edge cell: no screen point lies inside it. On the screen
    /// `d_min = 0` and `r_0` is the fovea radius, as it always was, so every
    /// ring, and the mask, is bit-identical; off it, the rings that the old
    /// loop stepped through between the fovea and the screen (one per ≤ n_max
    /// pixels of distance) made no cells and are skipped.
    ///
    /// Termination: every ring steps out by at least 1 px (the spacing is
    /// clamped to ≥ 1), so r passes `far` within `far − r_0 + 1` rings, and
    /// `far − r_0 ≤` the screen diagonal (the farthest corner is at most a
    /// diagonal beyond the nearest point). A ring beyond `far` stops the loop
    /// unless `r − far < s²/(8r)` (its polygon's inset, s its step ≤ r), which
    /// needs its spacing to grow by a square root of `8·far·s_prev` a ring:
    /// a handful of rings at most. The loop is cut at `far − r_0 + 64` rings
    /// regardless, a count from the screen size alone.
    fn rings(&self, rings: &mut Vec<Ring>, layout: Layout, fovea_radius_px: f64) {
        rings.clear();
        let far = self.screen.max_distance_px;
        if fovea_radius_px > far {
            return;
        }
        let mut r = fovea_radius_px.max(self.screen.min_distance_px);
        let max_rings = (far - r).max(0.0).ceil() as usize + 64;
        for _ in 0..max_rings {
            let tightest = self.step(r);
            let step = match layout {
                Layout::Nyquist => tightest.spacing_px,
                Layout::Seed => tightest.spacing_px.floor().max(1.0),
            };
            // At most MAX_POINTS_PER_TURN: a bound only a ring pushed far
            // beyond the screen by a huge max_spacing_px could reach.
            let needed = ((TAU * r / step).ceil().min(MAX_POINTS_PER_TURN) as u32).max(3);
            let points_per_turn = match (layout, rings.last()) {
                (Layout::Nyquist, Some(prev))
                    if needed <= prev.points_per_turn
                        && f64::from(needed)
                            >= KEEP_COUNT_FRACTION * f64::from(prev.points_per_turn) =>
                {
                    prev.points_per_turn
                }
                (Layout::Nyquist, _) => ladder(needed),
                (Layout::Seed, _) => needed,
            };
            rings.push(Ring {
                radius_px: r,
                points_per_turn,
                radial_step_px: step,
                tightest,
            });
            // Stop once this ring's polygon (inscribed, so its edges are
            // r·cos(π/n) from the POR) lies beyond every screen corner.
            if r * (PI / f64::from(points_per_turn)).cos() > far {
                break;
            }
            r += step;
        }
        if layout == Layout::Seed {
            // One constant angular step for all rings (Murphy 2007 §4.4.4):
            // the tightest any ring needs, which is the outermost ring's
            // whenever spacing grows faster than linearly with radius.
            let n = rings.iter().map(|r| r.points_per_turn).max().unwrap_or(3);
            for ring in rings.iter_mut() {
                ring.points_per_turn = n;
            }
        }
    }
}

/// Rounds a point count up to the form m·2^k with 16 ≤ m < 32 (at most
/// 1/16 more points), so consecutive rings share counts and their strips are
/// quads; counts of 32 and below are kept.
fn ladder(n: u32) -> u32 {
    if n <= 32 {
        return n;
    }
    let k = (31 - n.leading_zeros()) - 4;
    n.div_ceil(1 << k) << k
}

/// Fovea pixels: every pixel whose centre is within `radius` of the POR.
fn fovea_spans(spans: &mut Vec<PixelSpan>, por: [f64; 2], radius: f64, width: u32, height: u32) {
    spans.clear();
    let y_lo = (por[1] - radius - 0.5).ceil().max(0.0);
    let y_hi = (por[1] + radius - 0.5).floor().min(f64::from(height) - 1.0);
    if y_lo > y_hi {
        return;
    }
    for y in (y_lo as u32)..=(y_hi as u32) {
        let dy = f64::from(y) + 0.5 - por[1];
        let half = (radius * radius - dy * dy).max(0.0).sqrt();
        let x_lo = (por[0] - half - 0.5).ceil().max(0.0);
        let x_hi = (por[0] + half - 0.5).floor().min(f64::from(width) - 1.0);
        if x_lo <= x_hi {
            spans.push(PixelSpan {
                y,
                x_start: x_lo as u32,
                x_end: x_hi as u32 + 1,
            });
        }
    }
}

/// Rings with at most this many points per turn index their vertex ids in a
/// dense array (8 bytes a point, 2 MB at most): every ring of a POR on a
/// screen within the size limits (diagonal ≤ 23,170 px: ≤ 1.55·10⁵ points).
const DENSE_SLOTS_MAX: u32 = 1 << 18;

/// Point index → vertex id for rings too long for a dense array.
type SparseSlots = HashMap<u32, u32, BuildHasherDefault<IndexHasher>>;

/// Hashes a point index with one multiply (Fibonacci hashing): the keys are
/// runs of consecutive integers, which this spreads over every bit, and the
/// map is private, so no adversary picks them.
#[derive(Default)]
struct IndexHasher(u64);

impl Hasher for IndexHasher {
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.write_u32(u32::from(b));
        }
    }

    fn write_u32(&mut self, i: u32) {
        self.0 = (self.0 ^ u64::from(i)).wrapping_mul(0x9E37_79B9_7F4A_7C15);
    }

    fn finish(&self) -> u64 {
        self.0
    }
}

/// Vertex ids of one ring's points, created on first use.
///
/// A slot holds `(generation << 32) | vertex id`; bumping the generation
/// empties every slot at once when the buffer moves on to another ring.
/// Rings with more than [`DENSE_SLOTS_MAX`] points per turn (only a POR well
/// off the screen has them, and only a sliver of each ring is walked) keep
/// their ids in a map instead, so memory follows the points made, not `n`.
///
/// The walk visits a ring's indices in order, so a new point is usually the
/// previous one rotated by one angular step: one complex multiply instead of
/// a sine and cosine (the drift over a few thousand steps is ~1e-13, far
/// below the f32 the vertices are stored in).
#[derive(Debug, Clone)]
struct RingSlots {
    radius: f64,
    n: u32,
    generation: u64,
    slots: Vec<u64>,
    /// Used instead of `slots` when `n > DENSE_SLOTS_MAX`.
    sparse: Option<SparseSlots>,
    /// Index and unit vector of the last point created, and the rotation by one step.
    last_index: usize,
    last_unit: [f64; 2],
    step: [f64; 2],
}

impl Default for RingSlots {
    fn default() -> Self {
        Self::new()
    }
}

impl RingSlots {
    fn new() -> Self {
        Self {
            radius: 0.0,
            n: 0,
            generation: 0,
            slots: Vec::new(),
            sparse: None,
            last_index: usize::MAX,
            last_unit: [1.0, 0.0],
            step: [1.0, 0.0],
        }
    }

    fn reset(&mut self, ring: &Ring) {
        self.generation += 1;
        if self.generation > u64::from(u32::MAX) {
            // The generation lives in a slot's upper 32 bits: start again
            // from an emptied array rather than let an old id look current.
            self.slots.fill(0);
            self.generation = 1;
        }
        self.radius = ring.radius_px;
        self.n = ring.points_per_turn;
        self.last_index = usize::MAX;
        let (s, c) = (TAU / f64::from(self.n)).sin_cos();
        self.step = [c, s];
        if self.n > DENSE_SLOTS_MAX {
            self.sparse.get_or_insert_with(SparseSlots::default).clear();
        } else {
            if let Some(map) = self.sparse.as_mut() {
                map.clear();
            }
            if self.slots.len() < self.n as usize {
                self.slots.resize(self.n as usize, 0);
            }
        }
    }

    /// The vertex id already made for point `i`, if any.
    #[inline]
    fn lookup(&self, i: usize) -> Option<u32> {
        if self.n > DENSE_SLOTS_MAX {
            self.sparse.as_ref()?.get(&(i as u32)).copied()
        } else {
            let slot = self.slots[i];
            (slot >> 32 == self.generation).then_some(slot as u32)
        }
    }

    /// Vertex id of point `i` (already reduced to `0..n`).
    #[inline]
    fn vertex(&mut self, i: usize, por: [f64; 2], vertices: &mut Vec<[f32; 2]>) -> u32 {
        if let Some(id) = self.lookup(i) {
            return id;
        }
        // Rotate the previous point only when there is one on this ring
        // (`last_index` is `usize::MAX` after a reset: a wrapping `+ 1`
        // would take point 0 for its successor and rotate a stale unit
        // vector, putting point 0 of a ring walked from index 0 at a wrong
        // angle).
        let unit = if self.last_index != usize::MAX && self.last_index + 1 == i {
            let [c, s] = self.last_unit;
            [
                c * self.step[0] - s * self.step[1],
                s * self.step[0] + c * self.step[1],
            ]
        } else {
            let (s, c) = (TAU * i as f64 / f64::from(self.n)).sin_cos();
            [c, s]
        };
        self.last_index = i;
        self.last_unit = unit;
        let id = vertices.len() as u32;
        if self.n > DENSE_SLOTS_MAX {
            self.sparse
                .get_or_insert_with(SparseSlots::default)
                .insert(i as u32, id);
        } else {
            self.slots[i] = (self.generation << 32) | u64::from(id);
        }
        vertices.push([
            (por[0] + self.radius * unit[0]) as f32,
            (por[1] + self.radius * unit[1]) as f32,
        ]);
        id
    }
}

/// Joins each pair of consecutive rings into a strip over the angles where
/// the strip can touch the screen.
fn mesh_strips(mask: &mut RayMask, screen: &ScreenFromPor) {
    let por = mask.por_px;
    // The strips' arcs, computed again where they are walked (cheaper than
    // keeping a list of them: a few hundred rings).
    let strips = || {
        mask.rings
            .windows(2)
            .map(|pair| strip_arcs(&pair[0], &pair[1], screen))
    };
    // Reserve what the strips will produce: a ring's share of points is the
    // visible fraction of its turn.
    let estimate: f64 = strips()
        .zip(&mask.rings)
        .map(|(arcs, ring)| {
            let turn: f64 = arcs
                .intervals()
                .iter()
                .map(|(a, b)| b - a)
                .sum::<f64>()
                .min(TAU)
                / TAU;
            turn * f64::from(ring.points_per_turn)
        })
        .sum();
    let mut vertices = std::mem::take(&mut mask.vertices);
    let mut cells = std::mem::take(&mut mask.cells);
    vertices.clear();
    cells.clear();
    vertices.reserve((estimate * 1.1) as usize + 16);
    cells.reserve((estimate * 1.1) as usize + 16);
    let [mut inner, mut outer] = std::mem::take(&mut mask.slots);
    for pair in mask.rings.windows(2) {
        let arcs = strip_arcs(&pair[0], &pair[1], screen);
        let (ri, ro) = (&pair[0], &pair[1]);
        let (ni, no) = (ri.points_per_turn, ro.points_per_turn);
        std::mem::swap(&mut inner, &mut outer);
        if inner.n != ni || inner.radius != ri.radius_px {
            inner.reset(ri);
        }
        outer.reset(ro);
        let mut strip = Strip {
            inner: &mut inner,
            outer: &mut outer,
            por,
            vertices: &mut vertices,
            cells: &mut cells,
        };
        match arcs {
            ArcSet::Full => strip.walk(0, 0, |i, j| i < i64::from(ni) || j < i64::from(no)),
            ArcSet::Arcs(list) => {
                let (si, so) = (TAU / f64::from(ni), TAU / f64::from(no));
                for &(a, b) in list.as_slice() {
                    let i0 = (a / si).floor() as i64;
                    let j0 = (a / so).floor() as i64;
                    strip.walk(i0, j0, |i, j| (i as f64) * si < b || (j as f64) * so < b);
                }
            }
        }
    }
    mask.vertices = vertices;
    mask.cells = cells;
    mask.slots = [inner, outer];
}

/// The angles over which the strip between two rings can touch the screen,
/// widened so that cells reaching in to the inner ring's chords and out by
/// one step on either side are included.
fn strip_arcs(ri: &Ring, ro: &Ring, screen: &ScreenFromPor) -> ArcSet {
    let step_max = TAU / f64::from(ri.points_per_turn.min(ro.points_per_turn));
    let inset = ri.radius_px * (PI / f64::from(ri.points_per_turn)).cos();
    if ro.radius_px < screen.min_distance_px || inset > screen.max_distance_px {
        return ArcSet::EMPTY;
    }
    screen
        .visible_arcs(inset.max(screen.min_distance_px))
        .expanded(1.5 * step_max, 2.5 * step_max)
}

struct Strip<'a> {
    inner: &'a mut RingSlots,
    outer: &'a mut RingSlots,
    por: [f64; 2],
    vertices: &'a mut Vec<[f32; 2]>,
    cells: &'a mut Vec<[u32; 4]>,
}

impl Strip<'_> {
    /// Stitches the two rings from indices (i, j) while `go(i, j)` holds: a
    /// quad where the next angles coincide, else a triangle advancing the
    /// ring whose next point comes first. Angles are compared exactly, in
    /// integers: `(i+1)/n_inner` against `(j+1)/n_outer`.
    fn walk(&mut self, mut i: i64, mut j: i64, go: impl Fn(i64, i64) -> bool) {
        let (ni, no) = (i64::from(self.inner.n), i64::from(self.outer.n));
        let por = self.por;
        // Reduced indices, advanced alongside i and j without a division.
        let (ni_u, no_u) = (ni as usize, no as usize);
        let mut iw = i.rem_euclid(ni) as usize;
        let mut jw = j.rem_euclid(no) as usize;
        let wrap = |k: usize, n: usize| if k + 1 == n { 0 } else { k + 1 };
        // The current inner (a) and outer (d) corners carry over from one
        // cell to the next; only the advancing corner is looked up.
        let mut a = self.inner.vertex(iw, por, self.vertices);
        let mut d = self.outer.vertex(jw, por, self.vertices);
        while go(i, j) {
            let next_inner = (i + 1) * no;
            let next_outer = (j + 1) * ni;
            if next_inner <= next_outer {
                iw = wrap(iw, ni_u);
                i += 1;
                let b = self.inner.vertex(iw, por, self.vertices);
                if next_inner == next_outer {
                    jw = wrap(jw, no_u);
                    j += 1;
                    let c = self.outer.vertex(jw, por, self.vertices);
                    self.cells.push([a, b, c, d]);
                    d = c;
                } else {
                    self.cells.push([a, b, d, NO_VERTEX]);
                }
                a = b;
            } else {
                jw = wrap(jw, no_u);
                j += 1;
                let c = self.outer.vertex(jw, por, self.vertices);
                self.cells.push([a, c, d, NO_VERTEX]);
                d = c;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ring(n: u32) -> Ring {
        Ring {
            radius_px: 10.0,
            points_per_turn: n,
            radial_step_px: 1.0,
            tightest: Spacing {
                spacing_px: 1.0,
                eccentricity_deg: 0.0,
                ppd: 1.0,
            },
        }
    }

    #[test]
    fn point_zero_of_a_ring_is_at_angle_zero_whatever_came_before() {
        let mut s = RingSlots::new();
        let mut v = Vec::new();
        for (n, r) in [(16, 10.0), (32, 20.0), (16, 30.0)] {
            let mut ring = ring(n);
            ring.radius_px = r;
            s.reset(&ring);
            let a = s.vertex(0, [100.0, 50.0], &mut v) as usize;
            let b = s.vertex(1, [100.0, 50.0], &mut v) as usize;
            assert_eq!(v[a], [(100.0 + r) as f32, 50.0], "ring of {n} at {r}");
            let step = TAU / f64::from(n);
            let want = [100.0 + r * step.cos(), 50.0 + r * step.sin()].map(|x| x as f32);
            assert!((v[b][0] - want[0]).abs() < 1e-4 && (v[b][1] - want[1]).abs() < 1e-4);
        }
    }

    #[test]
    fn ring_slots_forget_old_ids_when_the_generation_wraps() {
        let mut s = RingSlots::new();
        let mut vertices = Vec::new();
        s.reset(&ring(16));
        let a = s.vertex(3, [0.0, 0.0], &mut vertices);
        assert_eq!(s.lookup(3), Some(a));
        // The last generation the upper 32 bits hold, then one more reset.
        s.generation = u64::from(u32::MAX) - 1;
        s.reset(&ring(16));
        assert_eq!(s.lookup(3), None);
        let b = s.vertex(3, [0.0, 0.0], &mut vertices);
        assert_eq!(s.lookup(3), Some(b));
        s.reset(&ring(16));
        assert_eq!(s.generation, 1, "wrapped");
        assert_eq!(s.lookup(3), None, "an id from before the wrap");
        let c = s.vertex(3, [0.0, 0.0], &mut vertices);
        assert_ne!(c, b);
        assert_eq!(s.lookup(3), Some(c));
    }
}
