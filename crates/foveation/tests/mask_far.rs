//! A point of regard far off the screen (or any f64 at all) costs what is
//! on the screen: the ray mask's work is bounded by counts derived from the
//! screen size, never by how far away the gaze is, and a mask for a far gaze
//! still tiles and samples the screen. Also: models whose screen exceeds the
//! size limits are refused before anything is allocated.

mod common;

use std::sync::OnceLock;

use common::{clip_to_rect, model, polygon_area, PointIndex};
use foveation::mask::{self, Layout, RayMask, FAR_POR_PX};
use foveation::sampling::SEED_MAX_SPACING_PX;
use foveation::{Display, GeislerPerry, SamplingModel, ScreenGeometry};
use proptest::prelude::*;

/// A display of `wmm`×`hmm` at the seed's eye distance.
fn display(name: &str, w: u32, h: u32, wmm: f64, hmm: f64) -> Display {
    Display {
        name: name.into(),
        size_mm: (wmm, hmm),
        ..Display::seed_17in(w, h)
    }
}

/// Small displays for the property test: coarse pixels (about 2 px/deg, so
/// the allowed spacing stays near one pixel and the rings are dense) and
/// fine pixels (about 37 px/deg, the 17" set-up's pitch).
fn small_displays() -> [Display; 2] {
    [
        Display::seed_17in(64, 48),
        display("fine 160x120", 160, 120, 42.2, 31.7),
    ]
}

fn diagonal_px(m: &SamplingModel) -> f64 {
    let [w, h] = m.geometry.size_px();
    w.hypot(h)
}

/// Distance from `p` to the screen rectangle `[0, w] × [0, h]`.
fn distance_to_screen(p: [f64; 2], w: f64, h: f64) -> f64 {
    let dx = (-p[0]).max(p[0] - w).max(0.0);
    let dy = (-p[1]).max(p[1] - h).max(0.0);
    dx.hypot(dy)
}

/// The most work any on-screen gaze costs: maxima of rings, mesh vertices,
/// cells and rays over a 9 × 9 grid of gazes that includes the corners, the
/// edges and the centre, for both layouts.
#[derive(Debug, Clone, Copy)]
struct Work {
    rings: usize,
    vertices: usize,
    cells: usize,
    rays: usize,
}

fn work(m: &RayMask) -> Work {
    Work {
        rings: m.rings.len(),
        vertices: m.vertices.len(),
        cells: m.cells.len(),
        rays: m.rays(),
    }
}

fn worst_on_screen(mdl: &SamplingModel) -> Work {
    let [w, h] = mdl.geometry.size_px();
    let mut worst = Work {
        rings: 0,
        vertices: 0,
        cells: 0,
        rays: 0,
    };
    for i in 0..=8 {
        for j in 0..=8 {
            let por = [w * f64::from(i) / 8.0, h * f64::from(j) / 8.0];
            for layout in [Layout::Nyquist, Layout::Seed] {
                let m = work(&mask::build(mdl, layout, por).expect("on-screen mask"));
                worst.rings = worst.rings.max(m.rings);
                worst.vertices = worst.vertices.max(m.vertices);
                worst.cells = worst.cells.max(m.cells);
                worst.rays = worst.rays.max(m.rays);
            }
        }
    }
    worst
}

