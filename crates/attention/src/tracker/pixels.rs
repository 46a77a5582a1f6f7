//! What both measurement paths share: per-object pixel accumulators, the
//! row blocks they run in, the frame ↔ map cell correspondence and the
//! run-length helpers over a row of object ids.

use super::fused::{CellObject, CellSums};
use crate::frame::BACKGROUND_ID;
use crate::measure::{footprints, ObjectIndex};

pub(super) const NO_OBJECT: u32 = ObjectIndex::UNLISTED;
/// Row blocks of the per-pixel passes; fixed so that sums do not depend on
/// the thread count.
pub(super) const PIXEL_BLOCKS: usize = 32;

/// Per-pixel accumulators of pass A (object statistics).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct PixelStats {
    pub(super) count: u64,
    pub(super) depth_sum_mm: f64,
    pub(super) depth_count: u64,
    pub(super) sum_x: u64,
    pub(super) sum_y: u64,
}

/// Per-pixel accumulators of pass C (object saliency and peak).
#[derive(Clone, Copy, Debug)]
pub(super) struct SaliencyStats {
    pub(super) sum: f64,
    pub(super) best: f32,
    pub(super) best_cell: u32,
    pub(super) best_sum_x: u64,
    pub(super) best_sum_y: u64,
    pub(super) best_count: u64,
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
    pub(super) fn add_run(&mut self, value: f32, cell: u32, count: u64, sum_x: u64, sum_y: u64) {
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

    pub(super) fn merge(&mut self, other: &Self) {
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
pub(super) struct PixelBlock {
    pub(super) stats: Vec<PixelStats>,
    pub(super) saliency: Vec<SaliencyStats>,
    pub(super) cell_objects: Vec<CellObject>,
    pub(super) row_sums: Vec<CellSums>,
    pub(super) row_objects: Vec<Vec<CellObject>>,
    pub(super) background: u64,
    pub(super) unlisted: u64,
}

/// Remembers the last lookup: ids come in long runs along a row.
pub(super) struct RunCache<'a> {
    pub(super) lookup: &'a ObjectIndex,
    pub(super) id: u32,
    pub(super) dense: u32,
}

impl<'a> RunCache<'a> {
    pub(super) fn new(lookup: &'a ObjectIndex) -> Self {
        Self {
            lookup,
            id: BACKGROUND_ID,
            dense: NO_OBJECT,
        }
    }

    #[inline]
    pub(super) fn get(&mut self, id: u32) -> u32 {
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
pub(super) struct CellGrid {
    pub(super) key: (u32, u32, u32),
    pub(super) x0: Vec<u32>,
    pub(super) x1: Vec<u32>,
    pub(super) y0: Vec<u32>,
    pub(super) y1: Vec<u32>,
    pub(super) cell_of_x: Vec<u32>,
    pub(super) cell_of_y: Vec<u32>,
}

impl CellGrid {
    pub(super) fn prepare(&mut self, width: u32, height: u32, map: u32) {
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
pub(super) struct FrameObject {
    pub(super) source: usize,
    pub(super) importance: f32,
    pub(super) speed: f32,
    pub(super) size: f32,
    pub(super) motion: f32,
}

pub(super) fn index_sum(start: usize, end: usize) -> u64 {
    // (start + end − 1)·len is always even.
    ((start + end - 1) as u64 * (end - start) as u64) / 2
}

/// Length of the run of equal ids starting at `start`.
#[inline]
pub(super) fn run_end(ids: &[u32], start: usize) -> usize {
    let id = ids[start];
    ids[start..]
        .iter()
        .position(|&v| v != id)
        .map_or(ids.len(), |n| start + n)
}

/// Sum and count of the finite depths (negative ones as 0), four lanes.
#[inline]
pub(super) fn finite_depth_sum(depth: &[f32]) -> (f64, u64) {
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
