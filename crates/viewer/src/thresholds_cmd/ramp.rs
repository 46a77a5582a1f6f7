//! `gazecast thresholds measure --procedure luebke-hallen --headless`:
//! Luebke & Hallen §6.1's ramp (`psychophysics::ramp`) answered by a
//! simulated observer frame by frame on a virtual clock, written to the
//! same session folder as the 2IFC procedure: `trials.tsv` (the ramp's
//! columns), `session.json`, `thresholds-<ID>.ron`, `fit-<ID>.json` and
//! the plot. The windowed form is [`super::ramp_window`].

use std::io::Write;

use psychophysics::fit::{fit_ramp, ramp_threshold_table};
use psychophysics::ramp::{RampRecord, RampSession, RampSpec};
use psychophysics::stimulus::GaborPatch;

use super::{
    create_folder, load_observer, software, write_results, write_session_json, Loaded, MeasureArgs,
    Measured, SessionInfo, SessionSetup,
};

/// `trials.tsv`'s header for the ramp. `response_ms` is on the ramp's
/// clock: ms from its first frame (headless: a virtual clock of
/// `frame_ms` frames, no host clock; windowed: from the onset on the host
/// monotonic clock). Contrasts are Michelson; `n/a` where a trial has none
/// (no response, no click, no sample). The last three columns are the
/// windowed form's (attempts aborted before the answered one, the onset
/// and the "seen" response on the host monotonic clock, µs): `0`, `n/a`
/// headless.
pub(super) const RAMP_TRIALS_HEADER: &str =
    "trial\tcondition\tfrequency_cpd\teccentricity_deg\tlocations\tlocation_shown\t\
     direction_deg\tstart_contrast\tstop_contrast\tmax_contrast\trate_log10_per_s\t\
     response_ms\tlocation_clicked\toutcome\tsample_contrast\tsample_log10\t\
     shown_sample_contrast\tdither_sd\testimate_log10\tse_log10\tfinished_condition\t\
     aborted_attempts\tonset_host_us\tresponse_host_us\n";

fn opt<T: std::fmt::Display>(v: Option<T>) -> String {
    v.map_or_else(|| "n/a".into(), |v| v.to_string())
}

/// One `trials.tsv` row; `p`: the patch rendered at the sample contrast;
/// `windowed`: the last three columns.
pub(super) fn ramp_row(rec: &RampRecord, p: Option<&GaborPatch>, windowed: &str) -> String {
    let t = &rec.trial;
    let s = &t.schedule;
    format!(
        "{}\t{}\t{}\t{}\t{}\t{}\t{}\t{:.6}\t{:.6}\t{:.6}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{}\t{:.4}\t{:.4}\t{}\t{windowed}\n",
        t.index,
        t.condition,
        t.frequency_cpd,
        t.eccentricity_deg,
        t.locations,
        t.location,
        t.direction_deg,
        10f64.powf(s.start_log10),
        rec.stop_contrast,
        10f64.powf(s.max_log10),
        s.rate_log10_per_s,
        opt(rec.response.response_ms.map(|v| format!("{v:.1}"))),
        opt(rec.response.clicked_location),
        rec.outcome.name(),
        opt(rec.sample_log10.map(|x| format!("{:.6}", 10f64.powf(x)))),
        opt(rec.sample_log10.map(|x| format!("{x:.4}"))),
        opt(p.map(|p| format!("{:.6}", p.measured_contrast()))),
        opt(p.map(|p| format!("{:.2e}", p.dither_contrast_sd))),
        rec.estimate_log10,
        rec.se_log10,
        u8::from(rec.finished_condition),
    )
}

/// The headless ramp session (module doc).
pub(super) fn measure_headless(a: &MeasureArgs, out: &mut dyn Write) -> Result<(), String> {
    let Some(observer_path) = &a.simulate_observer else {
        return Err("--headless needs --simulate-observer FILE.ron (who answers?)".into());
    };
    let mut observer = load_observer(observer_path)?;
    let loaded = Loaded::<RampSpec>::read_ramp(a)?;
    let mut session =
        RampSession::new(loaded.spec.clone()).map_err(|e| format!("ramp design: {e}"))?;
    let dir = create_folder(a)?;

    let mut tsv = String::from(RAMP_TRIALS_HEADER);
    while let Some(t) = session.next_trial() {
        let r = observer
            .respond_ramp(&t, loaded.spec.frame_ms)
            .map_err(|e| format!("trial {}: {e}", t.index))?;
        session
            .record_synthetic(&t, r)
            .map_err(|e| format!("trial {}: {e}", t.index))?;
        let Some(rec) = session.records().last().copied() else {
            return Err(format!("trial {}: not recorded", t.index));
        };
        // What the display shows at the sample: the dithered patch's
        // measured contrast.
        let patch = match rec.sample_log10 {
            Some(x) => Some(
                loaded
                    .patch(
                        a,
                        t.frequency_cpd,
                        t.eccentricity_deg,
                        10f64.powf(x),
                        u64::from(t.index),
                    )
                    .map_err(|e| format!("trial {}: {e}", t.index))?,
            ),
            None => None,
        };
        tsv.push_str(&ramp_row(&rec, patch.as_ref(), "0\tn/a\tn/a"));
    }
    let p = dir.join("trials.tsv");
    std::fs::write(&p, tsv).map_err(|e| format!("{}: {e}", p.display()))?;
    let info = SessionInfo {
        synthetic: session.is_synthetic(),
        note: "Luebke & Hallen's ramp: a simulated observer answered every ramp frame by frame on a virtual clock; no person has yet run this procedure".into(),
        software: software(),
        participant: &a.participant,
        observer_file: Some(observer_path.display().to_string()),
        observer: Some(*observer.spec()),
        completed: true,
        window: None,
        aborted_attempts: 0,
        setup: SessionSetup::of_ramp(&loaded, a, &session),
    };
    write_session_json(&dir, &info)?;
    let fit = fit_ramp(&session, &info.setup.fit_options).map_err(|e| format!("the fit: {e}"))?;
    let table = ramp_threshold_table(&session, &fit).map_err(|e| format!("the table: {e}"))?;
    let who = format!(
        "a simulated observer ({}), Luebke & Hallen's ramp",
        observer_path.display()
    );
    write_results(
        a,
        &dir,
        &Measured::of_ramp(&session),
        (fit, table),
        &who,
        out,
    )
}