/// The bound a gaze anywhere must stay within: twice the worst on-screen
/// work (vertices and cells against the worst on-screen vertex, cell or ray
/// count: where the fovea covers the whole screen there are no on-screen
/// rings to compare with), plus rings for one screen diagonal (a gaze off
/// the screen sees the whole screen beyond its nearest point, at most a
/// diagonal deep).
///
/// A gaze far off the screen sees it through rings that are straight
/// strips across it, covering the screen's bounding box in the gaze's
/// frame: up to `(w + h)² / 2` pixels (at 45°), about twice the screen's
/// area. Where the CSF still asks for one ray per pixel there — the coarse
/// 64×48 test display has 0.56° pixels, and the Nyquist spacing at 90°
/// eccentricity is 0.51° — the mask has a vertex per pixel of that box, so
/// the vertex and cell bounds take the box, not the screen, as their
/// measure. A gaze 65 million px off toward the lower right once made 6774
/// vertices against a bound of 6208 from the screen alone.
fn check_bounded(mdl: &SamplingModel, worst: Work, m: &RayMask) -> Result<(), TestCaseError> {
    let got = work(m);
    let [w, h] = mdl.geometry.size_px();
    let strips = ((w + h) * (w + h) / 2.0).ceil() as usize;
    let vertex_bound = 2 * worst.vertices.max(worst.rays).max(strips) + 64;
    let cell_bound = 2 * worst.cells.max(worst.rays).max(strips) + 64;
    let ring_bound = 2 * worst.rings + diagonal_px(mdl).ceil() as usize + 40;
    prop_assert!(
        got.rings <= ring_bound,
        "gaze {:?}: {} rings, bound {ring_bound}",
        m.por_px,
        got.rings
    );
    prop_assert!(
        got.vertices <= vertex_bound,
        "gaze {:?}: {} vertices, bound {vertex_bound}",
        m.por_px,
        got.vertices
    );
    prop_assert!(
        got.cells <= cell_bound,
        "gaze {:?}: {} cells, bound {cell_bound}",
        m.por_px,
        got.cells
    );
    prop_assert!(m.fovea_rays() as f64 <= w * h);
    Ok(())
}

fn small_models() -> &'static [(SamplingModel, Work); 2] {
    static MODELS: OnceLock<[(SamplingModel, Work); 2]> = OnceLock::new();
    MODELS.get_or_init(|| {
        small_displays().map(|d| {
            let mdl = model(&d, 1.0);
            (mdl, worst_on_screen(&mdl))
        })
    })
}

/// One gaze coordinate: anything an f64 can hold (NaN, ±∞, subnormals,
/// ±1e300, ±f64::MAX), values near the screen, and magnitudes spread evenly
/// over every decade from 1e-300 to 1e300.
fn coordinate() -> impl Strategy<Value = f64> {
    prop_oneof![
        any::<f64>(),
        prop::sample::select(vec![
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::MAX,
            f64::MIN,
            1e300,
            -1e300,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
            5e-324,
            0.0,
            -0.0,
            1.5e17,
            -1.5e17,
        ]),
        -300.0f64..500.0,
        (-300.0f64..300.0, any::<bool>()).prop_map(|(e, neg)| {
            let v = 10f64.powf(e);
            if neg {
                -v
            } else {
                v
            }
        }),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: fixtures::proptest_cases(512), ..ProptestConfig::default() })]

    /// Any f64 gaze: a non-finite one is an error naming the coordinate, a
    /// finite one gives a mask whose work (rings, vertices, cells) stays
    /// within a bound computed from on-screen gazes, however far it is.
    #[test]
    fn any_gaze_is_an_error_or_a_mask_costing_what_is_on_the_screen(
        x in coordinate(),
        y in coordinate(),
        which in 0usize..2,
        seed_layout in any::<bool>(),
    ) {
        let (mdl, worst) = &small_models()[which];
        let layout = if seed_layout { Layout::Seed } else { Layout::Nyquist };
        match mask::build(mdl, layout, [x, y]) {
            Err(e) => {
                prop_assert!(!x.is_finite() || !y.is_finite(), "finite gaze {x}, {y} refused: {e}");
                prop_assert_eq!(e.field, if x.is_finite() { "gaze.y" } else { "gaze.x" });
            }
            Ok(m) => {
                prop_assert!(x.is_finite() && y.is_finite());
                check_bounded(mdl, *worst, &m)?;
                prop_assert!(m.vertices.iter().all(|v| v[0].is_finite() && v[1].is_finite()));
                prop_assert!(m.por_px[0].is_finite() && m.por_px[1].is_finite());
            }
        }
    }
}

