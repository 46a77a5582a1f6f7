//! The hybrid frame's stages after the mask (Murphy 2007 ch. 5–6): cast
//! the mask vertices, classify cells, widen by the silhouette margin, then
//! per pixel cast (fovea, refined cells) or interpolate from a homogeneous
//! cell's corners (by runs of one owner), and shade.

use super::*;

/// Is a cell with these corner hits homogeneous under `t`?
pub(super) fn homogeneous(corners: &[Option<Hit>], t: &Triggers) -> bool {
    if corners.iter().all(Option::is_none) {
        return true;
    }
    let Some(a) = corners[0] else {
        return !t.silhouette;
    };
    if corners
        .iter()
        .any(|h| h.is_none_or(|h| h.object != a.object))
    {
        return !t.silhouette;
    }
    let hits = || corners.iter().flatten();
    if let Some(deg) = t.crease_deg {
        let cos = deg.to_radians().cos();
        for (i, p) in hits().enumerate() {
            if hits().skip(i + 1).any(|q| p.normal.dot(q.normal) < cos) {
                return false;
            }
        }
    }
    if let Some(jump) = t.depth_jump {
        let (lo, hi) = hits().fold((f32::INFINITY, 0.0f32), |(lo, hi), h| {
            (lo.min(h.t), hi.max(h.t))
        });
        if hi > lo * (1.0 + jump) {
            return false;
        }
    }
    true
}

pub(super) fn corners_of(cell: &[u32; 4]) -> &[u32] {
    if cell[3] == NO_VERTEX {
        &cell[..3]
    } else {
        &cell[..]
    }
}

/// Stages 2–4: cast the mask vertices, classify the cells, widen by the
/// margin, and give every pixel its owner.
#[allow(clippy::too_many_arguments)]
fn vertices_and_cells(
    scene: &Scene,
    cam: &Camera,
    settings: &Settings,
    m: &RayMask,
    vertex_hits: &mut Vec<Option<Hit>>,
    refined: &mut Vec<bool>,
    touched: &mut Vec<bool>,
    owner: &mut Vec<AtomicU32>,
    stages: &mut StageTimes,
    (w, h): (usize, usize),
    t: &mut Instant,
) {
    let test = settings.test;
    // 2. Mask rays, eight neighbouring vertices of a ring a packet
    // (bit-identical to casting each alone: `Scene::intersect_packet`).
    vertex_hits.clear();
    vertex_hits.resize(m.vertices.len(), None);
    vertex_hits
        .par_chunks_mut(PACKET)
        .zip(m.vertices.par_chunks(PACKET))
        .for_each(|(hits, vs)| {
            let mut rays = [cam.ray([0.0, 0.0]); PACKET];
            for (r, v) in rays.iter_mut().zip(vs) {
                *r = cam.ray(*v);
            }
            scene.intersect_packet(&rays[..vs.len()], 0.0, test, hits);
        });
    let vertex_hits: &[Option<Hit>] = vertex_hits;
    stages.vertex_rays = lap(t);
    // 3. Classify, then widen by one vertex ring.
    m.cells
        .par_iter()
        .map(|c| {
            let corners = corners_of(c);
            let mut hits = [None; 4];
            for (k, &v) in corners.iter().enumerate() {
                hits[k] = vertex_hits[v as usize];
            }
            !homogeneous(&hits[..corners.len()], &settings.triggers)
        })
        .collect_into_vec(refined);
    stages.classify = lap(t);
    if settings.triggers.margin {
        touched.clear();
        touched.resize(m.vertices.len(), false);
        for (c, r) in m.cells.iter().zip(refined.iter()) {
            if *r {
                corners_of(c)
                    .iter()
                    .for_each(|&v| touched[v as usize] = true);
            }
        }
        let touched: &[bool] = touched;
        refined
            .par_iter_mut()
            .zip(&m.cells)
            .for_each(|(r, c)| *r = *r || corners_of(c).iter().any(|&v| touched[v as usize]));
    }
    let refined: &[bool] = refined;
    stages.margin = lap(t);
    // 4. Ownership: fovea spans, then cells by an exact top-left rule.
    // A homogeneous cell whose corners all miss is background: unless
    // coverage is being checked, it is not rasterised at all.
    let background = |c: &[u32; 4]| {
        corners_of(c)
            .iter()
            .all(|&v| vertex_hits[v as usize].is_none())
    };
    owners_into(owner, m, w, h, |ci| {
        !settings.check_coverage && !refined[ci] && background(&m.cells[ci])
    });
    stages.ownership = lap(t);
}

