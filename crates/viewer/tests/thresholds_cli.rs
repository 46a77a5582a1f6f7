//! `gazecast thresholds measure --headless`: a simulated observer's
//! session end to end, its files, the recovered fit, and the refusals.
//! Everything here is synthetic.

mod common;

use common::{gazecast, Run};

const OBSERVER: &str = "config/participants/threshold-observer.ron";

fn measure(out: &std::path::Path, id: &str) -> std::process::Command {
    let mut c = gazecast();
    c.args([
        "thresholds",
        "measure",
        "--headless",
        "--simulate-observer",
        OBSERVER,
    ])
    .args(["--participant", id, "--bootstrap", "50", "--out"])
    .arg(out);
    c
}

#[test]
fn a_simulated_session_writes_its_folder_and_refuses_to_overwrite() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let out = tmp.path().join("thresholds");
    let o = measure(&out, "P01").succeed();
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.starts_with("SYNTHETIC"), "{stdout}");
    let dir = out.join("sub-P01");

    // trials.tsv: a header and the default 20 conditions × 40 trials.
    let tsv = std::fs::read_to_string(dir.join("trials.tsv")).unwrap();
    let lines: Vec<&str> = tsv.lines().collect();
    assert_eq!(lines.len(), 801);
    let header: Vec<&str> = lines[0].split('\t').collect();
    for col in [
        "condition",
        "frequency_cpd",
        "eccentricity_deg",
        "contrast",
        "shown_contrast",
        "correct",
        "valid",
        "estimate_log10",
        "spread_log10",
    ] {
        assert!(header.contains(&col), "no column {col}: {header:?}");
    }
    assert!(lines[1..]
        .iter()
        .all(|l| l.split('\t').count() == header.len()));

    // session.json and the fit say synthetic.
    let session: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("session.json")).unwrap()).unwrap();
    assert_eq!(session["synthetic"], true);
    assert_eq!(session["trials"], 800);
    let fit: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.join("fit-P01.json")).unwrap()).unwrap();
    assert_eq!(fit["synthetic"], true);
    // The observer file's CSF (CT0 0.012, α 0.095, e2 2.8°) comes back.
    let est = |k: &str| fit["fit"][k]["estimate"].as_f64().unwrap();
    assert!((est("ct0") / 0.012 - 1.0).abs() < 0.25, "{fit}");
    assert!((est("alpha") / 0.095 - 1.0).abs() < 0.3, "{fit}");
    assert!((est("e2_deg") / 2.8 - 1.0).abs() < 0.35, "{fit}");

    // The table reads as foveation's threshold table.
    let text = std::fs::read_to_string(dir.join("thresholds-P01.ron")).unwrap();
    assert!(text.starts_with("// SYNTHETIC"));
    let table: foveation::perceptibility::ThresholdTable = ron::from_str(&text).unwrap();
    assert_eq!(table.eccentricities_deg(), &[0.0, 2.5, 5.0, 10.0]);

    // Again into the same folder: refused, and nothing is touched.
    let again = measure(&out, "P01").output().unwrap();
    assert!(!again.status.success());
    let err = String::from_utf8_lossy(&again.stderr);
    assert!(err.contains("refusing to overwrite"), "{err}");
    assert_eq!(
        std::fs::read_to_string(dir.join("trials.tsv")).unwrap(),
        tsv
    );
}

#[test]
fn without_a_simulated_observer_it_says_what_is_missing() {
    let tmp = tempfile::tempdir().expect("tempdir");
    let o = gazecast()
        .args(["thresholds", "measure", "--participant", "P01", "--out"])
        .arg(tmp.path())
        .output()
        .unwrap();
    assert!(!o.status.success());
    assert!(String::from_utf8_lossy(&o.stderr).contains("--headless"));
    let o = gazecast()
        .args([
            "thresholds",
            "measure",
            "--headless",
            "--participant",
            "P01",
            "--out",
        ])
        .arg(tmp.path())
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&o.stderr).contains("--simulate-observer"));
    let o = measure(tmp.path(), "../x").output().unwrap();
    assert!(String::from_utf8_lossy(&o.stderr).contains("--participant"));
    assert!(
        std::fs::read_dir(tmp.path()).unwrap().next().is_none(),
        "nothing written"
    );
}
