//! The seed's uniform grid (Murphy 2007 §6.1.1), kept as a second
//! acceleration structure for comparison with the BVH.
//!
//! Construction follows the dissertation: start with the scene's bounding box
//! as one cell; insert every triangle into every cell it overlaps; if any cell
//! holds more than the bin size (40 triangles), restart with finer, roughly
//! cubic cells. Two differences, both stated: overlap is tested with the
//! triangle's bounding box rather than the separating-axis test (so cells hold
//! a few extra candidates), and refinement stops before the grid would exceed
//! [`max_cells`] cells (16 per triangle, at most 16 M) or
//! [`max_references`] cell references (32 per triangle, at most 128 M),
//! after which the fullest cell may exceed the bin size (reported in
//! `max_bin`). The limits hold whatever the geometry: coincident or
//! degenerate triangles never meet the bin size, and without them
//! refinement would go on until every cell held a copy of each (41
//! coincident triangles took 1.1 GB, 1000 would take 7 GB). The grid
//! therefore needs at most 4 B × (2 × cells + references) ≤ 256 B per
//! triangle and 640 MB in all; the shipped scenes never reach the limits
//! (`stress`: 9.0 cells and 2.2 references per triangle).
//! Traversal is Amanatides & Woo's 3-D DDA; a hit counts only once the ray has
//! reached it (its distance is within the current cell), since triangles span
//! cells.

use glam::Vec3;

use crate::ray::Aabb;

/// The seed's empirically derived bin size.
pub const BIN_SIZE: usize = 40;
/// Most cells a grid may have, whatever its triangle count.
pub const MAX_CELLS: usize = 16 << 20;
/// Most cells per triangle.
pub const CELLS_PER_TRIANGLE: usize = 16;
/// Most cell references (triangle copies) a grid may hold, whatever its
/// triangle count.
pub const MAX_REFERENCES: usize = 128 << 20;
/// Most cell references per triangle.
pub const REFERENCES_PER_TRIANGLE: usize = 32;
/// Refinement levels: with finite bounds the cell limit is reached first
/// (1.25^80 > 2^24); infinite bounds (coordinates near ±`f32::MAX`) keep one
/// cell at every level, so this ends them.
const MAX_LEVELS: u32 = 80;

/// The cell limit for `triangles` triangles.
pub fn max_cells(triangles: usize) -> usize {
    triangles
        .saturating_mul(CELLS_PER_TRIANGLE)
        .clamp(1, MAX_CELLS)
}

/// The reference limit for `triangles` triangles.
pub fn max_references(triangles: usize) -> usize {
    triangles
        .saturating_mul(REFERENCES_PER_TRIANGLE)
        .min(MAX_REFERENCES)
}

/// One refinement level: cell counts along each axis and the cell size.
fn level(extent: Vec3, side: f32) -> ([u32; 3], Vec3) {
    let dims = (extent / side).ceil().max(Vec3::ONE);
    let dims = [dims.x as u32, dims.y as u32, dims.z as u32];
    let cell_size = extent / Vec3::new(dims[0] as f32, dims[1] as f32, dims[2] as f32);
    (dims, cell_size)
}

/// The cells, lowest and highest along each axis, that box `b` overlaps.
fn cell_range(b: &Aabb, origin: Vec3, cell_size: Vec3, dims: [u32; 3]) -> ([u32; 3], [u32; 3]) {
    let lo = ((b.min - origin) / cell_size).floor();
    let hi = ((b.max - origin) / cell_size).floor();
    let c = |v: f32, d: u32| (v.max(0.0) as u32).min(d - 1);
    (
        [c(lo.x, dims[0]), c(lo.y, dims[1]), c(lo.z, dims[2])],
        [c(hi.x, dims[0]), c(hi.y, dims[1]), c(hi.z, dims[2])],
    )
}

/// Whether a grid of `dims` over these triangles stays within the limits;
/// counts its cells and references without allocating them.
fn within_limits(tri_bounds: &[Aabb], origin: Vec3, cell_size: Vec3, dims: [u32; 3]) -> bool {
    let cells = dims.iter().map(|&d| u64::from(d)).product::<u64>();
    if cells > max_cells(tri_bounds.len()) as u64 {
        return false;
    }
    let limit = max_references(tri_bounds.len()) as u64;
    let mut references = 0u64;
    for b in tri_bounds {
        let (lo, hi) = cell_range(b, origin, cell_size, dims);
        references += (0..3)
            .map(|a| u64::from(hi[a] - lo[a]) + 1)
            .product::<u64>();
        if references > limit {
            return false;
        }
    }
    true
}

/// The seed's uniform grid (module doc): the triangles overlapping each
/// cell, in compressed-row form.
#[derive(Debug, Clone)]
pub struct UniformGrid {
    /// Bounds of every triangle: the grid's extent.
    pub bounds: Aabb,
    /// Cells along x, y and z.
    pub dims: [u32; 3],
    /// Size of one cell, world mm.
    pub cell_size: Vec3,
    /// CSR: triangles of cell c are `items[start[c]..start[c + 1]]`.
    pub start: Vec<u32>,
    /// Triangle indices, cell after cell (see `start`).
    pub items: Vec<u32>,
    /// Most triangles in one cell.
    pub max_bin: usize,
    /// Rebuilds needed to meet the bin size.
    pub levels: u32,
}

