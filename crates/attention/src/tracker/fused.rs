//! The fused measurement pass, used when the frame is at least as large
//! as the map: one read of each frame buffer gives the cells' area sums
//! and, per object, its pixels in each cell, from which `B_s` and eq. 3.7
//! are finished without reading the frame again.

use rayon::prelude::*;

use super::maps::{CH_D, CH_HX, CH_HY, CH_L, CH_M, CH_S};
use super::pixels::{finite_depth_sum, index_sum, run_end, RunCache, NO_OBJECT};
use super::AttentionTracker;
use crate::frame::{FrameView, BACKGROUND_ID};
use crate::hls::lightness_and_hue_vector;

/// Area sums of one map cell in the fused pass.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct CellSums {
    pub(super) red: u64,
    pub(super) green: u64,
    pub(super) blue: u64,
    pub(super) depth: f64,
    pub(super) speed: f64,
}

/// The pixels of one object inside one map cell (the fused pass's record,
/// from which `B_s` and the object saliency of eq. 3.7 are finished without
/// reading the frame again). Coordinates relative to the cell's footprint.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct CellObject {
    pub(super) cell: u32,
    pub(super) object: u32,
    pub(super) count: u32,
    pub(super) sum_dx: u32,
    pub(super) sum_dy: u32,
}

impl AttentionTracker {
    /// The fused pass (cells partition the frame): per map cell, the
    /// area sums of colour and `B_d`, the motion sum, and per object the
    /// statistics of pass A and its pixels in the cell ([`CellObject`]).
    pub(super) fn fused_pass(&mut self, frame: &FrameView) {
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
    pub(super) fn finish_fused_cells(&mut self, max_speed: f32) {
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
}
