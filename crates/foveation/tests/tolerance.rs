//! The gaze tolerance: a mask built for a POR `c` with tolerance `ε` is
//! dense enough for every POR within `ε` of `c` at the eye; no tolerance
//! leaves every mask as it was; bad tolerances are refused by name.

mod common;

use common::{displays, model};
use foveation::mask::{self, Layout};
use foveation::sampling::MAX_GAZE_TOLERANCE_DEG;
use proptest::prelude::*;

#[test]
fn no_tolerance_is_the_mask_of_the_csf_alone() {
    common::assert_same_masks(|m| m.with_gaze_tolerance_deg(0.0).expect("0 is none"));
}

#[test]
fn bad_tolerances_are_refused_by_name() {
    let m = model(&displays()[0], 1.0);
    for bad in [
        f64::NAN,
        f64::INFINITY,
        -0.1,
        MAX_GAZE_TOLERANCE_DEG + 1e-9,
        1e300,
    ] {
        let e = m.with_gaze_tolerance_deg(bad).expect_err("refused");
        assert_eq!(e.field, "gaze_tolerance_deg", "{bad}");
    }
    assert!(m.with_gaze_tolerance_deg(MAX_GAZE_TOLERANCE_DEG).is_ok());
}

#[test]
fn within_tolerance_needs_a_tolerance_and_finite_points() {
    let m = model(&displays()[0], 1.0);
    assert!(!m.within_tolerance([640.0, 512.0], [640.0, 512.0]), "ε = 0");
    let t = m.with_gaze_tolerance_deg(0.5).expect("tolerance");
    assert!(t.within_tolerance([640.0, 512.0], [640.0, 512.0]));
    assert!(t.within_tolerance([640.0, 512.0], [650.0, 512.0]));
    // 0.5° at 54 cm is about 18 px of 0.264 mm.
    assert!(!t.within_tolerance([640.0, 512.0], [680.0, 512.0]));
    for bad in [f64::NAN, f64::INFINITY, f64::NEG_INFINITY] {
        assert!(!t.within_tolerance([640.0, 512.0], [bad, 512.0]));
        assert!(!t.within_tolerance([bad, 512.0], [640.0, 512.0]));
    }
}

#[test]
fn a_wider_tolerance_casts_more_rays() {
    let d = &displays()[0];
    let mut last = 0;
    for eps in [0.0, 0.25, 0.5, 1.0, 2.0] {
        let m = model(d, 1.0)
            .with_gaze_tolerance_deg(eps)
            .expect("tolerance");
        let k = mask::build(&m, Layout::Nyquist, [640.0, 512.0]).expect("mask");
        let rays = k.fovea_rays() + k.ring_rays();
        assert!(rays > last, "{eps}°: {rays} rays, not more than {last}");
        last = rays;
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(fixtures::proptest_cases(64)))]

    /// The spacing a tolerant model allows at any point for its POR `c` is
    /// at most what the plain model allows there for any POR `g` within the
    /// tolerance of `c` — so the tolerant mask built at `c` serves `g`.
    #[test]
    fn the_tolerant_spacing_serves_every_gaze_within_it(
        display in 0usize..4,
        eps in 0.01f64..3.0,
        c in (0.0f64..1.0, 0.0f64..1.0),
        dir in 0.0f64..std::f64::consts::TAU,
        frac in 0.0f64..=1.0,
        points in prop::collection::vec((-0.2f64..1.2, -0.2f64..1.2), 16),
    ) {
        let d = &displays()[display];
        let plain = model(d, 1.0);
        let tol = plain.with_gaze_tolerance_deg(eps).expect("tolerance");
        let g = plain.geometry;
        let [w, h] = g.size_px();
        let c = [c.0 * w, c.1 * h];
        // A POR within eps of c: bisect along `dir` for the radius at eps.
        let at = |r: f64| [c[0] + r * dir.cos(), c[1] + r * dir.sin()];
        let (mut lo, mut hi) = (0.0, 4.0 * (w + h));
        for _ in 0..60 {
            let mid = 0.5 * (lo + hi);
            if g.eccentricity_deg(c, at(mid)) <= eps { lo = mid } else { hi = mid }
        }
        let gaze = at(lo * frac);
        prop_assert!(tol.within_tolerance(c, gaze));
        for (x, y) in points {
            let p = [x * w, y * h];
            let a = tol.spacing_at(c, p).spacing_px;
            let b = plain.spacing_at(gaze, p).spacing_px;
            prop_assert!(a <= b * (1.0 + 1e-9), "at {p:?}: {a} px for c, {b} px for the gaze");
        }
        // And the tolerant mask's one-ray-per-pixel disc holds every pixel
        // of the plain mask's disc for that gaze that needs one ray per
        // pixel (the plain disc is round; the spacing is not, so some of
        // its pixels would allow more).
        let mt = mask::build(&tol, Layout::Nyquist, c).expect("mask");
        let mp = mask::build(&plain, Layout::Nyquist, gaze).expect("mask");
        let covered = |x: u32, y: u32| mt.fovea.iter().any(|s| s.y == y && s.x_start <= x && x < s.x_end);
        for s in &mp.fovea {
            for x in [s.x_start, s.x_end - 1] {
                let p = [f64::from(x) + 0.5, f64::from(s.y) + 0.5];
                if plain.spacing_at(gaze, p).spacing_px <= 1.0 {
                    prop_assert!(covered(x, s.y), "pixel ({x}, {}) needs one ray and is outside the tolerant disc", s.y);
                }
            }
        }
    }
}
