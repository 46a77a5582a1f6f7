//! Statistics against published worked examples and edge cases.
//!
//! Every expected value below was computed independently of this crate:
//! the sums of squares by hand (exact fractions, shown), the p-values as
//! published (R documentation; Field 2009) and re-derived with a separate
//! regularised-incomplete-beta implementation.

use experiment::stats::{
    self, holm, one_way_anova, pairwise_t_pooled, rm_anova, summarize, StatsError,
};
use proptest::prelude::*;

fn close(got: f64, want: f64, tol: f64, what: &str) {
    assert!(
        (got - want).abs() <= tol,
        "{what}: got {got}, want {want} ± {tol}"
    );
}

// PlantGrowth (Dobson 1983, *An Introduction to Statistical Modelling*,
// R's `datasets::PlantGrowth`): dried plant weight, control and
// two treatments, 10 plants each.
const CTRL: [f64; 10] = [4.17, 5.58, 5.18, 6.11, 4.50, 4.61, 5.17, 4.53, 5.33, 5.14];
const TRT1: [f64; 10] = [4.81, 4.17, 4.41, 3.59, 5.87, 3.83, 6.03, 4.89, 4.32, 4.69];
const TRT2: [f64; 10] = [6.31, 5.12, 5.54, 5.50, 5.37, 5.29, 4.92, 6.15, 5.80, 5.26];

#[test]
fn plant_growth_one_way_anova() {
    // By hand: group sums 50.32, 46.61, 55.26 -> means 5.032, 4.661, 5.526;
    // grand mean 152.19/30 = 5.073.
    // SS_between = 10[(5.032-5.073)^2 + (4.661-5.073)^2 + (5.526-5.073)^2]
    //            = 10[0.001681 + 0.169744 + 0.205209] = 3.76634.
    // SS_within  = 1.07208 + 4.42413 + 0.99588 ... summed exactly = 10.49209.
    // F = (3.76634/2) / (10.49209/27) = 1.88317 / 0.388596 = 4.846088.
    // R: summary(aov(weight ~ group, PlantGrowth)) -> F(2,27) = 4.846,
    // p = 0.01591.
    let a = one_way_anova(&[&CTRL, &TRT1, &TRT2]).unwrap();
    close(a.ss_between, 3.76634, 1e-9, "SS_between");
    close(a.ss_within, 10.49209, 1e-9, "SS_within");
    assert_eq!((a.df_between, a.df_within), (2.0, 27.0));
    close(a.f, 4.846088, 1e-6, "F");
    close(a.p, 0.01591, 5e-6, "p");
}

#[test]
fn plant_growth_pairwise_holm() {
    // Pooled variance = MS_within = 10.49209/27 = 0.388596, df 27.
    // ctrl-trt1: t = 0.371/sqrt(0.388596*0.2) = 1.33079, p = 0.194388
    // ctrl-trt2: t = -0.494/0.278782 = -1.77200,     p = 0.087682
    // trt1-trt2: t = -0.865/0.278782 = -3.10279,     p = 0.004459
    // Holm: 3*0.004459 = 0.013378; 2*0.087682 = 0.175363; 1*0.194388.
    // R: pairwise.t.test(weight, group, p.adjust.method = "holm") prints
    // ctrl-trt1 0.194, ctrl-trt2 0.175, trt1-trt2 0.013.
    let pairs = pairwise_t_pooled(&[&CTRL, &TRT1, &TRT2]).unwrap();
    let got: Vec<(usize, usize)> = pairs.iter().map(|p| (p.a, p.b)).collect();
    assert_eq!(got, vec![(0, 1), (0, 2), (1, 2)]);
    close(pairs[0].t, 1.330791, 1e-5, "t 0-1");
    close(pairs[1].t, -1.771996, 1e-5, "t 0-2");
    close(pairs[2].t, -3.102787, 1e-5, "t 1-2");
    close(pairs[0].p, 0.194388, 1e-5, "p 0-1");
    close(pairs[1].p, 0.087682, 1e-5, "p 0-2");
    close(pairs[2].p, 0.004459, 1e-5, "p 1-2");
    close(pairs[0].p_holm, 0.194388, 1e-5, "holm 0-1");
    close(pairs[1].p_holm, 0.175363, 1e-5, "holm 0-2");
    close(pairs[2].p_holm, 0.013378, 1e-5, "holm 1-2");
    assert!(pairs.iter().all(|p| p.df == 27.0));
}

