//! The ray mask meets the Nyquist spacing everywhere, its mesh tiles the
//! screen outside the fovea with no holes or overlaps, and the nyquist
//! layout stays close to the continuous bound.

mod common;

use common::{clip_to_rect, disc_rect_area, displays, model, polygon_area, PointIndex};
use foveation::mask::{self, Layout, NO_VERTEX};
use foveation::{bound, Display, GeislerPerry, SamplingModel};
use proptest::prelude::*;

fn corners(d: &Display) -> Vec<[f64; 2]> {
    let (w, h) = (f64::from(d.resolution_px.0), f64::from(d.resolution_px.1));
    vec![
        [0.5, 0.5],
        [w - 0.5, 0.5],
        [0.5, h - 0.5],
        [w - 0.5, h - 0.5],
    ]
}

/// Every point a renderer casts: fovea pixels and all mesh vertices
/// (including the few just off the screen that close the edge cells).
fn all_ray_points(m: &mask::RayMask) -> impl Iterator<Item = [f64; 2]> + '_ {
    let fovea = m.ray_positions().take(m.fovea_rays());
    fovea.chain(
        m.vertices
            .iter()
            .map(|v| [f64::from(v[0]), f64::from(v[1])]),
    )
}

/// A sampling lattice whose spacing is at most `s` in both directions leaves
/// no point farther than `s/√2` from a sample (the centre of an `s × s`
/// square; ring triangles do better, 0.625 `s`). The property,
/// "nearest ray ≤ allowed spacing", follows with room to spare; checking the
/// tighter `s/√2` (plus 6 % for the curvature of the rings and the sampled
/// ring minimum) also catches a radial step that is too long.
const NEAREST_FRACTION: f64 = std::f64::consts::FRAC_1_SQRT_2 * 1.06;

fn check_coverage(model: &SamplingModel, layout: Layout, por: [f64; 2], pixels: &[[f64; 2]]) {
    let m = mask::build(model, layout, por).expect("mask builds");
    let index = PointIndex::new(all_ray_points(&m), 8.0);
    for &p in pixels {
        let allowed = model.spacing_at(por, p).spacing_px;
        let reach = (NEAREST_FRACTION * allowed).max(std::f64::consts::FRAC_1_SQRT_2 + 1e-9);
        let nearest = index.nearest_within(p, reach);
        assert!(
            nearest.is_some(),
            "{layout:?} por {por:?}: pixel {p:?} has no ray within {reach:.3} px (allowed spacing {allowed:.3} px)"
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: fixtures::proptest_cases(24), ..ProptestConfig::default() })]

    /// Independent of how the mask is built: for random pixels and random
    /// PORs, some ray lies within the allowed spacing at that pixel.
    #[test]
    fn nearest_ray_is_within_the_allowed_spacing(
        display in 0usize..4,
        por_frac in (0.0f64..1.0, 0.0f64..1.0),
        corner in 0usize..5,
        contrast in prop::sample::select(vec![1.0, 0.5, 0.1]),
        seed_layout in any::<bool>(),
        pixel_fracs in prop::collection::vec((0.0f64..1.0, 0.0f64..1.0), 200),
    ) {
        let d = &displays()[display];
        let (w, h) = (f64::from(d.resolution_px.0), f64::from(d.resolution_px.1));
        let por = if corner < 4 { corners(d)[corner] } else { [por_frac.0 * w, por_frac.1 * h] };
        let pixels: Vec<[f64; 2]> = pixel_fracs.iter().map(|(x, y)| [(x * w).floor() + 0.5, (y * h).floor() + 0.5]).collect();
        let layout = if seed_layout { Layout::Seed } else { Layout::Nyquist };
        check_coverage(&model(d, contrast), layout, por, &pixels);
    }
}

fn check_tiling(model: &SamplingModel, layout: Layout, por: [f64; 2]) {
    let m = mask::build(model, layout, por).expect("mask builds");
    let [w, h] = model.geometry.size_px();
    // Every vertex belongs to a cell; every cell has 3 or 4 distinct corners.
    let mut used = vec![false; m.vertices.len()];
    for c in &m.cells {
        let n = if c[3] == NO_VERTEX { 3 } else { 4 };
        for k in 0..n {
            used[c[k] as usize] = true;
            for l in 0..k {
                assert_ne!(c[k], c[l], "degenerate cell {c:?}");
            }
        }
    }
    assert!(used.iter().all(|u| *u), "a mesh vertex belongs to no cell");
    // Area: cells clipped to the screen add up to the screen minus the fovea disc.
    let cells_area: f64 = (0..m.cells.len())
        .map(|i| polygon_area(&clip_to_rect(&m.cell_corners(i), w, h)))
        .sum();
    let expected = w * h - disc_rect_area(por, m.fovea_radius_px, w, h);
    let tolerance = 1e-4 * w * h + 1.0;
    assert!(
        (cells_area - expected).abs() < tolerance,
        "{layout:?} por {por:?}: cells cover {cells_area:.1} px², expected {expected:.1} (±{tolerance:.1})"
    );
}

