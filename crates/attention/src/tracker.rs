//! The attention tracker: one frame in, object attention out (Lee Fig. 3.1,
//! steps 1–6).

use std::collections::HashMap;

use rayon::prelude::*;

use crate::config::AttentionConfig;
use crate::context::{spatial_context, TemporalContext};
use crate::contrast::{combine, contrast_weight, CentreSurround};
use crate::error::AttentionError;
use crate::frame::{CameraMotion, FrameView, ObjectInfo, BACKGROUND_ID};
use crate::hls::{hue_vector_angle_deg, lightness_and_hue_vector};
use crate::kalman::ScalarKalman;
use crate::measure::{footprints, FrameMeasure, ObjectIndex, ObjectMeasure};
use crate::pyramid::Pyramid;

/// The five bottom-up features (Lee §3.1.1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Feature {
    /// `B_l`: HLS lightness.
    Luminance,
    /// `B_h`: HLS hue (a chroma-weighted hue vector).
    Hue,
    /// `B_d`: normalised depth, eq. 3.1.
    Depth,
    /// `B_s`: object size, eq. 3.2.
    Size,
    /// `B_m`: object motion, eq. 3.3.
    Motion,
}

impl Feature {
    /// All five, in the order of [`SaliencyMaps::weights`].
    pub const ALL: [Feature; 5] = [
        Feature::Luminance,
        Feature::Hue,
        Feature::Depth,
        Feature::Size,
        Feature::Motion,
    ];

    fn index(self) -> usize {
        self as usize
    }
}

/// Pyramid channels: lightness, hue vector x, hue vector y, depth, size, motion.
const CH_L: usize = 0;
const CH_HX: usize = 1;
const CH_HY: usize = 2;
const CH_D: usize = 3;
const CH_S: usize = 4;
const CH_M: usize = 5;
const CHANNELS: usize = 6;

const NO_OBJECT: u32 = ObjectIndex::UNLISTED;
/// Row blocks of the per-pixel passes; fixed so that sums do not depend on
/// the thread count.
const PIXEL_BLOCKS: usize = 32;

/// One object's result for a frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObjectAttention {
    /// The object's id.
    pub id: u32,
    /// Smoothed attention (Kalman-filtered `S_o`), [0, 1]. The ranking's key.
    pub attention: f32,
    /// `S_o` of this frame before smoothing (eq. 3.8), [0, 1].
    pub raw_attention: f32,
    /// `Ŝ_o`, eq. 3.7: importance times mean pixel saliency, [0, 1].
    pub object_saliency: f32,
    /// `T_s`, eq. 3.9, [0, 0.5] (computed even when switched off).
    pub spatial_context: f32,
    /// `T_t`, eq. 3.10, [0, 0.5].
    pub temporal_context: f32,
    /// Pixels of the object in the frame.
    pub pixel_count: u64,
    /// Mean eye distance of its pixels with a finite depth, mm (`x` of
    /// eq. 3.9; `depth_far_mm` if none has one).
    pub distance_mm: f32,
    /// Centroid of its pixels, frame pixels (x right, y down, pixel centres
    /// at +0.5).
    pub screen_centre_px: [f32; 2],
    /// Saliency peak on the object, frame pixels: the centroid of the
    /// object's pixels inside the saliency map cell with the highest `S_p`
    /// (ties: the lowest cell index). The centroid when the map is flat.
    pub peak_px: [f32; 2],
}

/// One frame's result.
#[derive(Clone, Debug, PartialEq)]
pub struct Attention {
    /// Visible listed objects with importance > 0, highest smoothed
    /// attention first; equal attention: lower id first.
    pub ranking: Vec<ObjectAttention>,
    /// The first of `ranking` if its attention reaches the configured
    /// threshold; `None` otherwise (e.g. an empty frame).
    pub attended: Option<u32>,
    /// The attended object's saliency peak, frame pixels: a gaze point.
    pub gaze_px: Option<[f32; 2]>,
    /// False when no bottom-up feature carried any contrast (or all were
    /// switched off); pixel saliency was then 1 everywhere.
    pub bottom_up_informative: bool,
    /// Pixels with the background id.
    pub background_pixels: u64,
    /// Pixels with an id missing from the object list (treated as background).
    pub unlisted_pixels: u64,
}

impl Attention {
    /// The ranking's ids, best first (for [`crate::eval::top_k_hit`]).
    pub fn ranking_ids(&self) -> Vec<u32> {
        self.ranking.iter().map(|o| o.id).collect()
    }

    /// The entry of object `id`, if ranked.
    pub fn get(&self, id: u32) -> Option<&ObjectAttention> {
        self.ranking.iter().find(|o| o.id == id)
    }
}

/// Read-only view of the last frame's maps, for debug pictures. Every map
/// is `size × size`, row-major, values in [0, 1] (hue vector components in
/// [−1, 1]). Maps of switched-off features are 0.
pub struct SaliencyMaps<'a> {
    tracker: &'a AttentionTracker,
}

impl<'a> SaliencyMaps<'a> {
    /// The map side.
    pub fn size(&self) -> usize {
        self.tracker.map_size()
    }

