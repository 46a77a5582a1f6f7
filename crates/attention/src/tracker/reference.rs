//! The three-pass measurement path (statistics, cell averages, object
//! saliency): used when the frame is smaller than the map, and the
//! reference the fused pass is tested against.

use rayon::prelude::*;

use super::maps::{CH_D, CH_HX, CH_HY, CH_L, CH_M, CH_S};
use super::pixels::{finite_depth_sum, index_sum, run_end, RunCache, NO_OBJECT};
use super::AttentionTracker;
use crate::frame::{FrameView, BACKGROUND_ID};
use crate::hls::lightness_and_hue_vector;

impl AttentionTracker {
    /// Pass A over the frame: pixel count, depth sum and centroid sums per
    /// object.
    pub(super) fn object_statistics(&mut self, frame: &FrameView) {
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
    pub(super) fn area_average_cells(&mut self, frame: &FrameView) {
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

    /// Pass C over the frame: sum of `S_p` and the peak cell per object.
    pub(super) fn object_saliency(&mut self, frame: &FrameView) {
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