/// Stages 2–5 of a foveated frame. With `kept`, the mask is bit-identical
/// to the last frame's and the vertex hits, refined flags and owners in
/// `scratch` are still right: stages 2–4 are skipped.
#[allow(clippy::too_many_arguments)]
pub(super) fn foveated(
    scene: &Scene,
    cam: &Camera,
    settings: &Settings,
    frame: &mut Frame,
    stats: &mut Stats,
    scratch: &mut Scratch,
    kept: bool,
    mut t: Instant,
) {
    let Scratch {
        mask,
        vertex_hits,
        refined,
        touched,
        owner,
        stages,
        reuse,
        ..
    } = scratch;
    let Some(m) = mask.as_ref() else {
        return;
    };
    let (w, h) = (frame.width_px as usize, frame.height_px as usize);
    let test = settings.test;
    if !kept {
        vertices_and_cells(
            scene,
            cam,
            settings,
            m,
            vertex_hits,
            refined,
            touched,
            owner,
            stages,
            (w, h),
            &mut t,
        );
    }
    let vertex_hits: &[Option<Hit>] = vertex_hits;
    let refined: &[bool] = refined;
    let owner: &[AtomicU32] = owner;
    let (epoch, samples) = match reuse.as_deref_mut() {
        Some(r) => (r.epoch, Some(&mut r.samples[..])),
        None => (0, None),
    };
    // 5. Cast (or take from the cache) or interpolate, and shade.
    let counts: (u64, u64, u64, f64, u64) = map_rows(
        frame,
        samples,
        |y, mut row, mut kept_row| {
            let surface = row.has_surface();
            // Fovea, refine, gap, cast ms, taken from the cache.
            let mut n = (0u64, 0u64, 0u64, 0f64, 0u64);
            let owners = &owner[y * w..(y + 1) * w];
            let py = y as f32 + 0.5;
            // The sample of a pixel whose owner sees nothing: the same
            // wherever it is.
            let empty = texel(scene, cam, [0.5, py], None, Layer::Interpolated, surface);
            // Pixels waiting to be cast as a packet.
            let mut pending = Pending::default();
            // Runs of pixels with one owner.
            let mut x = 0;
            while x < w {
                let o = owners[x].load(Ordering::Relaxed);
                let mut end = x + 1;
                while end < w && owners[end].load(Ordering::Relaxed) == o {
                    end += 1;
                }
                if o == UNOWNED && !settings.check_coverage {
                    fill(&mut row, x..end, empty);
                } else if o == FOVEA || o == UNOWNED || refined[o as usize] {
                    let layer = match o {
                        FOVEA => {
                            n.0 += (end - x) as u64;
                            Layer::Fovea
                        }
                        UNOWNED => {
                            n.2 += (end - x) as u64;
                            Layer::Gap
                        }
                        _ => {
                            n.1 += (end - x) as u64;
                            Layer::Refined
                        }
                    };
                    let t0 = Instant::now();
                    for x in x..end {
                        if let Some(kept) = kept_row.as_deref_mut() {
                            if let Some(hit) = kept[x].get(epoch) {
                                n.4 += 1;
                                let p = [x as f32 + 0.5, py];
                                row.put(x, texel(scene, cam, p, hit, layer, surface));
                                continue;
                            }
                        }
                        // Cast with the row's next pixels to cast, as one
                        // packet (bit-identical to casting each alone), as
                        // long as they lie close together.
                        if !pending.near(x) {
                            pending.flush(
                                scene,
                                cam,
                                py,
                                test,
                                &mut row,
                                kept_row.as_deref_mut(),
                                epoch,
                            );
                        }
                        if pending.push(x, layer) {
                            pending.flush(
                                scene,
                                cam,
                                py,
                                test,
                                &mut row,
                                kept_row.as_deref_mut(),
                                epoch,
                            );
                        }
                    }
                    n.3 += t0.elapsed().as_secs_f64() * 1e3;
                } else {
                    let s = CellSetup::new(m, &m.cells[o as usize], vertex_hits);
                    if s.first.is_none() {
                        fill(&mut row, x..end, empty);
                    } else {
                        for x in x..end {
                            let p = [x as f32 + 0.5, py];
                            let t = texel(
                                scene,
                                cam,
                                p,
                                s.interpolate(p),
                                Layer::Interpolated,
                                surface,
                            );
                            row.put(x, t);
                        }
                    }
                }
                x = end;
            }
            let t0 = Instant::now();
            pending.flush(
                scene,
                cam,
                py,
                test,
                &mut row,
                kept_row.as_deref_mut(),
                epoch,
            );
            n.3 += t0.elapsed().as_secs_f64() * 1e3;
            n
        },
        |a, b| (a.0 + b.0, a.1 + b.1, a.2 + b.2, a.3 + b.3, a.4 + b.4),
    );
    if let Some(r) = reuse.as_deref_mut() {
        r.stats.pixels_reused = counts.4;
        r.stats.pixels_cast = counts.0 + counts.1 + counts.2 - counts.4;
    }
    stats.rays_fovea = counts.0;
    stats.rays_mask = m.vertices.len() as u64;
    stats.rays_refine = counts.1 + counts.2;
    stats.pixels_uncovered = counts.2;
    stats.rays_total = stats.rays_fovea + stats.rays_mask + stats.rays_refine;
    stats.cells_total = m.cells.len() as u64;
    stats.cells_refined = refined.iter().filter(|r| **r).count() as u64;
    stages.pixels = lap(&mut t);
    stages.pixel_casts_cpu = counts.3;
}