    /// Level 0 of a scalar feature; `None` for [`Feature::Hue`] (see
    /// [`SaliencyMaps::hue_vector`]).
    pub fn feature(&self, feature: Feature) -> Option<&'a [f32]> {
        let ch = match feature {
            Feature::Luminance => CH_L,
            Feature::Hue => return None,
            Feature::Depth => CH_D,
            Feature::Size => CH_S,
            Feature::Motion => CH_M,
        };
        Some(self.tracker.pyramids[ch].level(0).data)
    }

    /// The chroma-weighted hue vector at level 0, `(C cos h, C sin h)`.
    pub fn hue_vector(&self) -> (&'a [f32], &'a [f32]) {
        (
            self.tracker.pyramids[CH_HX].level(0).data,
            self.tracker.pyramids[CH_HY].level(0).data,
        )
    }

    /// Hue in degrees at level 0 (allocates).
    pub fn hue_angle_deg(&self) -> Vec<f32> {
        let (x, y) = self.hue_vector();
        x.iter()
            .zip(y)
            .map(|(&x, &y)| hue_vector_angle_deg([x, y]))
            .collect()
    }

    /// The pyramid of a scalar feature; `None` for hue.
    pub fn pyramid(&self, feature: Feature) -> Option<&'a Pyramid> {
        let ch = match feature {
            Feature::Luminance => CH_L,
            Feature::Hue => return None,
            Feature::Depth => CH_D,
            Feature::Size => CH_S,
            Feature::Motion => CH_M,
        };
        Some(&self.tracker.pyramids[ch])
    }

    /// The pyramids of the hue vector's two components.
    pub fn hue_pyramids(&self) -> (&'a Pyramid, &'a Pyramid) {
        (&self.tracker.pyramids[CH_HX], &self.tracker.pyramids[CH_HY])
    }

    /// `C_f`, eq. 3.4.
    pub fn contrast(&self, feature: Feature) -> &'a [f32] {
        &self.tracker.contrast[feature.index()]
    }

    /// `w_f`, eq. 3.6, in [`Feature::ALL`] order (0 for off or flat features).
    pub fn weights(&self) -> [f32; 5] {
        self.tracker.weights
    }

    /// `S_p`, [0, 1].
    pub fn pixel_saliency(&self) -> &'a [f32] {
        &self.tracker.saliency
    }
}

/// Per-object state kept across frames.
#[derive(Clone, Debug)]
struct ObjectState {
    temporal: TemporalContext,
    kalman: Option<ScalarKalman>,
    last_distance_mm: Option<f32>,
    listed_in_frame: u64,
}

/// Per-pixel accumulators of pass A (object statistics).
#[derive(Clone, Copy, Debug, Default)]
struct PixelStats {
    count: u64,
    depth_sum_mm: f64,
    depth_count: u64,
    sum_x: u64,
    sum_y: u64,
}

/// Per-pixel accumulators of pass C (object saliency and peak).
#[derive(Clone, Copy, Debug)]
struct SaliencyStats {
    sum: f64,
    best: f32,
    best_cell: u32,
    best_sum_x: u64,
    best_sum_y: u64,
    best_count: u64,
}

impl Default for SaliencyStats {
    fn default() -> Self {
        Self {
            sum: 0.0,
            best: -1.0,
            best_cell: u32::MAX,
            best_sum_x: 0,
            best_sum_y: 0,
            best_count: 0,
        }
    }
}

impl SaliencyStats {
    /// A run of `count` pixels of one object in one map cell; `sum_x`,
    /// `sum_y` are the sums of their coordinates.
    #[inline]
    fn add_run(&mut self, value: f32, cell: u32, count: u64, sum_x: u64, sum_y: u64) {
        self.sum += f64::from(value) * count as f64;
        if value > self.best || (value == self.best && cell < self.best_cell) {
            self.best = value;
            self.best_cell = cell;
            self.best_sum_x = 0;
            self.best_sum_y = 0;
            self.best_count = 0;
        }
        if cell == self.best_cell {
            self.best_sum_x += sum_x;
            self.best_sum_y += sum_y;
            self.best_count += count;
        }
    }

    fn merge(&mut self, other: &Self) {
        self.sum += other.sum;
        if other.best_count == 0 {
            return;
        }
        if other.best > self.best || (other.best == self.best && other.best_cell < self.best_cell) {
            let sum = self.sum;
            *self = *other;
            self.sum = sum;
        } else if other.best == self.best && other.best_cell == self.best_cell {
            self.best_sum_x += other.best_sum_x;
            self.best_sum_y += other.best_sum_y;
            self.best_count += other.best_count;
        }
    }
}

#[derive(Clone, Debug, Default)]
struct PixelBlock {
    stats: Vec<PixelStats>,
    saliency: Vec<SaliencyStats>,
    cell_objects: Vec<CellObject>,
    row_sums: Vec<CellSums>,
    row_objects: Vec<Vec<CellObject>>,
    background: u64,
    unlisted: u64,
}

/// Area sums of one map cell in the fused pass.
#[derive(Clone, Copy, Debug, Default)]
struct CellSums {
    red: u64,
    green: u64,
    blue: u64,
    depth: f64,
    speed: f64,
}

/// The pixels of one object inside one map cell (the fused pass's record,
/// from which `B_s` and the object saliency of eq. 3.7 are finished without
/// reading the frame again). Coordinates relative to the cell's footprint.
#[derive(Clone, Copy, Debug, Default)]
struct CellObject {
    cell: u32,
    object: u32,
    count: u32,
    sum_dx: u32,
    sum_dy: u32,
}

/// Remembers the last lookup: ids come in long runs along a row.
struct RunCache<'a> {
    lookup: &'a ObjectIndex,
    id: u32,
    dense: u32,
}

impl<'a> RunCache<'a> {
    fn new(lookup: &'a ObjectIndex) -> Self {
        Self {
            lookup,
            id: BACKGROUND_ID,
            dense: NO_OBJECT,
        }
    }

    #[inline]
    fn get(&mut self, id: u32) -> u32 {
        if id != self.id {
            self.id = id;
            self.dense = if id == BACKGROUND_ID {
                NO_OBJECT
            } else {
                self.lookup.dense_of(id)
            };
        }
        self.dense
    }
}

/// Frame ↔ map correspondence: each map cell's footprint in the frame
/// (area average) and each frame pixel's cell (nearest).
#[derive(Clone, Debug, Default)]
struct CellGrid {
    key: (u32, u32, u32),
    x0: Vec<u32>,
    x1: Vec<u32>,
    y0: Vec<u32>,
    y1: Vec<u32>,
    cell_of_x: Vec<u32>,
    cell_of_y: Vec<u32>,
}

