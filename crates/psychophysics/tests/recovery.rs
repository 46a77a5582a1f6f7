//! The recovery test: hidden simulated observers, the whole procedure run
//! headlessly (`next_trial → observer answers → record`), and the fit must
//! find their CT0, α and e2 again. The tolerances and trial counts are the
//! crate docs' ("Recovery").

use foveation::perceptibility::{ThresholdTable, ThresholdTableData};
use psychophysics::fit::threshold_table;

mod support;

use support::{hidden_observers, measure, rel};

/// Runs six hidden observers; returns how many had each parameter's truth
/// inside its 95 % interval.
fn recover(trials_per_condition: u32, tol: [f64; 3]) -> [usize; 3] {
    let mut covered = [0; 3];
    for (k, spec) in hidden_observers(6).into_iter().enumerate() {
        let (s, fit) = measure(spec, trials_per_condition, k as u64);
        assert_eq!(s.records().len(), 20 * trials_per_condition as usize);
        assert!(fit.synthetic);
        let t = spec.csf;
        let pairs = [
            (fit.ct0, t.ct0, "CT0"),
            (fit.alpha, t.alpha, "alpha"),
            (fit.e2_deg, t.e2_deg, "e2"),
        ];
        for (i, (e, truth, name)) in pairs.into_iter().enumerate() {
            let err = rel(e.estimate, truth);
            assert!(
                err <= tol[i],
                "observer {k}: {name} {} vs {truth} ({:.1} % > {:.0} %)",
                e.estimate,
                100.0 * err,
                100.0 * tol[i]
            );
            covered[i] += usize::from(e.ci_low <= truth && truth <= e.ci_high);
        }
    }
    covered
}

#[test]
fn quest_recovers_hidden_observers_in_800_trials() {
    let covered = recover(40, [0.20, 0.25, 0.30]);
    assert!(
        covered.iter().all(|&c| c >= 5),
        "95 % intervals held the truth {covered:?} of 6"
    );
}

#[test]
fn quest_recovers_hidden_observers_closer_in_1600_trials() {
    let covered = recover(80, [0.10, 0.15, 0.15]);
    assert!(
        covered.iter().all(|&c| c >= 5),
        "95 % intervals held the truth {covered:?} of 6"
    );
}

#[test]
fn the_table_round_trips_through_ron_into_foveation() {
    let spec = hidden_observers(1)[0];
    let (s, fit) = measure(spec, 40, 9);
    let table = threshold_table(&s, &fit).unwrap();
    let text = ron::to_string(&ThresholdTableData::from(table.clone())).unwrap();
    let back: ThresholdTable = ron::from_str(&text).unwrap();
    assert_eq!(back.frequencies_cpd(), &[1.0, 2.0, 4.0, 8.0, 16.0]);
    // A used condition's threshold is in the table as measured.
    let r = s.results();
    let used = r.iter().find(|r| !r.censored).unwrap();
    let t = back.threshold(used.frequency_cpd, used.eccentricity_deg);
    assert!(
        (t / used.threshold - 1.0).abs() < 1e-9,
        "{t} vs {}",
        used.threshold
    );
    // The fit serialises with its intervals and the synthetic label.
    let json = serde_json::to_string(&fit).unwrap();
    assert!(
        json.contains("\"synthetic\":true") && json.contains("ci_low"),
        "{json}"
    );
}