#[test]
fn unequal_group_sizes_exact() {
    // {1,2,3}, {4,5,6,7}, {8,9}: means 2, 5.5, 8.5; grand mean 45/9 = 5.
    // SS_between = 3*9 + 4*0.25 + 2*12.25 = 27 + 1 + 24.5 = 52.5
    // SS_within  = 2 + 5 + 0.5 = 7.5; df (2, 6)
    // F = 26.25 / 1.25 = 21.
    // For d1 = 2 the F tail is closed-form: p = (1 + d1 F / d2)^(-d2/2)
    //   = (1 + 42/6)^(-3) = 8^-3 = 1/512 = 0.001953125.
    let a = one_way_anova(&[&[1.0, 2.0, 3.0], &[4.0, 5.0, 6.0, 7.0], &[8.0, 9.0]]).unwrap();
    close(a.ss_between, 52.5, 1e-12, "SS_between");
    close(a.ss_within, 7.5, 1e-12, "SS_within");
    assert_eq!((a.df_between, a.df_within), (2.0, 6.0));
    close(a.f, 21.0, 1e-12, "F");
    close(a.p, 1.0 / 512.0, 1e-10, "p");
}

#[test]
fn bushtucker_repeated_measures_greenhouse_geisser() {
    // Field (2009), *Discovering Statistics Using SPSS*, 3rd ed., ch. 13
    // (Bushtucker.sav): 8 celebrities x 4 animals, time to retch (s).
    // By hand: column means 8.125, 4.25, 4.125, 5.75; grand mean 89/16.
    // SS_conditions = 665/8 = 83.125; SS_subjects = 139/8 = 17.375;
    // SS_total = 2031/8 = 253.875; SS_error = 1227/8 = 153.375.
    // F = (83.125/3) / (153.375/21) = 27.7083 / 7.30357 = 3.79381, df (3, 21).
    // Field reports F(3,21) = 3.79, p = .026; GG eps = .533,
    // F(1.60, 11.19) = 3.79, p = .063. Exact eps from the double-centred
    // covariance matrix = 167281/313939 = 0.532846.
    let rows: [[f64; 4]; 8] = [
        [8.0, 7.0, 1.0, 6.0],
        [9.0, 5.0, 2.0, 5.0],
        [6.0, 2.0, 3.0, 8.0],
        [5.0, 3.0, 1.0, 9.0],
        [8.0, 4.0, 5.0, 8.0],
        [7.0, 5.0, 6.0, 7.0],
        [10.0, 2.0, 7.0, 2.0],
        [12.0, 6.0, 8.0, 1.0],
    ];
    let data: Vec<&[f64]> = rows.iter().map(|r| r.as_slice()).collect();
    let r = rm_anova(&data).unwrap();
    close(r.ss_conditions, 83.125, 1e-10, "SS_conditions");
    close(r.ss_subjects, 17.375, 1e-10, "SS_subjects");
    close(r.ss_error, 153.375, 1e-10, "SS_error");
    assert_eq!((r.df_conditions, r.df_error), (3.0, 21.0));
    close(r.f, 3.793806, 1e-6, "F");
    close(r.p, 0.025570, 1e-5, "p");
    close(r.gg_epsilon, 167281.0 / 313939.0, 1e-10, "GG epsilon");
    close(r.p_gg, 0.062584, 1e-5, "p GG");
}

#[test]
fn summary_mean_sd_se() {
    // 2, 4, 4, 4, 5, 5, 7, 9: mean 5, SS 32, s^2 = 32/7, SE = s/sqrt(8).
    let s = summarize(&[2.0, 4.0, 4.0, 4.0, 5.0, 5.0, 7.0, 9.0]).unwrap();
    assert_eq!(s.n, 8);
    close(s.mean, 5.0, 1e-12, "mean");
    close(s.sd, (32.0f64 / 7.0).sqrt(), 1e-12, "sd");
    close(s.se, (32.0f64 / 7.0).sqrt() / 8f64.sqrt(), 1e-12, "se");
    let one = summarize(&[3.5]).unwrap();
    assert_eq!((one.mean, one.sd, one.se), (3.5, 0.0, 0.0));
    assert_eq!(summarize(&[]), Err(StatsError::EmptyGroup(0)));
}