impl CellGrid {
    fn prepare(&mut self, width: u32, height: u32, map: u32) {
        if self.key == (width, height, map) {
            return;
        }
        footprints(width, map, &mut self.x0, &mut self.x1, &mut self.cell_of_x);
        footprints(height, map, &mut self.y0, &mut self.y1, &mut self.cell_of_y);
        self.key = (width, height, map);
    }
}

/// Per-object values derived this frame, in dense (id) order.
#[derive(Clone, Copy, Debug, Default)]
struct FrameObject {
    source: usize,
    importance: f32,
    speed: f32,
    size: f32,
    motion: f32,
}

/// Tracks object attention across frames (Lee ch. 3). Holds every buffer
/// between frames; `update` allocates only its result (and grows buffers
/// when objects are added).
///
/// Work runs on the current rayon pool: call `update` inside
/// `ThreadPool::install` to choose the thread count.
pub struct AttentionTracker {
    config: AttentionConfig,
    frame_index: u64,
    states: HashMap<u32, ObjectState>,
    index: ObjectIndex,
    /// This frame's measured statistics per object, dense order.
    measures: Vec<ObjectMeasure>,
    objects: Vec<FrameObject>,
    blocks: Vec<PixelBlock>,
    grid: CellGrid,
    cells: Vec<[f32; CHANNELS]>,
    pyramids: [Pyramid; CHANNELS],
    contrast: [Vec<f32>; 5],
    weights: [f32; 5],
    saliency: Vec<f32>,
    centre_surround: CentreSurround,
}

impl AttentionTracker {
    /// A tracker for `config` (checked: map size, depth range, constants).
    pub fn new(config: AttentionConfig) -> Result<Self, AttentionError> {
        config.validate()?;
        let m = config.map_size as usize;
        let mut pyramids: [Pyramid; CHANNELS] = Default::default();
        for p in pyramids.iter_mut() {
            p.base_mut(m, m).fill(0.0);
            p.rebuild();
        }
        Ok(Self {
            config,
            frame_index: 0,
            states: HashMap::new(),
            index: ObjectIndex::default(),
            measures: Vec::new(),
            objects: Vec::new(),
            blocks: vec![PixelBlock::default(); PIXEL_BLOCKS],
            grid: CellGrid::default(),
            cells: vec![[0.0; CHANNELS]; m * m],
            pyramids,
            contrast: std::array::from_fn(|_| vec![0.0; m * m]),
            weights: [0.0; 5],
            saliency: vec![1.0; m * m],
            centre_surround: CentreSurround::new(),
        })
    }

    /// The configuration in use.
    pub fn config(&self) -> &AttentionConfig {
        &self.config
    }

    /// The saliency map side.
    pub fn map_size(&self) -> usize {
        self.config.map_size as usize
    }

