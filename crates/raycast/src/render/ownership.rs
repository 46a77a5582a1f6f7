//! Pixel ownership: every pixel belongs to the fovea disc or to exactly one
//! cell of the intermediate mesh, by an exact integer top-left rule.

use super::*;

/// Owner of a pixel in the fovea disc ([`ownership`]).
pub const OWNER_FOVEA: u32 = FOVEA;
/// A pixel no cell claims ([`ownership`]).
pub const OWNER_NONE: u32 = UNOWNED;

/// Which part of the mask owns each pixel: [`OWNER_FOVEA`], the index of the
/// one cell whose exact top-left rule claims the pixel centre, or
/// [`OWNER_NONE`]. Depends on the gaze only (every cell is rasterised); the
/// GPU core uploads it.
pub fn ownership(m: &RayMask, w: usize, h: usize) -> Vec<u32> {
    owners(m, w, h, |_| false)
}

/// Fovea spans first, then every cell that `skip` does not exclude.
pub(super) fn owners(
    m: &RayMask,
    w: usize,
    h: usize,
    skip: impl Fn(usize) -> bool + Sync,
) -> Vec<u32> {
    let mut owner = Vec::new();
    owners_into(&mut owner, m, w, h, skip);
    owner.into_par_iter().map(AtomicU32::into_inner).collect()
}

/// [`owners`] into `owner`, reusing its buffer. A pixel is claimed only while
/// unowned; the exact rule gives every pixel at most one cell, so plain
/// (relaxed) loads and stores do, with no read-modify-write per pixel.
pub(super) fn owners_into(
    owner: &mut Vec<AtomicU32>,
    m: &RayMask,
    w: usize,
    h: usize,
    skip: impl Fn(usize) -> bool + Sync,
) {
    owner.resize_with(w * h, || AtomicU32::new(UNOWNED));
    owner.par_iter_mut().for_each(|o| *o.get_mut() = UNOWNED);
    for s in &m.fovea {
        let row = s.y as usize * w;
        for o in &mut owner[row + s.x_start as usize..row + s.x_end as usize] {
            *o.get_mut() = FOVEA;
        }
    }
    let owner: &[AtomicU32] = owner;
    m.cells.par_iter().enumerate().for_each(|(ci, c)| {
        if skip(ci) {
            return;
        }
        rasterise(m, corners_of(c), w, h, |i| {
            if owner[i].load(Ordering::Relaxed) == UNOWNED {
                owner[i].store(ci as u32, Ordering::Relaxed);
            }
        })
    });
}

/// Calls `own` for the index of every pixel whose centre lies in the cell.
/// Coordinates are snapped to 1/65536 px and edge functions evaluated exactly
/// in integers; a centre on an edge belongs to the cell for which that edge
/// runs "down or left" (a top-left style rule), so cells sharing an edge never
/// both claim a pixel and never both miss it. Along a row each edge function
/// steps by an exact integer, so it is evaluated incrementally.
pub(super) fn rasterise(
    m: &RayMask,
    corners: &[u32],
    w: usize,
    h: usize,
    mut own: impl FnMut(usize),
) {
    let n = corners.len();
    let mut all = [(0i64, 0i64); 4];
    for (k, &v) in corners.iter().enumerate() {
        let p = m.vertices[v as usize];
        all[k] = (
            (f64::from(p[0]) * SUB).round() as i64,
            (f64::from(p[1]) * SUB).round() as i64,
        );
    }
    let pts = &mut all[..n];
    let area2: i64 = (0..n)
        .map(|i| pts[i].0 * pts[(i + 1) % n].1 - pts[(i + 1) % n].0 * pts[i].1)
        .sum();
    if area2 == 0 {
        return;
    }
    if area2 < 0 {
        pts.reverse();
    }
    let sub = SUB as i64;
    let (x0, x1) = pts
        .iter()
        .fold((i64::MAX, i64::MIN), |(a, b), p| (a.min(p.0), b.max(p.0)));
    let (y0, y1) = pts
        .iter()
        .fold((i64::MAX, i64::MIN), |(a, b), p| (a.min(p.1), b.max(p.1)));
    // Pixel centres (x + 0.5)·SUB within the bounding box, clipped to the screen.
    let first = |lo: i64| ((lo - sub / 2) as f64 / SUB).ceil().max(0.0) as i64;
    let last = |hi: i64, limit: usize| {
        (((hi - sub / 2) as f64 / SUB).floor() as i64).min(limit as i64 - 1)
    };
    let (px0, px1, py0, py1) = (first(x0), last(x1, w), first(y0), last(y1, h));
    if px0 > px1 {
        return;
    }
    // Per edge: start point, direction, and whether a centre on it is inside.
    let mut edges = [((0i64, 0i64), (0i64, 0i64), false); 4];
    for i in 0..n {
        let (a, b) = (pts[i], pts[(i + 1) % n]);
        let (dx, dy) = (b.0 - a.0, b.1 - a.1);
        edges[i] = (a, (dx, dy), dy > 0 || (dy == 0 && dx < 0));
    }
    let edges = &edges[..n];
    let cx0 = px0 * sub + sub / 2;
    for py in py0..=py1 {
        let cy = py * sub + sub / 2;
        let mut e = [0i64; 4];
        for (e, &(a, (dx, dy), _)) in e.iter_mut().zip(edges) {
            *e = dx * (cy - a.1) - dy * (cx0 - a.0);
        }
        let row = py as usize * w;
        for px in px0..=px1 {
            let inside = e
                .iter()
                .zip(edges)
                .all(|(&e, &(_, _, on))| e > 0 || (e == 0 && on));
            if inside {
                own(row + px as usize);
            }
            if px < px1 {
                for (e, &(_, (_, dy), _)) in e.iter_mut().zip(edges) {
                    *e -= dy * sub;
                }
            }
        }
    }
}