#[test]
fn one_group_is_an_error() {
    assert_eq!(
        one_way_anova(&[&[1.0, 2.0, 3.0]]),
        Err(StatsError::TooFewGroups { needed: 2, got: 1 })
    );
    assert!(matches!(
        pairwise_t_pooled(&[&[1.0, 2.0]]),
        Err(StatsError::TooFewGroups { .. })
    ));
    assert!(matches!(
        rm_anova(&[&[1.0], &[2.0]]),
        Err(StatsError::TooFewGroups { .. })
    ));
}

#[test]
fn nan_and_infinity_are_errors_naming_the_value() {
    let err = one_way_anova(&[&[1.0, 2.0], &[3.0, f64::NAN, 4.0]]).unwrap_err();
    assert!(
        matches!(
            err,
            StatsError::NotFinite {
                group: 1,
                index: 1,
                ..
            }
        ),
        "{err}"
    );
    assert!(matches!(
        summarize(&[1.0, f64::INFINITY]),
        Err(StatsError::NotFinite {
            group: 0,
            index: 1,
            ..
        })
    ));
    assert!(matches!(
        rm_anova(&[&[1.0, 2.0], &[f64::NAN, 2.0]]),
        Err(StatsError::NotFinite {
            group: 1,
            index: 0,
            ..
        })
    ));
}

#[test]
fn zero_variance() {
    // Identical everything: 0/0.
    assert_eq!(
        one_way_anova(&[&[2.0, 2.0], &[2.0, 2.0]]),
        Err(StatsError::ZeroVariance)
    );
    // No within-group spread but different means: F = inf, p = 0.
    let a = one_way_anova(&[&[1.0, 1.0], &[2.0, 2.0]]).unwrap();
    assert!(a.f.is_infinite() && a.p == 0.0);
    assert_eq!(
        pairwise_t_pooled(&[&[1.0, 1.0], &[2.0, 2.0]]),
        Err(StatsError::ZeroVariance)
    );
    // Repeated measures: every subject shifted by a constant -> no error term.
    let r = rm_anova(&[&[1.0, 2.0, 4.0], &[11.0, 12.0, 14.0]]).unwrap();
    assert!(r.f.is_infinite() && r.p == 0.0 && r.p_gg == 0.0);
    assert_eq!(
        rm_anova(&[&[1.0, 1.0], &[5.0, 5.0]]),
        Err(StatsError::ZeroVariance)
    );
}

#[test]
fn degenerate_shapes() {
    assert_eq!(one_way_anova(&[&[1.0], &[2.0]]), Err(StatsError::NoErrorDf));
    assert_eq!(
        one_way_anova(&[&[1.0, 2.0], &[]]),
        Err(StatsError::EmptyGroup(1))
    );
    assert_eq!(rm_anova(&[&[1.0, 2.0]]), Err(StatsError::NoErrorDf));
    assert_eq!(
        rm_anova(&[&[1.0, 2.0], &[1.0]]),
        Err(StatsError::Ragged {
            subject: 1,
            got: 1,
            expected: 2
        })
    );
    // A single-value group is fine when others carry the error df.
    let a = one_way_anova(&[&[1.0], &[2.0, 3.0, 4.0]]).unwrap();
    assert_eq!((a.df_between, a.df_within), (1.0, 2.0));
}

#[test]
fn gg_epsilon_is_one_for_two_conditions() {
    // With k = 2 sphericity holds trivially: eps = 1 and p_gg = p.
    let r = rm_anova(&[&[1.0, 3.0], &[2.0, 3.5], &[4.0, 4.5], &[3.0, 6.0]]).unwrap();
    close(r.gg_epsilon, 1.0, 1e-12, "eps");
    close(r.p_gg, r.p, 1e-12, "p_gg");
}

#[test]
fn holm_adjustment() {
    // Holm (1979) by hand: sorted 0.01, 0.02, 0.04, 0.30 with m = 4:
    // 0.04, max(0.04, 0.06) = 0.06, max(0.06, 0.08) = 0.08, max(0.08, 0.30) = 0.30.
    let adj = holm(&[0.04, 0.01, 0.30, 0.02]);
    let want = [0.08, 0.04, 0.30, 0.06];
    for (g, w) in adj.iter().zip(want) {
        close(*g, w, 1e-15, "holm");
    }
    assert_eq!(holm(&[0.9, 0.8]), vec![1.0, 1.0]);
    assert!(holm(&[]).is_empty());
}