    /// The last frame's maps.
    pub fn maps(&self) -> SaliencyMaps<'_> {
        SaliencyMaps { tracker: self }
    }

    /// The smoothed attention of any object listed in the last frame,
    /// visible or not.
    pub fn smoothed_attention(&self, id: u32) -> Option<f32> {
        let state = self.states.get(&id)?;
        state.kalman.map(|k| k.value().clamp(0.0, 1.0) as f32)
    }

    /// Forgets every object's history (temporal context, filter).
    pub fn reset(&mut self) {
        self.states.clear();
    }

    /// Processes one frame. `objects` lists every object that may appear
    /// (listed but invisible objects keep their history; unlisted ids are
    /// background). `dt_s` is the time since the previous frame, for the
    /// filter. Errors leave the tracker's history unchanged.
    pub fn update(
        &mut self,
        frame: &FrameView,
        objects: &[ObjectInfo],
        camera: CameraMotion,
        dt_s: f64,
    ) -> Result<Attention, AttentionError> {
        self.update_with(frame, objects, camera, dt_s, true)
    }

    /// `update`, optionally without the fused pass (to test that both
    /// paths agree).
    fn update_with(
        &mut self,
        frame: &FrameView,
        objects: &[ObjectInfo],
        camera: CameraMotion,
        dt_s: f64,
        allow_fused: bool,
    ) -> Result<Attention, AttentionError> {
        if !(dt_s.is_finite() && dt_s >= 0.0) {
            frame.validate()?;
            return Err(AttentionError::InvalidTimeStep(dt_s));
        }
        let (informative, background, unlisted) = self.measure_with(frame, objects, allow_fused)?;
        self.frame_index += 1;
        Ok(self.finish(
            objects,
            camera,
            dt_s,
            (frame.width, frame.height),
            informative,
            (background, unlisted),
        ))
    }

    /// The per-pixel and per-map part of a frame on the CPU (Lee Fig. 3.1
    /// steps 1–6): the maps ([`AttentionTracker::maps`]) and the per-object
    /// statistics, in the order of `objects`. Touches no history;
    /// [`AttentionTracker::update_measured`] with the result is
    /// [`AttentionTracker::update`], bit for bit.
    pub fn measure(
        &mut self,
        frame: &FrameView,
        objects: &[ObjectInfo],
    ) -> Result<FrameMeasure, AttentionError> {
        let (informative, background, unlisted) = self.measure_with(frame, objects, true)?;
        let mut records = vec![ObjectMeasure::default(); objects.len()];
        for (&source, m) in self.index.sources().iter().zip(&self.measures) {
            records[source] = *m;
        }
        Ok(FrameMeasure {
            width: frame.width,
            height: frame.height,
            objects: records,
            background_pixels: background,
            unlisted_pixels: unlisted,
            bottom_up_informative: informative,
        })
    }

    /// Fills the maps and `self.measures` (dense order); returns whether
    /// `S_p` is informative and the background and unlisted pixel counts.
    fn measure_with(
        &mut self,
        frame: &FrameView,
        objects: &[ObjectInfo],
        allow_fused: bool,
    ) -> Result<(bool, u64, u64), AttentionError> {
        let total_pixels = frame.validate()?;
        self.index_objects(objects)?;
        let features = self.config.features;
        let n = self.objects.len();

        // When the map cells partition the frame (the frame is at least as
        // large as the map), one fused pass reads every buffer once; else
        // three passes (statistics, cell averages, object saliency).
        let m = self.config.map_size;
        self.grid.prepare(frame.width, frame.height, m);
        let fused = allow_fused && frame.width >= m && frame.height >= m;
        if fused {
            self.fused_pass(frame);
        } else {
            self.object_statistics(frame);
        }
        let mut stats = vec![PixelStats::default(); n];
        let (mut background, mut unlisted) = (0u64, 0u64);
        for block in &self.blocks {
            background += block.background;
            unlisted += block.unlisted;
            for (s, b) in stats.iter_mut().zip(&block.stats) {
                s.count += b.count;
                s.depth_sum_mm += b.depth_sum_mm;
                s.depth_count += b.depth_count;
                s.sum_x += b.sum_x;
                s.sum_y += b.sum_y;
            }
        }

        // Object features: B_s (eq. 3.2) and B_m (eq. 3.3) normalised by the
        // fastest visible object.
        let mut max_speed = 0.0f32;
        for (d, o) in self.objects.iter().enumerate() {
            if stats[d].count > 0 {
                max_speed = max_speed.max(o.speed);
            }
        }
        for (d, o) in self.objects.iter_mut().enumerate() {
            o.size = (stats[d].count as f64 / total_pixels as f64) as f32;
            o.motion = if max_speed > 0.0 && stats[d].count > 0 {
                (o.speed / max_speed).min(1.0)
            } else {
                0.0
            };
        }

        // Bottom-up saliency (eq. 3.1–3.6).
        let informative = if features.any_bottom_up() {
            if fused {
                self.finish_fused_cells(max_speed);
            } else {
                self.area_average_cells(frame);
            }
            self.build_pyramids();
            self.contrast_maps();
            let contrasts: Vec<(&[f32], f32)> = self
                .contrast
                .iter()
                .zip(self.weights)
                .map(|(c, w)| (c.as_slice(), w))
                .collect();
            combine(&contrasts, &mut self.saliency)
        } else {
            self.weights = [0.0; 5];
            self.saliency.fill(1.0);
            false
        };

        // Mean pixel saliency and peak per object (eq. 3.7).
        let mut saliency_stats = vec![SaliencyStats::default(); n];
        if informative && fused {
            let grid = &self.grid;
            for block in &self.blocks {
                for co in &block.cell_objects {
                    let (cx, cy) = ((co.cell % m) as usize, (co.cell / m) as usize);
                    let count = u64::from(co.count);
                    saliency_stats[co.object as usize].add_run(
                        self.saliency[co.cell as usize],
                        co.cell,
                        count,
                        u64::from(co.sum_dx) + count * u64::from(grid.x0[cx]),
                        u64::from(co.sum_dy) + count * u64::from(grid.y0[cy]),
                    );
                }
            }
        } else if informative {
            self.object_saliency(frame);
            for block in &self.blocks {
                for (s, b) in saliency_stats.iter_mut().zip(&block.saliency) {
                    s.merge(b);
                }
            }
        }

        self.measures.clear();
        self.measures.extend(
            stats
                .iter()
                .zip(&saliency_stats)
                .map(|(st, ss)| ObjectMeasure {
                    pixel_count: st.count,
                    depth_sum_mm: st.depth_sum_mm,
                    depth_count: st.depth_count,
                    sum_x: st.sum_x,
                    sum_y: st.sum_y,
                    saliency_sum: ss.sum,
                    peak_saliency: ss.best,
                    peak_cell: ss.best_cell,
                    peak_count: ss.best_count,
                    peak_sum_x: ss.best_sum_x,
                    peak_sum_y: ss.best_sum_y,
                }),
        );
        Ok((informative, background, unlisted))
    }

    /// Finishes a frame whose per-pixel and per-map part ran elsewhere (a
    /// GPU): the same contexts (eq. 3.9, 3.10), final attention (3.8),
    /// Kalman smoothing, ranking and threshold as [`AttentionTracker::update`],
    /// from `measure`'s per-object statistics (one record per entry of
    /// `objects`, in its order). `measure` is checked first
    /// ([`FrameMeasure::validate`]); errors leave the history unchanged.
    ///
    /// The tracker's own maps ([`AttentionTracker::maps`]) are not touched:
    /// they keep the last CPU frame's.
    pub fn update_measured(
        &mut self,
        measure: &FrameMeasure,
        objects: &[ObjectInfo],
        camera: CameraMotion,
        dt_s: f64,
    ) -> Result<Attention, AttentionError> {
        measure.validate(objects.len(), self.config.map_size)?;
        if !(dt_s.is_finite() && dt_s >= 0.0) {
            return Err(AttentionError::InvalidTimeStep(dt_s));
        }
        self.index_objects(objects)?;
        self.frame_index += 1;
        self.measures.clear();
        let index = &self.index;
        self.measures.extend(
            index
                .sources()
                .iter()
                .map(|&source| measure.objects[source]),
        );
        let informative = measure.bottom_up_informative && self.config.features.any_bottom_up();
        Ok(self.finish(
            objects,
            camera,
            dt_s,
            (measure.width, measure.height),
            informative,
            (measure.background_pixels, measure.unlisted_pixels),
        ))
    }

    /// Top-down modulation, smoothing, ranking (eq. 3.7–3.10) from
    /// `self.measures` (dense order): the one place a frame is finished.
    fn finish(
        &mut self,
        objects: &[ObjectInfo],
        camera: CameraMotion,
        dt_s: f64,
        (width, height): (u32, u32),
        informative: bool,
        (background, unlisted): (u64, u64),
    ) -> Attention {
        let features = self.config.features;
        let (w, h) = (f64::from(width), f64::from(height));
        let half_diagonal = 0.5 * (w * w + h * h).sqrt();
        let moving_forward = camera.moving_forward();
        let cfg = self.config;
        let mut ranking = Vec::new();
        for (o, st) in self.objects.iter().zip(&self.measures) {
            let info = &objects[o.source];
            let visible = st.pixel_count > 0;
            let state = self.states.entry(info.id).or_insert_with(|| ObjectState {
                temporal: TemporalContext::new(cfg.temporal_window_frames as usize),
                kalman: None,
                last_distance_mm: None,
                listed_in_frame: 0,
            });
            state.listed_in_frame = self.frame_index;
            let count = st.pixel_count.max(1) as f64;
            let centre = [
                (st.sum_x as f64 / count + 0.5) as f32,
                (st.sum_y as f64 / count + 0.5) as f32,
            ];
            let distance_mm = if st.depth_count > 0 {
                (st.depth_sum_mm / st.depth_count as f64) as f32
            } else {
                cfg.depth_far_mm
            };
            let spatial = if visible {
                let dx = f64::from(centre[0]) - 0.5 * w;
                let dy = f64::from(centre[1]) - 0.5 * h;
                let offset = ((dx * dx + dy * dy).sqrt() / half_diagonal.max(1e-9)) as f32;
                let receding = state
                    .last_distance_mm
                    .is_some_and(|last| distance_mm > last);
                spatial_context(&cfg.spatial, distance_mm, offset, receding, moving_forward)
            } else {
                0.0
            };
            let temporal = state.temporal.push(spatial);
            state.last_distance_mm = visible.then_some(distance_mm);

            let (mean_saliency, peak) = if !visible {
                (0.0, centre)
            } else if informative && st.peak_count > 0 {
                let bc = st.peak_count as f64;
                (
                    (st.saliency_sum / st.pixel_count as f64).clamp(0.0, 1.0) as f32,
                    [
                        (st.peak_sum_x as f64 / bc + 0.5) as f32,
                        (st.peak_sum_y as f64 / bc + 0.5) as f32,
                    ],
                )
            } else {
                (1.0, centre)
            };
            let object_saliency = o.importance * mean_saliency;
            let modulation = if features.any_context() {
                let s = if features.spatial_context {
                    spatial
                } else {
                    0.0
                };
                let t = if features.temporal_context {
                    temporal
                } else {
                    0.0
                };
                s + t
            } else {
                1.0
            };
            let raw = (modulation * object_saliency).clamp(0.0, 1.0);
            let smoothed = match &mut state.kalman {
                Some(k) => k.step(raw, dt_s, &cfg.kalman),
                None => {
                    let k = ScalarKalman::new(raw, &cfg.kalman);
                    let v = k.value();
                    state.kalman = Some(k);
                    v
                }
            };
            let attention = smoothed.clamp(0.0, 1.0) as f32;
            if visible && o.importance > 0.0 {
                ranking.push(ObjectAttention {
                    id: info.id,
                    attention,
                    raw_attention: raw,
                    object_saliency,
                    spatial_context: spatial,
                    temporal_context: temporal,
                    pixel_count: st.pixel_count,
                    distance_mm,
                    screen_centre_px: centre,
                    peak_px: peak,
                });
            }
        }
        let frame_index = self.frame_index;
        self.states.retain(|_, s| s.listed_in_frame == frame_index);

        ranking.sort_by(|a, b| b.attention.total_cmp(&a.attention).then(a.id.cmp(&b.id)));
        let attended = ranking
            .first()
            .filter(|o| o.attention >= cfg.attention_threshold);
        Attention {
            attended: attended.map(|o| o.id),
            gaze_px: attended.map(|o| o.peak_px),
            ranking,
            bottom_up_informative: informative,
            background_pixels: background,
            unlisted_pixels: unlisted,
        }
    }

    /// Sorts the object list by id into dense indices; rejects duplicates,
    /// the background id and overlong lists. Touches no history.
    fn index_objects(&mut self, objects: &[ObjectInfo]) -> Result<(), AttentionError> {
        self.index.rebuild(objects)?;
        self.objects.clear();
        self.objects
            .extend(self.index.sources().iter().map(|&i| FrameObject {
                source: i,
                importance: objects[i].importance_used(),
                speed: objects[i].speed_used(),
                size: 0.0,
                motion: 0.0,
            }));
        let n = objects.len();
        for block in &mut self.blocks {
            block.stats.clear();
            block.stats.resize(n, PixelStats::default());
            block.saliency.clear();
            block.saliency.resize(n, SaliencyStats::default());
            block.cell_objects.clear();
            block.background = 0;
            block.unlisted = 0;
        }
        Ok(())
    }

    /// The fused pass (cells partition the frame): per map cell, the
    /// area sums of colour and `B_d`, the motion sum, and per object the
    /// statistics of pass A and its pixels in the cell ([`CellObject`]).
    fn fused_pass(&mut self, frame: &FrameView) {
        let f = self.config.features;
        let m = self.config.map_size as usize;
        let grid = &self.grid;
        let lookup = &self.index;
        let objects = &self.objects;
        let w = frame.width as usize;
        let near = self.config.depth_near_mm;
        let inv_range = 1.0 / (self.config.depth_far_mm - near);
        let (colour, depth) = (f.luminance || f.hue, f.depth);
        let bottom_up = f.any_bottom_up();
        let rows_per_block = m.div_ceil(self.blocks.len());
        let cells = self.cells.par_chunks_mut(rows_per_block * m);
        cells
            .zip(self.blocks.par_iter_mut())
            .enumerate()
            .for_each(|(b, (cells, block))| {
                let mut cache = RunCache::new(lookup);
                block.row_sums.resize(m, CellSums::default());
                block.row_objects.resize_with(m, Vec::new);
                for (r, cell_row) in cells.chunks_mut(m).enumerate() {
                    let my = b * rows_per_block + r;
                    let (y0, y1) = (grid.y0[my] as usize, grid.y1[my] as usize);
                    block.row_sums.fill(CellSums::default());
                    block.row_objects.iter_mut().for_each(Vec::clear);
                    // Frame rows in order, cells along each row: sequential reads.
                    for y in y0..y1 {
                        let row = y * w;
                        if colour || depth {
                            for mx in 0..m {
                                let (x0, x1) = (grid.x0[mx] as usize, grid.x1[mx] as usize);
                                let sums = &mut block.row_sums[mx];
                                if colour {
                                    let (mut r, mut g, mut b) = (0u32, 0u32, 0u32);
                                    for px in
                                        frame.rgb[(row + x0) * 3..(row + x1) * 3].chunks_exact(3)
                                    {
                                        r += u32::from(px[0]);
                                        g += u32::from(px[1]);
                                        b += u32::from(px[2]);
                                    }
                                    sums.red += u64::from(r);
                                    sums.green += u64::from(g);
                                    sums.blue += u64::from(b);
                                }
                                if depth {
                                    // Eq. 3.1; background (non-finite) is the far plane.
                                    let mut span_sum = 0.0f32;
                                    for &z in &frame.depth_mm[row + x0..row + x1] {
                                        span_sum += if z.is_finite() {
                                            ((z - near) * inv_range).clamp(0.0, 1.0)
                                        } else {
                                            1.0
                                        };
                                    }
                                    sums.depth += f64::from(span_sum);
                                }
                            }
                        }
                        // Runs of one id along the whole row, split at cell
                        // boundaries only for the per-cell records.
                        let ids = &frame.object[row..row + w];
                        let zs = &frame.depth_mm[row..row + w];
                        let mut start = 0;
                        while start < w {
                            let end = run_end(ids, start);
                            let len = (end - start) as u64;
                            let id = ids[start];
                            let d = cache.get(id);
                            if id == BACKGROUND_ID {
                                block.background += len;
                            } else if d == NO_OBJECT {
                                block.unlisted += len;
                            } else {
                                let (depth_sum, depth_count) = finite_depth_sum(&zs[start..end]);
                                let s = &mut block.stats[d as usize];
                                s.count += len;
                                s.sum_x += index_sum(start, end);
                                s.sum_y += y as u64 * len;
                                s.depth_sum_mm += depth_sum;
                                s.depth_count += depth_count;
                                let speed = f64::from(objects[d as usize].speed);
                                let mut x = start;
                                while x < end {
                                    let mx = grid.cell_of_x[x] as usize;
                                    let x0 = grid.x0[mx] as usize;
                                    let piece_end = end.min(grid.x1[mx] as usize);
                                    let piece = (piece_end - x) as u64;
                                    block.row_sums[mx].speed += speed * piece as f64;
                                    // Footprints are at most 16384/64 = 256 px a
                                    // side, so the relative sums fit in u32.
                                    let dx = index_sum(x - x0, piece_end - x0) as u32;
                                    let dy = ((y - y0) as u64 * piece) as u32;
                                    let list = &mut block.row_objects[mx];
                                    match list.iter_mut().find(|c| c.object == d) {
                                        Some(c) => {
                                            c.count += piece as u32;
                                            c.sum_dx += dx;
                                            c.sum_dy += dy;
                                        }
                                        None => list.push(CellObject {
                                            cell: (my * m + mx) as u32,
                                            object: d,
                                            count: piece as u32,
                                            sum_dx: dx,
                                            sum_dy: dy,
                                        }),
                                    }
                                    x = piece_end;
                                }
                            }
                            start = end;
                        }
                    }
                    for (mx, cell) in cell_row.iter_mut().enumerate() {
                        block.cell_objects.extend_from_slice(&block.row_objects[mx]);
                        if !bottom_up {
                            continue;
                        }
                        let sums = &block.row_sums[mx];
                        let (x0, x1) = (grid.x0[mx] as usize, grid.x1[mx] as usize);
                        let inv = 1.0 / ((x1 - x0) * (y1 - y0)) as f64;
                        if colour {
                            let k = inv / 255.0;
                            let (l, hv) = lightness_and_hue_vector(
                                (sums.red as f64 * k) as f32,
                                (sums.green as f64 * k) as f32,
                                (sums.blue as f64 * k) as f32,
                            );
                            cell[CH_L] = l;
                            cell[CH_HX] = hv[0];
                            cell[CH_HY] = hv[1];
                        }
                        cell[CH_D] = (sums.depth * inv) as f32;
                        // Finished in `finish_fused_cells` once counts are known.
                        cell[CH_S] = 0.0;
                        cell[CH_M] = (sums.speed * inv) as f32;
                    }
                }
            });
    }

    /// Completes `B_s` and `B_m` in the cells after the fused pass.
    fn finish_fused_cells(&mut self, max_speed: f32) {
        let m = self.config.map_size as usize;
        let grid = &self.grid;
        for block in &self.blocks {
            for co in &block.cell_objects {
                let size = self.objects[co.object as usize].size;
                self.cells[co.cell as usize][CH_S] += size * co.count as f32;
            }
        }
        let inv_speed = if max_speed > 0.0 {
            1.0 / max_speed
        } else {
            0.0
        };
        self.cells
            .par_chunks_mut(m)
            .enumerate()
            .for_each(|(my, row)| {
                let rows = (grid.y1[my] - grid.y0[my]) as f32;
                for (mx, cell) in row.iter_mut().enumerate() {
                    let area = (grid.x1[mx] - grid.x0[mx]) as f32 * rows;
                    cell[CH_S] /= area;
                    cell[CH_M] = (cell[CH_M] * inv_speed).clamp(0.0, 1.0);
                }
            });
    }

    /// Pass A over the frame: pixel count, depth sum and centroid sums per
    /// object.
    fn object_statistics(&mut self, frame: &FrameView) {
        let (w, h) = (frame.width as usize, frame.height as usize);
        let lookup = &self.index;
        let blocks = self.blocks.len();
        self.blocks
            .par_iter_mut()
            .enumerate()
            .for_each(|(b, block)| {
                let mut cache = RunCache::new(lookup);
                for y in (b * h / blocks)..((b + 1) * h / blocks) {
                    let ids = &frame.object[y * w..(y + 1) * w];
                    let depth = &frame.depth_mm[y * w..(y + 1) * w];
                    let mut start = 0;
                    while start < w {
                        let end = run_end(ids, start);
                        let len = (end - start) as u64;
                        let id = ids[start];
                        let d = cache.get(id);
                        if id == BACKGROUND_ID {
                            block.background += len;
                        } else if d == NO_OBJECT {
                            block.unlisted += len;
                        } else {
                            let (depth_sum, depth_count) = finite_depth_sum(&depth[start..end]);
                            let s = &mut block.stats[d as usize];
                            s.count += len;
                            s.sum_x += index_sum(start, end);
                            s.sum_y += y as u64 * len;
                            s.depth_sum_mm += depth_sum;
                            s.depth_count += depth_count;
                        }
                        start = end;
                    }
                }
            });
    }

    /// Pass B (unfused path): area-average the frame into the map cells.
    fn area_average_cells(&mut self, frame: &FrameView) {
        let f = self.config.features;
        let m = self.config.map_size;
        let grid = &self.grid;
        let lookup = &self.index;
        let objects = &self.objects;
        let w = frame.width as usize;
        let near = self.config.depth_near_mm;
        let inv_range = 1.0 / (self.config.depth_far_mm - near);
        let (colour, depth, object) = (f.luminance || f.hue, f.depth, f.size || f.motion);
        self.cells
            .par_chunks_mut(m as usize)
            .enumerate()
            .for_each(|(my, row)| {
                let mut cache = RunCache::new(lookup);
                let (y0, y1) = (grid.y0[my] as usize, grid.y1[my] as usize);
                for (mx, cell) in row.iter_mut().enumerate() {
                    let (x0, x1) = (grid.x0[mx] as usize, grid.x1[mx] as usize);
                    let area = ((x1 - x0) * (y1 - y0)) as f64;
                    let (mut r, mut g, mut b) = (0u64, 0u64, 0u64);
                    let (mut d_sum, mut s_sum, mut m_sum) = (0.0f64, 0.0f64, 0.0f64);
                    for y in y0..y1 {
                        let span = y * w + x0..y * w + x1;
                        if colour {
                            for px in frame.rgb[span.start * 3..span.end * 3].chunks_exact(3) {
                                r += u64::from(px[0]);
                                g += u64::from(px[1]);
                                b += u64::from(px[2]);
                            }
                        }
                        if depth {
                            // Eq. 3.1; background (non-finite) is the far plane.
                            let mut span_sum = 0.0f32;
                            for &z in &frame.depth_mm[span.clone()] {
                                span_sum += if z.is_finite() {
                                    ((z - near) * inv_range).clamp(0.0, 1.0)
                                } else {
                                    1.0
                                };
                            }
                            d_sum += f64::from(span_sum);
                        }
                        if object {
                            let ids = &frame.object[span];
                            let mut start = 0;
                            while start < ids.len() {
                                let end = run_end(ids, start);
                                let d = cache.get(ids[start]);
                                if d != NO_OBJECT {
                                    let o = &objects[d as usize];
                                    let len = (end - start) as f64;
                                    s_sum += f64::from(o.size) * len;
                                    m_sum += f64::from(o.motion) * len;
                                }
                                start = end;
                            }
                        }
                    }
                    let inv = 1.0 / area;
                    if colour {
                        let k = inv / 255.0;
                        let (l, hv) = lightness_and_hue_vector(
                            (r as f64 * k) as f32,
                            (g as f64 * k) as f32,
                            (b as f64 * k) as f32,
                        );
                        cell[CH_L] = l;
                        cell[CH_HX] = hv[0];
                        cell[CH_HY] = hv[1];
                    }
                    cell[CH_D] = (d_sum * inv) as f32;
                    cell[CH_S] = (s_sum * inv) as f32;
                    cell[CH_M] = (m_sum * inv) as f32;
                }
            });
    }

    /// The pyramids of every enabled channel from the cells (Lee §3.1.1).
    fn build_pyramids(&mut self) {
        let m = self.config.map_size;
        let enabled = channel_flags(&self.config);
        let side = m as usize;
        let cells = &self.cells;
        self.pyramids
            .par_iter_mut()
            .enumerate()
            .for_each(|(ch, pyramid)| {
                let base = pyramid.base_mut(side, side);
                if enabled[ch] {
                    for (b, c) in base.iter_mut().zip(cells) {
                        *b = c[ch];
                    }
                } else {
                    base.fill(0.0);
                }
                pyramid.rebuild();
            });
    }

    /// Eq. 3.4 per enabled feature, and the weights of eq. 3.6.
    fn contrast_maps(&mut self) {
        let on = self.config.features.as_array();
        for (i, feature) in Feature::ALL.iter().enumerate() {
            let out = &mut self.contrast[i];
            if !on[i] {
                out.fill(0.0);
                self.weights[i] = 0.0;
                continue;
            }
            match feature {
                Feature::Hue => {
                    let (px, py) = (&self.pyramids[CH_HX], &self.pyramids[CH_HY]);
                    self.centre_surround.hue(px, py, out);
                }
                _ => {
                    let ch = match feature {
                        Feature::Luminance => CH_L,
                        Feature::Depth => CH_D,
                        Feature::Size => CH_S,
                        _ => CH_M,
                    };
                    self.centre_surround.scalar(&self.pyramids[ch], out);
                }
            }
            self.weights[i] = contrast_weight(out);
        }
    }

    /// Pass C over the frame: sum of `S_p` and the peak cell per object.
    fn object_saliency(&mut self, frame: &FrameView) {
        let (w, h) = (frame.width as usize, frame.height as usize);
        let m = self.config.map_size;
        let lookup = &self.index;
        let grid = &self.grid;
        let saliency = &self.saliency;
        let blocks = self.blocks.len();
        self.blocks
            .par_iter_mut()
            .enumerate()
            .for_each(|(b, block)| {
                let mut cache = RunCache::new(lookup);
                for y in (b * h / blocks)..((b + 1) * h / blocks) {
                    let ids = &frame.object[y * w..(y + 1) * w];
                    let row_cell = grid.cell_of_y[y] * m;
                    let mut start = 0;
                    while start < w {
                        // A run: one object, one map cell.
                        let (id, cx) = (ids[start], grid.cell_of_x[start]);
                        let mut end = start + 1;
                        while end < w && ids[end] == id && grid.cell_of_x[end] == cx {
                            end += 1;
                        }
                        let d = cache.get(id);
                        if d != NO_OBJECT {
                            let cell = row_cell + cx;
                            let len = (end - start) as u64;
                            block.saliency[d as usize].add_run(
                                saliency[cell as usize],
                                cell,
                                len,
                                index_sum(start, end),
                                y as u64 * len,
                            );
                        }
                        start = end;
                    }
                }
            });
    }
}