/// Gazes at distance `d` beyond the bottom-right corner, the right edge,
/// the top edge and the top-left corner of a `w × h` screen.
fn gazes_at(d: f64, w: f64, h: f64) -> [[f64; 2]; 4] {
    [
        [w + 0.8 * d, h + 0.6 * d],
        [w + d, h * 0.4],
        [w * 0.3, -d],
        [-0.6 * d, -0.8 * d],
    ]
}

/// The shipped 17" and 27" 4K set-ups, with gazes from one screen diagonal
/// to 1e6 px off the screen: none costs more than the worst on-screen gaze
/// (the rings start where they can first reach the screen).
#[test]
fn far_gaze_costs_no_more_than_an_on_screen_one() {
    let displays = [
        Display::seed_17in(1280, 1024),
        display("27in 3840x2160", 3840, 2160, 596.7, 335.7),
    ];
    for d in displays {
        let mdl = model(&d, 1.0);
        let worst = worst_on_screen(&mdl);
        let [w, h] = mdl.geometry.size_px();
        for dist in [diagonal_px(&mdl), 1e3, 1e4, 1e5, 1e6] {
            for por in gazes_at(dist, w, h) {
                for layout in [Layout::Nyquist, Layout::Seed] {
                    let m = mask::build(&mdl, layout, por).expect("finite gaze");
                    if let Err(e) = check_bounded(&mdl, worst, &m) {
                        panic!("{} {layout:?} at {dist} px off: {e}", d.name);
                    }
                    // The rings start at the nearest screen point, not at
                    // the gaze: no ring lies wholly inside that distance.
                    let nearest = distance_to_screen(por, w, h);
                    assert!(
                        m.rings.len() < 2 || m.rings[1].radius_px >= nearest,
                        "{} {layout:?} at {dist} px off: ring 1 at {} px, screen from {nearest} px",
                        d.name,
                        m.rings[1].radius_px
                    );
                }
            }
        }
    }
}

/// A gaze farther than FAR_POR_PX from the screen is built as its stand-in
/// at exactly that distance, in the same direction from the nearest screen
/// point; the fovea disc is then off the screen.
#[test]
fn far_gaze_mask_is_the_mask_of_its_stand_in_at_far_por_px() {
    let d = &small_displays()[1];
    let mdl = model(d, 1.0);
    let [w, h] = mdl.geometry.size_px();
    // 1.2·FAR_POR_PX off a corner: each coordinate is within FAR_POR_PX of
    // the screen, the distance is not.
    for dist in [1.2 * FAR_POR_PX, 2.0 * FAR_POR_PX, 1e15, 1e300] {
        for por in gazes_at(dist, w, h) {
            for layout in [Layout::Nyquist, Layout::Seed] {
                let m = mask::build(&mdl, layout, por).expect("finite gaze");
                let stand_in = m.por_px;
                let at = distance_to_screen(stand_in, w, h);
                assert!(
                    (at - FAR_POR_PX).abs() <= 1e-6 * FAR_POR_PX,
                    "{por:?} stands in at {stand_in:?}, {at} px off"
                );
                // Same direction from the nearest screen point.
                let near = [por[0].clamp(0.0, w), por[1].clamp(0.0, h)];
                let (u, v) = (
                    [por[0] - near[0], por[1] - near[1]],
                    [stand_in[0] - near[0], stand_in[1] - near[1]],
                );
                let (nu, nv) = (u[0].hypot(u[1]), v[0].hypot(v[1]));
                let cos = (u[0] / nu) * (v[0] / nv) + (u[1] / nu) * (v[1] / nv);
                assert!(cos > 1.0 - 1e-12, "{por:?} -> {stand_in:?}");
                assert_eq!(m.fovea_rays(), 0, "{por:?}: fovea on the screen");
                let again = mask::build(&mdl, layout, stand_in).expect("stand-in");
                assert_eq!(again.vertices, m.vertices);
                assert_eq!(again.cells, m.cells);
            }
        }
    }
    // Up to FAR_POR_PX the gaze is kept as given.
    let por = [w + FAR_POR_PX, h / 2.0];
    assert_eq!(
        mask::build(&mdl, Layout::Nyquist, por)
            .expect("mask")
            .por_px,
        por
    );
}