#[test]
fn murphy_degrees_of_freedom() {
    // Murphy (2007) §7.2.2 reports F(10,473): 11 scene types and
    // 11 subjects x 44 trials = 484 search times -> df (11-1, 484-11).
    let groups: Vec<Vec<f64>> = (0..11)
        .map(|g| {
            (0..44)
                .map(|i| 7.0 + g as f64 * 0.1 + (i % 7) as f64 * 0.3)
                .collect()
        })
        .collect();
    let refs: Vec<&[f64]> = groups.iter().map(|g| g.as_slice()).collect();
    let a = one_way_anova(&refs).unwrap();
    assert_eq!((a.df_between, a.df_within), (10.0, 473.0));
}

proptest::proptest! {
    /// Holm-adjusted p-values are at least the raw ones, at most 1, and
    /// keep the raw p-values' order.
    #[test]
    fn holm_properties(p in proptest::collection::vec(0.0f64..=1.0, 0..30)) {
        let adj = holm(&p);
        for i in 0..p.len() {
            proptest::prop_assert!(adj[i] >= p[i] && adj[i] <= 1.0);
            for j in 0..p.len() {
                if p[i] < p[j] {
                    proptest::prop_assert!(adj[i] <= adj[j]);
                }
            }
        }
    }
}

/// Values near the top of f64 (1e308: sums of squares overflow, and
/// statrs's tail functions panicked on the NaN that followed) are errors,
/// never a panic or an F of inf.
#[test]
fn huge_values_are_an_overflow_error_not_a_panic() {
    let a = [1e308, 1e308, 9e307];
    let b = [1.0, 2.0, 3.0];
    assert!(matches!(
        stats::one_way_anova(&[&a, &b]),
        Err(StatsError::Overflow(_))
    ));
    assert!(stats::pairwise_t_pooled(&[&a, &b]).is_err());
    assert!(stats::rm_anova(&[&a, &b]).is_err());
    assert!(matches!(stats::summarize(&a), Err(StatsError::Overflow(_))));
    // The tails themselves take any statistic.
    assert_eq!(stats::f_sf(1e308, 10.0, 473.0), Ok(0.0));
    assert!((stats::f_sf(0.0, 10.0, 473.0).unwrap() - 1.0).abs() < 1e-15);
    assert_eq!(stats::t_two_sided_p(1e300, 20.0), Ok(0.0));
    assert!(stats::f_sf(f64::NAN, 1.0, 2.0).is_err());
    assert!(stats::t_two_sided_p(1.0, 0.0).is_err());
}

fn value() -> impl Strategy<Value = f64> {
    prop_oneof![
        0.0f64..100.0,
        Just(1e308),
        Just(-1e308),
        Just(1e155),
        Just(f64::MIN_POSITIVE),
        1e100f64..1e300,
        -1e-300f64..1e-300,
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(fixtures::proptest_cases(400)))]

    /// Any finite values: every test gives finite statistics with p in
    /// [0, 1] (F may be +∞ with p = 0 when only the means differ), or an
    /// error; never a panic, never NaN.
    #[test]
    fn any_finite_values_give_finite_statistics_or_an_error(
        groups in prop::collection::vec(prop::collection::vec(value(), 1..6), 2..5),
    ) {
        let gs: Vec<&[f64]> = groups.iter().map(|g| g.as_slice()).collect();
        if let Ok(a) = stats::one_way_anova(&gs) {
            prop_assert!(a.f >= 0.0 && !a.f.is_nan(), "{a:?}");
            prop_assert!((0.0..=1.0).contains(&a.p), "{a:?}");
            prop_assert!(a.ms_within.is_finite() && a.ms_between.is_finite(), "{a:?}");
        }
        if let Ok(ps) = stats::pairwise_t_pooled(&gs) {
            for p in ps {
                prop_assert!(p.t.is_finite() && (0.0..=1.0).contains(&p.p), "{p:?}");
                prop_assert!((0.0..=1.0).contains(&p.p_holm), "{p:?}");
            }
        }
        let k = groups[0].len();
        let rows: Vec<&[f64]> = groups.iter().map(|g| &g[..k.min(g.len())]).collect();
        if let Ok(r) = stats::rm_anova(&rows) {
            prop_assert!(!r.f.is_nan() && (0.0..=1.0).contains(&r.p), "{r:?}");
            prop_assert!((0.0..=1.0).contains(&r.p_gg), "{r:?}");
        }
        for g in &gs {
            if let Ok(s) = stats::summarize(g) {
                prop_assert!(s.mean.is_finite() && s.sd.is_finite() && s.se.is_finite());
            }
        }
    }
}