fn index_sum(start: usize, end: usize) -> u64 {
    // (start + end − 1)·len is always even.
    ((start + end - 1) as u64 * (end - start) as u64) / 2
}

/// Length of the run of equal ids starting at `start`.
#[inline]
fn run_end(ids: &[u32], start: usize) -> usize {
    let id = ids[start];
    ids[start..]
        .iter()
        .position(|&v| v != id)
        .map_or(ids.len(), |n| start + n)
}

/// Sum and count of the finite depths (negative ones as 0), four lanes.
#[inline]
fn finite_depth_sum(depth: &[f32]) -> (f64, u64) {
    let mut sum = [0.0f64; 4];
    let mut count = [0u64; 4];
    let chunks = depth.chunks_exact(4);
    let tail = chunks.remainder();
    for c in chunks {
        for i in 0..4 {
            let ok = c[i].is_finite();
            sum[i] += if ok { f64::from(c[i].max(0.0)) } else { 0.0 };
            count[i] += u64::from(ok);
        }
    }
    for &z in tail {
        let ok = z.is_finite();
        sum[0] += if ok { f64::from(z.max(0.0)) } else { 0.0 };
        count[0] += u64::from(ok);
    }
    (sum.iter().sum(), count.iter().sum())
}

fn channel_flags(config: &AttentionConfig) -> [bool; CHANNELS] {
    let [luminance, hue, depth, size, motion] = config.features.as_array();
    [luminance, hue, hue, depth, size, motion]
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synthetic::SyntheticScene;

    fn close(a: f32, b: f32) -> bool {
        (a - b).abs() <= 1e-5
    }

    #[test]
    fn fused_and_three_pass_paths_agree() {
        for (w, h, map) in [(640, 480, 64), (333, 257, 100), (512, 512, 256)] {
            let mut scene = SyntheticScene::new(w, h, 40, u64::from(w)).expect("valid");
            let objects = scene.objects();
            let camera = CameraMotion::new([0.0, 0.0, -1.0], [0.0, 0.0, -500.0]);
            let config = AttentionConfig::with_map_size(map);
            let mut fused = AttentionTracker::new(config).expect("valid");
            let mut plain = AttentionTracker::new(config).expect("valid");
            for _ in 0..3 {
                let a = fused
                    .update_with(&scene.view(), &objects, camera, 0.02, true)
                    .expect("ok");
                let b = plain
                    .update_with(&scene.view(), &objects, camera, 0.02, false)
                    .expect("ok");
                assert_eq!(a.ranking.len(), b.ranking.len());
                assert_eq!(
                    (a.background_pixels, a.unlisted_pixels),
                    (b.background_pixels, b.unlisted_pixels)
                );
                let ids_b: HashMap<u32, &ObjectAttention> =
                    b.ranking.iter().map(|o| (o.id, o)).collect();
                for x in &a.ranking {
                    let y = ids_b[&x.id];
                    assert!(
                        close(x.attention, y.attention) && close(x.raw_attention, y.raw_attention)
                    );
                    assert!(
                        close(x.object_saliency, y.object_saliency),
                        "{} vs {}",
                        x.object_saliency,
                        y.object_saliency
                    );
                    assert_eq!(x.pixel_count, y.pixel_count);
                    assert!(
                        close(x.distance_mm, y.distance_mm)
                            || (x.distance_mm - y.distance_mm).abs() < 1e-3
                    );
                    assert_eq!(x.screen_centre_px, y.screen_centre_px);
                    assert_eq!(x.peak_px, y.peak_px, "object {}", x.id);
                }
                for f in Feature::ALL {
                    let (ca, cb) = (fused.maps().contrast(f), plain.maps().contrast(f));
                    assert!(
                        ca.iter().zip(cb).all(|(p, q)| (p - q).abs() < 1e-4),
                        "{f:?}"
                    );
                }
                scene.advance(0.05);
            }
        }
    }
}