impl UniformGrid {
    /// Builds the grid over the triangles' bounding boxes (`tri_bounds[i]` is
    /// triangle `i`'s), refining as the module doc describes.
    pub fn build(tri_bounds: &[Aabb]) -> Self {
        let mut bounds = Aabb::EMPTY;
        for b in tri_bounds {
            bounds = bounds.union(b);
        }
        if tri_bounds.is_empty() {
            return Self {
                bounds,
                dims: [1; 3],
                cell_size: Vec3::ONE,
                start: vec![0, 0],
                items: Vec::new(),
                max_bin: 0,
                levels: 0,
            };
        }
        // Pad flat boxes so every axis has some extent.
        let extent = (bounds.max - bounds.min).max(Vec3::splat(
            1e-3 * (bounds.max - bounds.min).max_element().max(1e-6),
        ));
        bounds.max = bounds.min + extent;
        let mut side = extent.max_element();
        let mut levels = 0;
        loop {
            let (dims, cell_size) = level(extent, side);
            let cells = dims.iter().map(|&d| d as usize).product::<usize>();
            let mut counts = vec![0u32; cells + 1];
            let range = |b: &Aabb| cell_range(b, bounds.min, cell_size, dims);
            let index = |x: u32, y: u32, z: u32| ((z * dims[1] + y) * dims[0] + x) as usize;
            for b in tri_bounds {
                let (lo, hi) = range(b);
                for z in lo[2]..=hi[2] {
                    for y in lo[1]..=hi[1] {
                        for x in lo[0]..=hi[0] {
                            counts[index(x, y, z)] += 1;
                        }
                    }
                }
            }
            let max_bin = counts.iter().copied().max().unwrap_or(0) as usize;
            let finer_cells = (cells as f64 * 1.25f64.powi(3)) as usize;
            if max_bin > BIN_SIZE && finer_cells <= MAX_CELLS && levels < MAX_LEVELS && {
                let (dims, cell_size) = level(extent, side / 1.25);
                within_limits(tri_bounds, bounds.min, cell_size, dims)
            } {
                side /= 1.25;
                levels += 1;
                continue;
            }
            // Prefix sums, then fill.
            let mut start = vec![0u32; cells + 1];
            for c in 0..cells {
                start[c + 1] = start[c] + counts[c];
            }
            let mut fill = start.clone();
            let mut items = vec![0u32; start[cells] as usize];
            for (t, b) in tri_bounds.iter().enumerate() {
                let (lo, hi) = range(b);
                for z in lo[2]..=hi[2] {
                    for y in lo[1]..=hi[1] {
                        for x in lo[0]..=hi[0] {
                            let c = index(x, y, z);
                            items[fill[c] as usize] = t as u32;
                            fill[c] += 1;
                        }
                    }
                }
            }
            return Self {
                bounds,
                dims,
                cell_size,
                start,
                items,
                max_bin,
                levels,
            };
        }
    }

    /// Walks the cells the ray crosses, near to far, calling `visit(triangles,
    /// t_max)` with the cell's exit distance as `t_max`; stops when `visit`
    /// returns true (a hit inside the cell).
    pub fn traverse(&self, ray: &crate::ray::Ray, mut visit: impl FnMut(&[u32], f32) -> bool) {
        let Some(t_enter) = self.bounds.hit(ray, f32::INFINITY) else {
            return;
        };
        let p = ray.at(t_enter) - self.bounds.min;
        let mut cell = [0i64; 3];
        let mut step = [0i64; 3];
        let mut t_next = [f32::INFINITY; 3];
        let mut t_delta = [f32::INFINITY; 3];
        for a in 0..3 {
            let d = ray.dir[a];
            cell[a] =
                ((p[a] / self.cell_size[a]).floor() as i64).clamp(0, i64::from(self.dims[a]) - 1);
            if d > 0.0 {
                step[a] = 1;
                t_next[a] = t_enter + (((cell[a] + 1) as f32) * self.cell_size[a] - p[a]) / d;
                t_delta[a] = self.cell_size[a] / d;
            } else if d < 0.0 {
                step[a] = -1;
                t_next[a] = t_enter + ((cell[a] as f32) * self.cell_size[a] - p[a]) / d;
                t_delta[a] = -self.cell_size[a] / d;
            }
        }
        loop {
            let c = ((cell[2] * i64::from(self.dims[1]) + cell[1]) * i64::from(self.dims[0])
                + cell[0]) as usize;
            let exit = t_next[0].min(t_next[1]).min(t_next[2]);
            let tris = &self.items[self.start[c] as usize..self.start[c + 1] as usize];
            if !tris.is_empty() && visit(tris, exit * (1.0 + 4.0 * f32::EPSILON)) {
                return;
            }
            let a = if t_next[0] <= t_next[1] && t_next[0] <= t_next[2] {
                0
            } else if t_next[1] <= t_next[2] {
                1
            } else {
                2
            };
            if step[a] == 0 {
                return;
            }
            cell[a] += step[a];
            if cell[a] < 0 || cell[a] >= i64::from(self.dims[a]) {
                return;
            }
            t_next[a] += t_delta[a];
        }
    }
}