/// The widest run of a row, in pixels, whose pixels to cast share a packet.
const PACKET_SPAN: usize = 16;

/// Up to [`PACKET`] pixels of one row waiting to be cast together
/// ([`Scene::intersect_packet`]), with the layer each is drawn in.
pub(super) struct Pending {
    x: [usize; PACKET],
    layer: [Layer; PACKET],
    len: usize,
}

impl Default for Pending {
    fn default() -> Self {
        Self {
            x: [0; PACKET],
            layer: [Layer::Fovea; PACKET],
            len: 0,
        }
    }
}

impl Pending {
    /// Whether pixel `x` is close enough to the waiting pixels to share
    /// their packet (within [`PACKET_SPAN`] pixels of the first): rays
    /// far apart share little of a traversal.
    #[inline]
    pub(super) fn near(&self, x: usize) -> bool {
        self.len == 0 || x < self.x[0] + PACKET_SPAN
    }

    /// Adds pixel `x`; true when the packet is full (flush it).
    #[inline]
    pub(super) fn push(&mut self, x: usize, layer: Layer) -> bool {
        self.x[self.len] = x;
        self.layer[self.len] = layer;
        self.len += 1;
        self.len == PACKET
    }

    /// Casts the waiting pixels (row centre `py`) as one packet, keeps
    /// their hits in `kept` (the reuse cache's row) when there is one, and
    /// writes their texels.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub(super) fn flush(
        &mut self,
        scene: &Scene,
        cam: &Camera,
        py: f32,
        test: TriangleTest,
        row: &mut RowMut<'_>,
        mut kept: Option<&mut [Sample]>,
        epoch: u32,
    ) {
        let n = self.len;
        if n == 0 {
            return;
        }
        self.len = 0;
        let surface = row.has_surface();
        let mut rays = [cam.ray([0.5, py]); PACKET];
        for (r, &x) in rays.iter_mut().zip(&self.x[..n]) {
            *r = cam.ray([x as f32 + 0.5, py]);
        }
        let mut hits = [None; PACKET];
        scene.intersect_packet(&rays[..n], 0.0, test, &mut hits[..n]);
        for (k, &hit) in hits[..n].iter().enumerate() {
            let x = self.x[k];
            if let Some(kept) = kept.as_deref_mut() {
                kept[x].set(epoch, hit);
            }
            let p = [x as f32 + 0.5, py];
            row.put(x, texel(scene, cam, p, hit, self.layer[k], surface));
        }
    }
}

