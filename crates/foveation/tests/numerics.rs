//! Numerically hard cases stay finite and correct (property tests over wide
//! ranges: zero, huge, tiny, NaN).

mod common;

use foveation::perceptibility::ThresholdTable;
use foveation::thin_lens::{mipmap_level, EyeLens};
use foveation::{degradation, Display, GeislerPerry};
use proptest::prelude::*;
use twofloat::TwoFloat;

fn display(distance_mm: f64) -> Display {
    Display {
        name: "t".into(),
        resolution_px: (1920, 1080),
        size_mm: (531.4, 298.9),
        eye_distance_mm: distance_mm,
        eye_point_px: None,
    }
}

/// Eccentricity in double-double arithmetic, from the same geometry, as the
/// high-precision reference.
fn reference_eccentricity_deg(d: &Display, a: [f64; 2], b: [f64; 2]) -> f64 {
    let g = d.geometry().expect("geometry");
    let t = TwoFloat::from;
    let v = |p: [f64; 2]| {
        [
            (t(p[0]) - t(g.eye_point_px[0])) * t(g.pitch_x_mm),
            (t(p[1]) - t(g.eye_point_px[1])) * t(g.pitch_y_mm),
            -t(g.eye_distance_mm),
        ]
    };
    let (va, vb) = (v(a), v(b));
    let cross = [
        va[1] * vb[2] - va[2] * vb[1],
        va[2] * vb[0] - va[0] * vb[2],
        va[0] * vb[1] - va[1] * vb[0],
    ];
    let norm = (cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2]).sqrt();
    let dot = va[0] * vb[0] + va[1] * vb[1] + va[2] * vb[2];
    let rad: f64 = norm.atan2(dot).into();
    rad.to_degrees()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: fixtures::proptest_cases(2000), ..ProptestConfig::default() })]

    #[test]
    fn eccentricity_of_identical_points_is_exactly_zero(
        x in -1e6f64..1e6, y in -1e6f64..1e6, log_d in -6.0f64..9.0,
    ) {
        let g = display(10f64.powf(log_d)).geometry().expect("geometry");
        prop_assert_eq!(g.eccentricity_deg([x, y], [x, y]), 0.0);
    }

    #[test]
    fn eccentricity_of_nearly_identical_points_matches_double_double(
        x in 0.0f64..1920.0, y in 0.0f64..1080.0,
        log_offset in -9.0f64..0.0, angle in 0.0f64..std::f64::consts::TAU,
        log_d in 1.0f64..4.0,
    ) {
        let d = display(10f64.powf(log_d));
        let off = 10f64.powf(log_offset);
        let (a, b) = ([x, y], [x + off * angle.cos(), y + off * angle.sin()]);
        let got = d.geometry().expect("geometry").eccentricity_deg(a, b);
        let want = reference_eccentricity_deg(&d, a, b);
        prop_assert!(want > 0.0);
        prop_assert!(((got - want) / want).abs() < 1e-9, "got {} want {}", got, want);
    }

    #[test]
    fn eccentricity_is_finite_symmetric_and_bounded_for_any_eye_distance(
        a in (-1e5f64..1e5, -1e5f64..1e5), b in (-1e5f64..1e5, -1e5f64..1e5), log_d in -9.0f64..12.0,
    ) {
        let g = display(10f64.powf(log_d)).geometry().expect("geometry");
        let (a, b) = ([a.0, a.1], [b.0, b.1]);
        let e = g.eccentricity_deg(a, b);
        prop_assert!(e.is_finite() && (0.0..=180.0).contains(&e));
        prop_assert!((e - g.eccentricity_deg(b, a)).abs() <= 1e-9 * e.max(1.0));
        let ppd = g.local_ppd(a);
        prop_assert!(ppd.is_finite() && ppd > 0.0);
    }

    #[test]
    fn csf_is_never_nan_for_non_nan_input(
        f in prop_oneof![Just(0.0), Just(f64::INFINITY), 0.0f64..1e300],
        e in prop_oneof![Just(0.0), Just(f64::INFINITY), -10.0f64..1e300],
        c in prop_oneof![Just(0.0), Just(1.0 / 64.0), Just(1.0), -1.0f64..10.0],
    ) {
        let m = GeislerPerry::default();
        let t = m.contrast_threshold(f, e);
        prop_assert!(!t.is_nan() && t >= m.ct0);
        let fc = m.cutoff_frequency_cpd(c, e);
        prop_assert!(!fc.is_nan() && fc >= 0.0);
        if c <= m.ct0 {
            prop_assert_eq!(fc, 0.0);
            prop_assert_eq!(m.eccentricity_limit_deg(f, c), None);
        }
        if let Some(limit) = m.eccentricity_limit_deg(f, c) {
            prop_assert!(limit >= 0.0);
        }
    }

    #[test]
    fn csf_threshold_grows_with_frequency_and_eccentricity(
        f in 0.0f64..100.0, df in 0.0f64..10.0, e in 0.0f64..90.0, de in 0.0f64..10.0,
    ) {
        let m = GeislerPerry::default();
        prop_assert!(m.contrast_threshold(f + df, e) >= m.contrast_threshold(f, e));
        prop_assert!(m.contrast_threshold(f, e + de) >= m.contrast_threshold(f, e));
        prop_assert!(m.cutoff_frequency_cpd(1.0, e + de) <= m.cutoff_frequency_cpd(1.0, e));
    }

    #[test]
    fn perceptibility_table_agrees_with_the_model_between_grid_points(
        f in 0.5f64..64.0, e in 0.0f64..90.0, c in 0.001f64..1.0,
    ) {
        let model = GeislerPerry::default();
        let table = ThresholdTable::from_model(&model);
        let t = table.threshold(f, e);
        // log CT is bilinear in (f, e), so interpolating log thresholds is exact.
        let exact = model.contrast_threshold(f, e);
        prop_assert!((t / exact - 1.0).abs() < 1e-9, "{} vs {}", t, exact);
        prop_assert_eq!(table.is_perceptible(c, f, e), c >= t);
    }

    #[test]
    fn perceptibility_never_panics_and_nan_means_perceptible(
        c in prop_oneof![Just(f64::NAN), -1.0f64..2.0],
        f in prop_oneof![Just(f64::NAN), Just(0.0), Just(f64::INFINITY), -10.0f64..1e6],
        e in prop_oneof![Just(f64::NAN), Just(f64::INFINITY), -10.0f64..1e6],
    ) {
        let table = ThresholdTable::from_model(&GeislerPerry::default());
        let p = table.is_perceptible(c, f, e);
        if c.is_nan() || f.is_nan() || e.is_nan() {
            prop_assert!(p);
        }
        let d = table.imperceptible_distance_mm(c, 1.0, e);
        prop_assert!(!d.is_nan() && d >= 0.0);
    }

    #[test]
    fn thin_lens_is_finite_beyond_the_focal_length(
        d in prop_oneof![Just(f64::INFINITY), 16.8f64..1e9],
        f in prop_oneof![Just(f64::INFINITY), 16.8f64..1e9],
    ) {
        let lens = EyeLens::default();
        let c = lens.coc_px(d, f, 600.0, 3.6).expect("valid depths");
        prop_assert!(c.is_finite() && c >= 0.0);
        let m = mipmap_level(c / 2.0);
        prop_assert!(m.is_finite() && m >= 0.0);
    }

    #[test]
    fn degradation_lookup_is_total_over_its_domain(e in 0.0f64..1e6, depth in 0usize..5) {
        let level = degradation::level_for(e, depth).expect("in the table");
        prop_assert!((1..=5).contains(&level));
    }
}

#[test]
fn eye_distance_tiny_and_huge_keeps_geometry_finite() {
    for dist in [1e-9, 1e-3, 1e6, 1e15] {
        let g = display(dist).geometry().expect("geometry");
        let e = g.eccentricity_deg([0.0, 0.0], [1919.0, 1079.0]);
        assert!(e.is_finite() && (0.0..180.0).contains(&e), "{dist}: {e}");
        assert!(g.local_ppd([0.0, 0.0]).is_finite());
    }
    assert!(display(0.0).geometry().is_err());
    assert!(display(-1.0).geometry().is_err());
    assert!(display(f64::NAN).geometry().is_err());
}

#[test]
fn threshold_table_round_trips_through_ron() {
    let table = ThresholdTable::from_model(&GeislerPerry::default());
    let text = ron::to_string(&table).expect("serialise");
    let back: ThresholdTable = ron::from_str(&text).expect("parse");
    assert_eq!(back, table);
    let bad = "(frequencies_cpd: [2.0, 1.0], eccentricities_deg: [0.0], thresholds: [[0.1, 0.2]])";
    let err = ron::from_str::<ThresholdTable>(bad).expect_err("unsorted axis");
    assert!(err.to_string().contains("frequencies_cpd"), "{err}");
}