/// Masks for far gazes still cover the whole screen: their cells, clipped
/// to it, add up to its area (no fovea on it), and every sampled pixel has a
/// ray within the spacing allowed for the gaze as given (not its stand-in).
#[test]
fn far_gaze_mask_tiles_and_samples_the_screen() {
    let d = Display::seed_17in(1280, 1024);
    let mdl = model(&d, 1.0);
    let [w, h] = mdl.geometry.size_px();
    let mut rng = 0x2545_F491_4F6C_DD1Du64;
    let mut next = move || {
        rng ^= rng << 13;
        rng ^= rng >> 7;
        rng ^= rng << 17;
        (rng >> 11) as f64 / (1u64 << 53) as f64
    };
    let pixels: Vec<[f64; 2]> = (0..400)
        .map(|_| [(next() * w).floor() + 0.5, (next() * h).floor() + 0.5])
        .collect();
    for dist in [diagonal_px(&mdl), 1e4, 1e6, 1e9] {
        for por in gazes_at(dist, w, h) {
            for layout in [Layout::Nyquist, Layout::Seed] {
                let m = mask::build(&mdl, layout, por).expect("finite gaze");
                let area: f64 = (0..m.cells.len())
                    .map(|i| polygon_area(&clip_to_rect(&m.cell_corners(i), w, h)))
                    .sum();
                assert!(
                    (area - w * h).abs() < 1e-4 * w * h,
                    "{layout:?} {por:?}: cells cover {area:.1} px² of {:.1}",
                    w * h
                );
                let index = PointIndex::new(
                    m.vertices
                        .iter()
                        .map(|v| [f64::from(v[0]), f64::from(v[1])]),
                    8.0,
                );
                for &p in &pixels {
                    let allowed = mdl.spacing_at(por, p).spacing_px;
                    let reach = std::f64::consts::FRAC_1_SQRT_2 * 1.06 * allowed;
                    assert!(
                        index.nearest_within(p, reach).is_some(),
                        "{layout:?} {por:?}: pixel {p:?} has no ray within {reach:.2} px"
                    );
                }
            }
        }
    }
}

/// Defence in depth: a model whose geometry exceeds the display limits
/// (built by hand, not through `Display::geometry`) is refused by the mask
/// builder, naming the resolution, before it allocates anything.
#[test]
fn oversized_geometry_is_refused_by_the_mask_builder() {
    let geometry = |w: u32, h: u32| ScreenGeometry {
        width_px: w,
        height_px: h,
        pitch_x_mm: 0.25,
        pitch_y_mm: 0.25,
        eye_point_px: [f64::from(w) / 2.0, f64::from(h) / 2.0],
        eye_distance_mm: 600.0,
    };
    for (w, h, field) in [
        (16_385, 16, "resolution_px.0"),
        (16, 16_385, "resolution_px.1"),
        (8_193, 8_193, "resolution_px"),
        (u32::MAX, u32::MAX, "resolution_px.0"),
        (0, 10, "resolution_px.0"),
    ] {
        let mdl = SamplingModel::new(
            geometry(w, h),
            GeislerPerry::default(),
            1.0,
            SEED_MAX_SPACING_PX,
        )
        .expect("model");
        let Err(err) = mask::build(&mdl, Layout::Nyquist, [1.0, 1.0]) else {
            panic!("{w}x{h}: oversized geometry must be refused");
        };
        assert_eq!(err.field, field, "{w}x{h}: {err}");
    }
    let mdl = SamplingModel::new(
        geometry(8_192, 8_192),
        GeislerPerry::default(),
        1.0,
        SEED_MAX_SPACING_PX,
    )
    .expect("model");
    assert!(mask::build(&mdl, Layout::Nyquist, [4096.0, 4096.0]).is_ok());
}