#[test]
fn mesh_tiles_the_annulus_without_holes_or_overlaps() {
    for d in displays() {
        let (w, h) = (f64::from(d.resolution_px.0), f64::from(d.resolution_px.1));
        let mut pors = corners(&d);
        pors.extend([
            [w / 2.0, h / 2.0],
            [w * 0.3, h * 0.8],
            [-40.0, h / 3.0],
            [w + 500.0, h + 20.0],
        ]);
        for por in pors {
            for layout in [Layout::Nyquist, Layout::Seed] {
                check_tiling(&model(&d, 1.0), layout, por);
            }
        }
    }
}

#[test]
fn random_points_outside_the_fovea_lie_in_exactly_one_cell() {
    let d = &displays()[0];
    let m = mask::build(&model(d, 1.0), Layout::Nyquist, [200.0, 700.0]).expect("mask");
    // Bucket cells by bounding box, then count containing cells per point.
    let cell = 16.0;
    let mut buckets: std::collections::HashMap<(i64, i64), Vec<usize>> = Default::default();
    for i in 0..m.cells.len() {
        let c = m.cell_corners(i);
        let (x0, x1) = c
            .iter()
            .fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p[0]), b.max(p[0])));
        let (y0, y1) = c
            .iter()
            .fold((f64::MAX, f64::MIN), |(a, b), p| (a.min(p[1]), b.max(p[1])));
        for bx in (x0 / cell).floor() as i64..=(x1 / cell).floor() as i64 {
            for by in (y0 / cell).floor() as i64..=(y1 / cell).floor() as i64 {
                buckets.entry((bx, by)).or_default().push(i);
            }
        }
    }
    let inside = |poly: &[[f64; 2]], q: [f64; 2]| {
        let mut sign = 0.0;
        for k in 0..poly.len() {
            let (a, b) = (poly[k], poly[(k + 1) % poly.len()]);
            let cr = (b[0] - a[0]) * (q[1] - a[1]) - (b[1] - a[1]) * (q[0] - a[0]);
            if cr.abs() < 1e-6 {
                return None; // on an edge: ambiguous, skip
            }
            if sign == 0.0 {
                sign = cr.signum();
            } else if cr.signum() != sign {
                return Some(false);
            }
        }
        Some(true)
    };
    let mut rng = 0x9E37_79B9_7F4A_7C15u64;
    let mut next = || {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        (rng >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut checked = 0;
    for _ in 0..20_000 {
        let q = [next() * 1280.0, next() * 1024.0];
        if (q[0] - 200.0).hypot(q[1] - 700.0) < m.fovea_radius_px + 2.0 {
            continue;
        }
        let key = ((q[0] / cell).floor() as i64, (q[1] / cell).floor() as i64);
        let mut count = 0;
        let mut ambiguous = false;
        for &i in buckets.get(&key).into_iter().flatten() {
            match inside(&m.cell_corners(i), q) {
                Some(true) => count += 1,
                None => ambiguous = true,
                Some(false) => {}
            }
        }
        if !ambiguous {
            assert_eq!(count, 1, "point {q:?} lies in {count} cells");
            checked += 1;
        }
    }
    assert!(checked > 15_000);
}

#[test]
fn every_ray_is_a_fovea_pixel_or_a_mesh_vertex_and_counts_agree() {
    let d = &displays()[2];
    let m = mask::build(&model(d, 1.0), Layout::Nyquist, [960.0, 540.0]).expect("mask");
    assert_eq!(m.ray_positions().count(), m.rays());
    for s in &m.fovea {
        for x in s.x_start..s.x_end {
            let p = [f64::from(x) + 0.5, f64::from(s.y) + 0.5];
            assert!((p[0] - 960.0).hypot(p[1] - 540.0) <= m.fovea_radius_px + 1e-9);
        }
    }
}

#[test]
fn nyquist_layout_stays_within_a_quarter_of_the_continuous_bound() {
    for d in displays() {
        let mdl = model(&d, 1.0);
        for por in [mdl.geometry.centre_px(), [0.5, 0.5]] {
            let b = bound::nyquist_bound_rays(&mdl, por);
            let nyquist = mask::build(&mdl, Layout::Nyquist, por)
                .expect("mask")
                .rays() as f64;
            let seed = mask::build(&mdl, Layout::Seed, por).expect("mask").rays() as f64;
            assert!(
                nyquist <= 1.25 * b,
                "{}: nyquist {nyquist} vs bound {b}",
                d.name
            );
            assert!(
                nyquist >= b * 0.99,
                "{}: fewer rays ({nyquist}) than the bound ({b})?",
                d.name
            );
            assert!(
                seed > nyquist,
                "{}: seed {seed} should cost more than nyquist {nyquist}",
                d.name
            );
        }
    }
}

#[test]
fn bound_on_two_pixel_cells_matches_the_per_pixel_sum() {
    for d in displays().into_iter().take(3) {
        let mdl = model(&d, 1.0);
        for por in [mdl.geometry.centre_px(), [3.0, 5.0]] {
            let fine = bound::integrate(&mdl, por, 1);
            let coarse = bound::nyquist_bound_rays(&mdl, por);
            assert!(
                (coarse / fine - 1.0).abs() < 1e-3,
                "{}: {coarse} vs {fine}",
                d.name
            );
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: fixtures::proptest_cases(64), ..ProptestConfig::default() })]

    /// Any finite POR (on, at the edge of, or far off the screen) and any eye
    /// distance from 1 mm to 100 m gives a mask without panicking, with
    /// finite vertices and a ray count no larger than the pixel count plus
    /// the ring points.
    #[test]
    fn any_por_and_eye_distance_builds_a_sane_mask(
        x in -5000.0f64..6000.0,
        y in -5000.0f64..6000.0,
        log_distance in 0.0f64..5.0,
        contrast in 0.02f64..1.0,
    ) {
        let mut d = displays()[1].clone();
        d.eye_distance_mm = 10f64.powf(log_distance);
        let g = d.geometry().expect("geometry");
        let mdl = SamplingModel::new(g, GeislerPerry::default(), contrast, foveation::sampling::SEED_MAX_SPACING_PX).expect("model");
        let m = mask::build(&mdl, Layout::Nyquist, [x, y]).expect("mask");
        prop_assert!(m.vertices.iter().all(|v| v[0].is_finite() && v[1].is_finite()));
        prop_assert!(m.fovea_rays() <= 640 * 480);
        prop_assert!(m.fovea_radius_px.is_finite() && m.fovea_radius_px >= 1.0);
    }
}

