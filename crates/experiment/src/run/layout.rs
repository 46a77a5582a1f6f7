//! The design's search grid on one display: the size of each object and
//! where each cell is, in the world (mm, the objects' plane) and on the
//! screen (px), with the hit-test a confirming click uses.
//!
//! Geometry: the objects stand [`DEPTH_MM`] behind the screen, facing the
//! viewer. An object `object_deg` wide is `2 (d + depth) tan(object_deg / 2)`
//! mm across (d the eye-to-screen distance); the grid, `grid_deg` wide from
//! the outer edge of one outer object to the other, spaces the cell centres
//! evenly. The shipped search-task scene (17" at 54 cm: 3.5° objects,
//! 17.11 mm scale, 40.82 mm spacing) is this construction.

use screen_geometry::ScreenGeometry;

use crate::design::Design;

/// Objects stand this far behind the screen plane (mm).
pub const DEPTH_MM: f64 = 20.0;

/// The grid on one display: where each cell is, in the world and on the
/// screen.
#[derive(Debug, Clone, PartialEq)]
pub struct Layout {
    /// Rows of the grid.
    pub rows: u32,
    /// Columns of the grid.
    pub cols: u32,
    /// Mesh scale (mm): the face mesh fits the unit sphere, so this is the
    /// object's radius.
    pub scale_mm: f64,
    /// Centre-to-centre spacing of cells (mm, in the objects' plane).
    pub spacing_mm: f64,
    /// Cell centres on the screen (px), row-major.
    pub centres_px: Vec<[f64; 2]>,
    /// An object's radius on the screen (px), for hit-testing clicks.
    pub radius_px: f64,
}

impl Layout {
    /// The design's grid on `geometry`.
    pub fn new(design: &Design, geometry: &ScreenGeometry) -> Self {
        let s = &design.stimulus;
        let (rows, cols) = s.grid;
        let plane = geometry.eye_distance_mm + DEPTH_MM;
        let width = |deg: f64| 2.0 * plane * (deg.to_radians() / 2.0).tan();
        let object = width(s.object_deg);
        let grid = width(s.grid_deg);
        let n = rows.max(cols);
        let spacing_mm = if n > 1 {
            ((grid - object) / f64::from(n - 1)).max(object)
        } else {
            object
        };
        let cam = raycast::Camera::new(geometry);
        let eye = [
            f64::from(cam.eye.x),
            f64::from(cam.eye.y),
            f64::from(cam.eye.z),
        ];
        let [w, h] = geometry.size_px();
        let to_screen = |x: f64, y: f64| {
            // Along the line from the eye to (x, y, −depth) to z = 0.
            let t = eye[2] / (eye[2] + DEPTH_MM);
            let sx = eye[0] + t * (x - eye[0]);
            let sy = eye[1] + t * (y - eye[1]);
            [
                sx / geometry.pitch_x_mm + w / 2.0,
                h / 2.0 - sy / geometry.pitch_y_mm,
            ]
        };
        let mut centres_px = Vec::with_capacity((rows * cols) as usize);
        for r in 0..rows {
            for c in 0..cols {
                let (x, y) = cell_mm(r, c, rows, cols, spacing_mm);
                centres_px.push(to_screen(x, y));
            }
        }
        let scale_mm = object / 2.0;
        let radius_px = scale_mm * geometry.eye_distance_mm
            / plane
            / geometry.pitch_x_mm.max(geometry.pitch_y_mm);
        Self {
            rows,
            cols,
            scale_mm,
            spacing_mm,
            centres_px,
            radius_px,
        }
    }

    /// The cell under screen point `p` (px): the nearest centre if it is
    /// within half a spacing (a click between objects counts for the
    /// nearest), else `None`.
    pub fn cell_at(&self, p: [f64; 2]) -> Option<(u32, u32)> {
        if !(p[0].is_finite() && p[1].is_finite()) {
            return None;
        }
        let (k, d) = self
            .centres_px
            .iter()
            .enumerate()
            .map(|(k, c)| (k, (c[0] - p[0]).hypot(c[1] - p[1])))
            .min_by(|a, b| a.1.total_cmp(&b.1))?;
        let half_spacing_px = if self.centres_px.len() > 1 {
            self.spacing_px() / 2.0
        } else {
            self.radius_px
        };
        (d <= half_spacing_px.max(self.radius_px))
            .then_some((k as u32 / self.cols, k as u32 % self.cols))
    }

    /// Spacing on the screen (px) between neighbouring centres.
    pub fn spacing_px(&self) -> f64 {
        match self.centres_px.as_slice() {
            [a, b, ..] => (a[0] - b[0]).hypot(a[1] - b[1]),
            _ => 0.0,
        }
    }

    /// The centres (px) of the cells a search can stop at, row-major: every
    /// cell but the reference's (it holds the target mesh but is not the
    /// target to find).
    pub fn search_centres(&self, reference: Option<(u32, u32)>) -> Vec<[f64; 2]> {
        self.centres_px
            .iter()
            .enumerate()
            .filter(|&(k, _)| reference.is_none_or(|(r, c)| (r * self.cols + c) as usize != k))
            .map(|(_, p)| *p)
            .collect()
    }

    /// The centre (px) of cell (row, col).
    pub fn centre_px(&self, (r, c): (u32, u32)) -> [f64; 2] {
        self.centres_px
            .get((r * self.cols + c) as usize)
            .copied()
            .unwrap_or([0.0, 0.0])
    }
}

/// World position (mm) of cell (r, c): row 0 at the top.
pub(crate) fn cell_mm(r: u32, c: u32, rows: u32, cols: u32, spacing: f64) -> (f64, f64) {
    let x = (f64::from(c) - f64::from(cols - 1) / 2.0) * spacing;
    let y = (f64::from(rows - 1) / 2.0 - f64::from(r)) * spacing;
    (x, y)
}

#[cfg(test)]
mod tests {
    use super::*;

    use crate::run::test_support::{murphy, seed_display};

    /// The construction gives the shipped search-task scene's numbers
    /// (3.5° objects, 20° grid at 54 cm).
    #[test]
    fn the_seed_grid_matches_the_search_task_scene() {
        let l = Layout::new(&murphy(), &seed_display());
        assert!((l.scale_mm - 17.11).abs() < 0.01, "{}", l.scale_mm);
        assert!((l.spacing_mm - 40.82).abs() < 0.01, "{}", l.spacing_mm);
        assert_eq!(l.centres_px.len(), 25);
        // The centre cell is the screen's centre.
        let c = l.centre_px((2, 2));
        assert!((c[0] - 640.0).abs() < 1e-9 && (c[1] - 512.0).abs() < 1e-9);
        // Row 0 is above (smaller y), column 0 to the left.
        assert!(l.centre_px((0, 0))[1] < c[1] && l.centre_px((0, 0))[0] < c[0]);
    }

    #[test]
    fn clicks_find_the_nearest_cell_and_not_far_away() {
        let l = Layout::new(&murphy(), &seed_display());
        for (k, c) in l.centres_px.iter().enumerate() {
            let cell = (k as u32 / 5, k as u32 % 5);
            assert_eq!(l.cell_at(*c), Some(cell));
            assert_eq!(l.cell_at([c[0] + 0.4 * l.spacing_px(), c[1]]), Some(cell));
        }
        assert_eq!(l.cell_at([5.0, 5.0]), None);
        assert_eq!(l.cell_at([f64::NAN, 5.0]), None);
    }
}