/// Writes the one sample `t` to the pixels `xs` of `row`.
pub(super) fn fill(row: &mut RowMut<'_>, xs: std::ops::Range<usize>, t: Texel) {
    for px in row.rgb[3 * xs.start..3 * xs.end].chunks_exact_mut(3) {
        px.copy_from_slice(&t.rgb);
    }
    row.hit[xs.clone()].fill(t.hit);
    row.layer[xs.clone()].fill(t.layer);
    if row.has_surface() {
        let (d, o, n) = match t.surface {
            Some((d, o, n)) => (d, o, n.to_array()),
            None => (f32::INFINITY, NO_OBJECT, [0.0; 3]),
        };
        row.depth_mm[xs.clone()].fill(d);
        row.object[xs.clone()].fill(o);
        row.normal[xs].fill(n);
    }
}

/// A homogeneous cell's corners, prepared once for interpolating at the
/// pixels it owns (the same arithmetic as per pixel, so the same bits).
pub(super) struct CellSetup {
    /// Hits at the corners; `None` for a cell whose first corner misses.
    hits: [Option<Hit>; 4],
    first: Option<Hit>,
    /// Per triangle: corner indices, `a`, `b - a`, `c - a` and the doubled
    /// signed area `d` (`None` when zero: the triangle is skipped).
    tris: [Option<Tri>; 2],
    last: usize,
}

#[derive(Clone, Copy)]
pub(super) struct Tri {
    idx: [usize; 3],
    a: [f32; 2],
    ba: [f32; 2],
    ca: [f32; 2],
    d: f32,
}

impl CellSetup {
    fn new(m: &RayMask, cell: &[u32; 4], hits: &[Option<Hit>]) -> Self {
        let corners = corners_of(cell);
        let mut h = [None; 4];
        for (k, &v) in corners.iter().enumerate() {
            h[k] = hits[v as usize];
        }
        let first = h[0];
        let pos = |v: u32| m.vertices[v as usize];
        let tris: &[[usize; 3]] = if corners.len() == 4 {
            &[[0, 1, 2], [0, 2, 3]]
        } else {
            &[[0, 1, 2]]
        };
        let mut out = [None; 2];
        if first.is_some() {
            for (k, t) in tris.iter().enumerate() {
                let (a, b, c) = (pos(corners[t[0]]), pos(corners[t[1]]), pos(corners[t[2]]));
                let ba = [b[0] - a[0], b[1] - a[1]];
                let ca = [c[0] - a[0], c[1] - a[1]];
                let d = ba[0] * ca[1] - ba[1] * ca[0];
                if d != 0.0 {
                    out[k] = Some(Tri {
                        idx: *t,
                        a,
                        ba,
                        ca,
                        d,
                    });
                }
            }
        }
        Self {
            hits: h,
            first,
            tris: out,
            last: tris.len() - 1,
        }
    }

    /// Distance and normal at `p`, interpolated from the corners (quads as
    /// two triangles): the hit the interpolated sample stands for.
    #[inline]
    fn interpolate(&self, p: [f32; 2]) -> Option<Hit> {
        let first = self.first?;
        let mut weights = None;
        for (k, t) in self.tris.iter().enumerate() {
            let Some(t) = t else { continue };
            let (pa0, pa1) = (p[0] - t.a[0], p[1] - t.a[1]);
            let wb = (pa0 * t.ca[1] - pa1 * t.ca[0]) / t.d;
            let wc = (t.ba[0] * pa1 - t.ba[1] * pa0) / t.d;
            let wa = 1.0 - wb - wc;
            let inside = wa >= -1e-4 && wb >= -1e-4 && wc >= -1e-4;
            if inside || k == self.last {
                weights = Some((t.idx, [wa, wb, wc]));
                if inside {
                    break;
                }
            }
        }
        let Some((t, wts)) = weights else {
            return Some(first);
        };
        let mut dist = 0.0;
        let mut normal = Vec3::ZERO;
        for (k, &idx) in t.iter().enumerate() {
            let h = self.hits[idx].unwrap_or(first);
            dist += wts[k] * h.t;
            normal += wts[k] * h.normal;
        }
        Some(Hit {
            t: dist,
            object: first.object,
            triangle: first.triangle,
            normal: normal.try_normalize().unwrap_or(first.normal),
        })
    }
}