#[test]
fn non_finite_por_and_bad_contrast_are_errors_not_panics() {
    let d = &displays()[0];
    let mdl = model(d, 1.0);
    assert_eq!(
        mask::build(&mdl, Layout::Nyquist, [f64::NAN, 3.0])
            .unwrap_err()
            .field,
        "gaze.x"
    );
    assert_eq!(
        mask::build(&mdl, Layout::Nyquist, [3.0, f64::INFINITY])
            .unwrap_err()
            .field,
        "gaze.y"
    );
    let g = d.geometry().expect("geometry");
    for c in [1.0 / 64.0, 0.0, -1.0, f64::NAN, f64::INFINITY] {
        assert_eq!(
            SamplingModel::new(
                g,
                GeislerPerry::default(),
                c,
                foveation::sampling::SEED_MAX_SPACING_PX
            )
            .unwrap_err()
            .field,
            "contrast"
        );
    }
    assert_eq!(
        SamplingModel::new(g, GeislerPerry::default(), 1.0, 0.5)
            .unwrap_err()
            .field,
        "max_spacing_px"
    );
}

/// Rebuilding a mask in place (what a renderer does frame after frame)
/// gives exactly the mask a fresh build gives, whatever gazes came before.
#[test]
fn a_mask_rebuilt_in_place_is_the_mask_built_afresh() {
    for d in common::displays() {
        let m = common::model(&d, 1.0);
        let [w, h] = m.geometry.size_px();
        let gazes = [
            [0.5 * w, 0.5 * h],
            [0.5 * w + 0.4, 0.5 * h + 0.2],
            [0.1 * w, 0.8 * h],
            [-0.5 * w, 0.3 * h],
            [0.5 * w, 0.5 * h],
            [w, 0.0],
        ];
        for layout in [Layout::Nyquist, Layout::Seed] {
            let mut kept = mask::build(&m, layout, gazes[2]).expect("mask");
            for g in gazes {
                mask::rebuild(&mut kept, &m, layout, g).expect("rebuild");
                let fresh = mask::build(&m, layout, g).expect("mask");
                assert_eq!(kept.vertices, fresh.vertices, "{} {g:?}", d.name);
                assert_eq!(kept.cells, fresh.cells, "{} {g:?}", d.name);
                assert_eq!(kept.fovea, fresh.fovea, "{} {g:?}", d.name);
            }
        }
    }
}

/// Every mesh vertex is a ring point: at one of the rings' radii from the
/// POR and at a whole multiple of that ring's angular step (to 10⁻³ px;
/// the points are stored in f32).
#[test]
fn every_mesh_vertex_sits_on_its_ring_at_a_whole_step() {
    let d = &common::displays()[0];
    let m = common::model(d, 1.0);
    for gaze in [[640.0, 512.0], [300.0, 700.0]] {
        let k = mask::build(&m, Layout::Nyquist, gaze).expect("mask");
        for v in &k.vertices {
            let (dx, dy) = (f64::from(v[0]) - k.por_px[0], f64::from(v[1]) - k.por_px[1]);
            let r = dx.hypot(dy);
            let ring = k
                .rings
                .iter()
                .find(|ring| (ring.radius_px - r).abs() < 0.01)
                .unwrap_or_else(|| panic!("vertex {v:?} at {r} px is on no ring"));
            let step = std::f64::consts::TAU / f64::from(ring.points_per_turn);
            let turns = dy.atan2(dx).rem_euclid(std::f64::consts::TAU) / step;
            let off_px = (turns - turns.round()).abs() * step * r;
            assert!(
                off_px < 1e-3,
                "vertex {v:?}: {off_px} px from a point of the ring of {} at {r}",
                ring.points_per_turn
            );
        }
    }
}
