//! The attention tracker: one frame in, object attention out (Lee Fig. 3.1).
//! This file holds the tracker's buffers and a frame's order of work;
//! the per-pixel passes are in [`fused`] (one pass, the usual case) and
//! [`reference`] (three passes, small frames and the test of the fused
//! pass), the maps in [`maps`], the finishing of a frame across time in
//! [`temporal`], and the result types in [`result`].

mod fused;
mod maps;
mod pixels;
mod reference;
mod result;
mod temporal;

use std::collections::HashMap;

use crate::config::AttentionConfig;
use crate::contrast::{combine, CentreSurround};
use crate::error::AttentionError;
use crate::frame::{CameraMotion, FrameView, ObjectInfo};
use crate::measure::{FrameMeasure, ObjectIndex, ObjectMeasure};
use crate::pyramid::Pyramid;

pub use maps::SaliencyMaps;
pub use result::{Attention, Feature, ObjectAttention};

use maps::CHANNELS;
use pixels::{CellGrid, FrameObject, PixelBlock, PixelStats, SaliencyStats, PIXEL_BLOCKS};
use temporal::ObjectState;

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
