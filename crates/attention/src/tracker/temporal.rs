//! Finishing a frame across time (Lee eq. 3.7–3.10): spatial and temporal
//! context, final attention, Kalman smoothing per object, ranking and the
//! attended object; for a frame measured here or elsewhere (a GPU).

use super::result::{Attention, ObjectAttention};
use super::AttentionTracker;
use crate::context::{spatial_context, TemporalContext};
use crate::error::AttentionError;
use crate::frame::{CameraMotion, ObjectInfo};
use crate::kalman::ScalarKalman;
use crate::measure::FrameMeasure;

/// Per-object state kept across frames.
#[derive(Clone, Debug)]
pub(super) struct ObjectState {
    pub(super) temporal: TemporalContext,
    pub(super) kalman: Option<ScalarKalman>,
    pub(super) last_distance_mm: Option<f32>,
    pub(super) listed_in_frame: u64,
}

impl AttentionTracker {
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
    pub(super) fn finish(
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
}
