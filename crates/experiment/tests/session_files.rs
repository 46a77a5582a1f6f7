//! The session folder's file formats: exact round trips (proptest), the
//! header lines, `n/a`, a killed writer's half line, header mismatches,
//! parse errors that name file, line and column, refused tabs and line
//! breaks, the flush policy, and session.json.

use experiment::session::{
    read_tsv, DisplayInfo, EventRow, FrameRow, MarkerRow, SampleRow, SessionFileError, SessionInfo,
    TrialRow, TsvLog, TsvRow,
};
use proptest::prelude::*;
use std::io::Write;
use std::path::Path;
use std::time::Duration;

fn trial(i: usize) -> TrialRow {
    TrialRow {
        participant: "P 01".into(),
        sitting: 1,
        run: i / 11,
        trial: i,
        trial_in_run: i % 11,
        condition: "NE2".into(),
        method: "hybrid".into(),
        inset_deg: Some(2.0),
        silhouette_edges: false,
        target_mesh: 3,
        target_row: 1,
        target_col: 4,
        search_onset_us: 1_000_000 + i as u64 * 10_000_000,
        response_us: 9_000_000 + i as u64 * 10_000_000,
        rt_s: 8.0 + i as f64 * 0.125,
        clicked_row: None,
        clicked_col: Some(4),
        correct: None,
        frames: 240,
        frames_late: 2,
        mean_rays: 123456.5,
        synthetic: true,
        plan: Some("foveated on cpu; passes: POR box (cpu)".into()),
        reference_row: Some(2),
        reference_col: Some(2),
        mean_triangles: None,
        mean_render_ms: Some(41.25),
        p95_render_ms: Some(55.5),
        practice: false,
    }
}

/// The trials.tsv columns added after `plan`: the reference's cell and
/// the search frames' costs.
const AFTER_PLAN: [&str; 6] = [
    "reference_row",
    "reference_col",
    "mean_triangles",
    "mean_render_ms",
    "p95_render_ms",
    "practice",
];

/// `row` as read from a file written before the columns after `plan`.
fn without_costs(row: TrialRow) -> TrialRow {
    TrialRow {
        reference_row: None,
        reference_col: None,
        mean_triangles: None,
        mean_render_ms: None,
        p95_render_ms: None,
        practice: false,
        ..row
    }
}

fn write_rows<T: TsvRow>(path: &Path, rows: &[T]) {
    let mut log = TsvLog::<T>::append_to(path).expect("open");
    for r in rows {
        log.write(r).expect("write");
    }
}

fn first_line(path: &Path) -> String {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .next()
        .unwrap()
        .to_string()
}

#[test]
fn header_lines_are_the_documented_ones() {
    // Hard-coded: renaming or reordering a field must fail here.
    let dir = tempfile::tempdir().unwrap();
    type Writer = Box<dyn Fn(&Path)>;
    let cases: [(&str, Writer); 5] = [
        (
            "participant\tsitting\trun\ttrial\ttrial_in_run\tcondition\tmethod\tinset_deg\tsilhouette_edges\ttarget_mesh\ttarget_row\ttarget_col\tsearch_onset_us\tresponse_us\trt_s\tclicked_row\tclicked_col\tcorrect\tframes\tframes_late\tmean_rays\tsynthetic\tplan\treference_row\treference_col\tmean_triangles\tmean_render_ms\tp95_render_ms\tpractice",
            Box::new(|p| write_rows(p, &[trial(0)])),
        ),
        (
            "sitting\tmapped_us\tdevice_us\tarrival_us\ttime_order\tsegment\ttrial\tphase\traw_x\traw_y\tx_px\ty_px\tleft_x_px\tleft_y_px\tleft_pupil\tright_x_px\tright_y_px\tright_pupil",
            Box::new(|p| write_rows::<SampleRow>(p, &[])),
        ),
        (
            "sitting\ttrial\tkind\tonset_us\tend_us\tonset_device_us\tend_device_us\tx_px\ty_px\tend_x_px\tend_y_px\tpractice",
            Box::new(|p| write_rows::<EventRow>(p, &[])),
        ),
        (
            "sitting\thost_us\ttrial\tevent\tdetail",
            Box::new(|p| write_rows::<MarkerRow>(p, &[])),
        ),
        (
            "sitting\thost_us\ttrial\tphase\trays\trender_ms\tinterval_ms\tlate\tplan\tgpu_uploaded_bytes\tgpu_read_back_bytes\tgpu_dispatches\tgpu_draws\tgpu_submits",
            Box::new(|p| write_rows::<FrameRow>(p, &[])),
        ),
    ];
    for (i, (header, write)) in cases.iter().enumerate() {
        let p = dir.path().join(format!("f{i}.tsv"));
        write(&p);
        assert_eq!(&first_line(&p), header);
    }
    assert_eq!(TrialRow::FILE, "trials.tsv");
    assert_eq!(SampleRow::FILE, "samples.tsv");
    assert_eq!(EventRow::FILE, "events.tsv");
    assert_eq!(MarkerRow::FILE, "markers.tsv");
    assert_eq!(FrameRow::FILE, "frames.tsv");
}

#[test]
fn columns_are_the_serde_field_names() {
    // COLUMNS must list what serde writes, in order: compare with the
    // header csv derives from the struct itself.
    fn serde_header<T: TsvRow>(row: &T) -> Vec<String> {
        let mut w = csv::WriterBuilder::new()
            .delimiter(b'\t')
            .from_writer(Vec::new());
        w.serialize(row).unwrap();
        let bytes = w.into_inner().unwrap();
        let text = String::from_utf8(bytes).unwrap();
        text.lines()
            .next()
            .unwrap()
            .split('\t')
            .map(String::from)
            .collect()
    }
    fn cols<T: TsvRow>() -> Vec<String> {
        T::COLUMNS.iter().map(|s| s.to_string()).collect()
    }
    assert_eq!(serde_header(&trial(0)), cols::<TrialRow>());
    let s = SampleRow {
        sitting: 1,
        mapped_us: 1,
        device_us: Some(2),
        arrival_us: 3,
        time_order: "ok".into(),
        segment: 0,
        trial: None,
        phase: "search".into(),
        raw_x: None,
        raw_y: None,
        x_px: None,
        y_px: None,
        left_x_px: None,
        left_y_px: None,
        left_pupil: None,
        right_x_px: None,
        right_y_px: None,
        right_pupil: None,
    };
    assert_eq!(serde_header(&s), cols::<SampleRow>());
    let e = EventRow {
        sitting: 1,
        trial: None,
        kind: "fixation".into(),
        onset_us: 0,
        end_us: 1,
        onset_device_us: 0,
        end_device_us: 0,
        x_px: 0.0,
        y_px: 0.0,
        end_x_px: 0.0,
        end_y_px: 0.0,
        practice: false,
    };
    assert_eq!(serde_header(&e), cols::<EventRow>());
    let m = MarkerRow {
        sitting: 1,
        host_us: 0,
        trial: None,
        event: "key".into(),
        detail: "space".into(),
    };
    assert_eq!(serde_header(&m), cols::<MarkerRow>());
    let f = FrameRow {
        sitting: 1,
        host_us: 0,
        trial: None,
        phase: "search".into(),
        rays: 0,
        render_ms: 0.0,
        interval_ms: None,
        late: false,
        plan: None,
        gpu_uploaded_bytes: None,
        gpu_read_back_bytes: None,
        gpu_dispatches: None,
        gpu_draws: None,
        gpu_submits: None,
    };
    assert_eq!(serde_header(&f), cols::<FrameRow>());
}

#[test]
fn missing_values_are_written_n_a() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("trials.tsv");
    write_rows(&p, &[trial(0)]);
    let text = std::fs::read_to_string(&p).unwrap();
    let row: Vec<&str> = text.lines().nth(1).unwrap().split('\t').collect();
    assert_eq!(row.len(), 29);
    assert_eq!(row[0], "P 01", "spaces kept, no quoting");
    assert_eq!(row[1], "1", "sitting");
    assert_eq!(row[7], "2.0");
    assert_eq!(row[15], "n/a", "clicked_row None");
    assert_eq!(row[16], "4");
    assert_eq!(row[17], "n/a", "correct None");
    assert_eq!(row[21], "true");
    assert_eq!(row[22], "foveated on cpu; passes: POR box (cpu)");
    assert_eq!(
        row[23..],
        ["2", "2", "n/a", "41.25", "55.5", "false"],
        "reference, costs, practice"
    );
    // An empty field reads as None too (hand-edited files).
    let edited = text.replace("\tn/a\t4\tn/a\t", "\t\t4\t\t");
    std::fs::write(&p, edited).unwrap();
    let back = read_tsv::<TrialRow>(&p).unwrap();
    assert_eq!(back.rows, vec![trial(0)]);
}

fn same_f64(a: f64, b: f64) -> bool {
    a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
}

fn same_opt(a: Option<f64>, b: Option<f64>) -> bool {
    match (a, b) {
        (Some(a), Some(b)) => same_f64(a, b),
        (None, None) => true,
        _ => false,
    }
}

/// Every f64 class but NaN (whose payload and sign TSV cannot keep; see
/// `nan_and_infinities_round_trip`).
fn any_f64() -> impl Strategy<Value = f64> {
    prop_oneof![
        proptest::num::f64::POSITIVE
            | proptest::num::f64::NEGATIVE
            | proptest::num::f64::NORMAL
            | proptest::num::f64::SUBNORMAL
            | proptest::num::f64::ZERO
            | proptest::num::f64::INFINITE,
        Just(f64::MIN_POSITIVE),
        Just(5e-324),
        Just(f64::MAX),
        Just(f64::MIN),
        Just(-0.0),
        Just(1e-300),
        Just(1e300),
        Just(0.1),
    ]
}

/// Text without tab, CR or LF: spaces, quotes, `n/a`, Unicode.
fn text() -> impl Strategy<Value = String> {
    prop_oneof![
        "[^\t\n\r]{0,24}",
        Just(String::new()),
        Just("n/a".to_string()),
        Just("  two  spaces ".to_string()),
        Just("\"quoted\" and 'single'".to_string()),
        Just("ümlaut ° ± 视觉".to_string()),
    ]
}

/// A plan column's value: `None` (`n/a`) or a provenance-like line
/// (never empty and never `n/a` itself, which read back as `None`).
fn plan() -> impl Strategy<Value = Option<String>> {
    proptest::option::of(prop_oneof![
        "[^\t\n\r]{1,60}".prop_filter("n/a reads as None", |s| s != "n/a"),
        Just("image-based on gpu; passes: image-based foveation (gpu) → POR box (cpu)".to_string()),
        Just("foveated on cpu; passes: none".to_string()),
    ])
}

fn trial_row() -> impl Strategy<Value = TrialRow> {
    (
        (
            text(),
            any::<usize>(),
            any::<usize>(),
            any::<usize>(),
            text(),
            text(),
        ),
        (
            proptest::option::of(any_f64()),
            any::<bool>(),
            any::<u32>(),
            any::<u32>(),
            any::<u32>(),
        ),
        (any::<u64>(), any::<u64>(), any_f64()),
        (
            proptest::option::of(any::<u32>()),
            proptest::option::of(any::<u32>()),
            proptest::option::of(any::<bool>()),
        ),
        (any::<u64>(), any::<u64>(), any_f64(), any::<bool>(), plan()),
        (
            proptest::option::of(any::<u32>()),
            proptest::option::of(any::<u32>()),
            proptest::option::of(any_f64()),
            proptest::option::of(any_f64()),
            proptest::option::of(any_f64()),
        ),
        any::<bool>(),
    )
        .prop_map(
            |(
                (participant, run, trial, trial_in_run, condition, method),
                (inset_deg, silhouette_edges, target_mesh, target_row, target_col),
                (search_onset_us, response_us, rt_s),
                (clicked_row, clicked_col, correct),
                (frames, frames_late, mean_rays, synthetic, plan),
                (reference_row, reference_col, mean_triangles, mean_render_ms, p95_render_ms),
                practice,
            )| TrialRow {
                participant,
                sitting: (run % 7) as u32 + 1,
                run,
                trial,
                trial_in_run,
                condition,
                method,
                inset_deg,
                silhouette_edges,
                target_mesh,
                target_row,
                target_col,
                search_onset_us,
                response_us,
                rt_s,
                clicked_row,
                clicked_col,
                correct,
                frames,
                frames_late,
                mean_rays,
                synthetic,
                plan,
                reference_row,
                reference_col,
                mean_triangles,
                mean_render_ms,
                p95_render_ms,
                practice,
            },
        )
}

fn trial_same(a: &TrialRow, b: &TrialRow) -> bool {
    same_opt(a.inset_deg, b.inset_deg)
        && same_f64(a.rt_s, b.rt_s)
        && same_f64(a.mean_rays, b.mean_rays)
        && same_opt(a.mean_triangles, b.mean_triangles)
        && same_opt(a.mean_render_ms, b.mean_render_ms)
        && same_opt(a.p95_render_ms, b.p95_render_ms)
        && TrialRow {
            inset_deg: None,
            rt_s: 0.0,
            mean_rays: 0.0,
            mean_triangles: None,
            mean_render_ms: None,
            p95_render_ms: None,
            ..a.clone()
        } == TrialRow {
            inset_deg: None,
            rt_s: 0.0,
            mean_rays: 0.0,
            mean_triangles: None,
            mean_render_ms: None,
            p95_render_ms: None,
            ..b.clone()
        }
}

fn sample_row() -> impl Strategy<Value = SampleRow> {
    (
        (
            any::<u32>(),
            any::<u64>(),
            proptest::option::of(any::<u64>()),
            any::<u64>(),
            prop_oneof![
                Just("ok"),
                Just("first"),
                Just("repeated"),
                Just("backwards")
            ],
            any::<u32>(),
        ),
        proptest::option::of(any::<usize>()),
        text(),
        proptest::option::of(any_f64()),
        proptest::option::of(any_f64()),
        proptest::option::of(any_f64()),
        proptest::option::of(any_f64()),
    )
        .prop_map(
            |(
                (sitting, mapped_us, device_us, arrival_us, order, segment),
                trial,
                phase,
                raw_x,
                raw_y,
                x_px,
                y_px,
            )| SampleRow {
                sitting,
                mapped_us,
                device_us,
                arrival_us,
                time_order: order.into(),
                segment,
                trial,
                phase,
                raw_x,
                raw_y,
                x_px,
                y_px,
                left_x_px: None,
                left_y_px: None,
                left_pupil: None,
                right_x_px: None,
                right_y_px: None,
                right_pupil: None,
            },
        )
}

fn sample_same(a: &SampleRow, b: &SampleRow) -> bool {
    (
        a.sitting,
        a.mapped_us,
        a.device_us,
        a.arrival_us,
        &a.time_order,
        a.segment,
    ) == (
        b.sitting,
        b.mapped_us,
        b.device_us,
        b.arrival_us,
        &b.time_order,
        b.segment,
    ) && a.trial == b.trial
        && a.phase == b.phase
        && same_opt(a.raw_x, b.raw_x)
        && same_opt(a.raw_y, b.raw_y)
        && same_opt(a.x_px, b.x_px)
        && same_opt(a.y_px, b.y_px)
}

fn event_row() -> impl Strategy<Value = EventRow> {
    (
        proptest::option::of(any::<usize>()),
        text(),
        (any::<u64>(), any::<u64>(), any::<u64>(), any::<u64>()),
        any_f64(),
        any_f64(),
        any_f64(),
        any_f64(),
        any::<bool>(),
    )
        .prop_map(
            |(
                trial,
                kind,
                (onset_us, end_us, onset_device_us, end_device_us),
                x_px,
                y_px,
                end_x_px,
                end_y_px,
                practice,
            )| EventRow {
                sitting: 1,
                trial,
                kind,
                onset_us,
                end_us,
                onset_device_us,
                end_device_us,
                x_px,
                y_px,
                end_x_px,
                end_y_px,
                practice,
            },
        )
}

fn event_same(a: &EventRow, b: &EventRow) -> bool {
    a.trial == b.trial
        && a.kind == b.kind
        && a.onset_us == b.onset_us
        && a.end_us == b.end_us
        && (a.onset_device_us, a.end_device_us) == (b.onset_device_us, b.end_device_us)
        && same_f64(a.x_px, b.x_px)
        && same_f64(a.y_px, b.y_px)
        && same_f64(a.end_x_px, b.end_x_px)
        && same_f64(a.end_y_px, b.end_y_px)
        && a.practice == b.practice
}

fn marker_row() -> impl Strategy<Value = MarkerRow> {
    (
        any::<u64>(),
        proptest::option::of(any::<usize>()),
        text(),
        text(),
    )
        .prop_map(|(host_us, trial, event, detail)| MarkerRow {
            sitting: 1,
            host_us,
            trial,
            event,
            detail,
        })
}

fn frame_row() -> impl Strategy<Value = FrameRow> {
    (
        any::<u64>(),
        proptest::option::of(any::<usize>()),
        text(),
        any::<u64>(),
        any_f64(),
        proptest::option::of(any_f64()),
        any::<bool>(),
        plan(),
        proptest::array::uniform5(proptest::option::of(any::<u64>())),
    )
        .prop_map(
            |(host_us, trial, phase, rays, render_ms, interval_ms, late, plan, gpu)| FrameRow {
                sitting: 2,
                host_us,
                trial,
                phase,
                rays,
                render_ms,
                interval_ms,
                late,
                plan,
                gpu_uploaded_bytes: gpu[0],
                gpu_read_back_bytes: gpu[1],
                gpu_dispatches: gpu[2],
                gpu_draws: gpu[3],
                gpu_submits: gpu[4],
            },
        )
}

fn frame_same(a: &FrameRow, b: &FrameRow) -> bool {
    a.host_us == b.host_us
        && a.trial == b.trial
        && a.phase == b.phase
        && a.rays == b.rays
        && same_f64(a.render_ms, b.render_ms)
        && same_opt(a.interval_ms, b.interval_ms)
        && a.late == b.late
        && a.plan == b.plan
        && (
            a.gpu_uploaded_bytes,
            a.gpu_read_back_bytes,
            a.gpu_dispatches,
            a.gpu_draws,
            a.gpu_submits,
        ) == (
            b.gpu_uploaded_bytes,
            b.gpu_read_back_bytes,
            b.gpu_dispatches,
            b.gpu_draws,
            b.gpu_submits,
        )
}

/// Writes `rows` in two sessions of the log (reopened in between, as a
/// resumed session would) and reads them back.
fn round_trip<T: TsvRow + Clone>(rows: &[T], split: usize) -> Vec<T> {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join(T::FILE);
    let split = split.min(rows.len());
    write_rows(&p, &rows[..split]);
    write_rows(&p, &rows[split..]);
    let back = read_tsv::<T>(&p).unwrap();
    assert!(back.warnings.is_empty(), "{:?}", back.warnings);
    assert_eq!(back.lines, (2..2 + rows.len() as u64).collect::<Vec<_>>());
    back.rows
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(fixtures::proptest_cases(48)))]

    #[test]
    fn trials_round_trip(rows in proptest::collection::vec(trial_row(), 0..12), split in 0usize..12) {
        let back = round_trip(&rows, split);
        prop_assert_eq!(back.len(), rows.len());
        for (a, b) in rows.iter().zip(&back) {
            prop_assert!(trial_same(a, b), "{:?}\n!=\n{:?}", a, b);
        }
    }

    #[test]
    fn samples_round_trip(rows in proptest::collection::vec(sample_row(), 0..16), split in 0usize..16) {
        let back = round_trip(&rows, split);
        prop_assert_eq!(back.len(), rows.len());
        for (a, b) in rows.iter().zip(&back) {
            prop_assert!(sample_same(a, b), "{:?}\n!=\n{:?}", a, b);
        }
    }

    #[test]
    fn events_round_trip(rows in proptest::collection::vec(event_row(), 0..16), split in 0usize..16) {
        let back = round_trip(&rows, split);
        prop_assert_eq!(back.len(), rows.len());
        for (a, b) in rows.iter().zip(&back) {
            prop_assert!(event_same(a, b), "{:?}\n!=\n{:?}", a, b);
        }
    }

    #[test]
    fn markers_round_trip(rows in proptest::collection::vec(marker_row(), 0..16), split in 0usize..16) {
        let back = round_trip(&rows, split);
        prop_assert_eq!(back, rows);
    }

    #[test]
    fn frames_round_trip(rows in proptest::collection::vec(frame_row(), 0..16), split in 0usize..16) {
        let back = round_trip(&rows, split);
        prop_assert_eq!(back.len(), rows.len());
        for (a, b) in rows.iter().zip(&back) {
            prop_assert!(frame_same(a, b), "{:?}\n!=\n{:?}", a, b);
        }
    }

    #[test]
    fn tabs_and_line_breaks_are_refused(
        before in "[a-z ]{0,5}",
        bad in prop_oneof![Just('\t'), Just('\n'), Just('\r')],
        after in "[a-z ]{0,5}",
    ) {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("markers.tsv");
        let mut log = TsvLog::<MarkerRow>::append_to(&p).unwrap();
        let good = MarkerRow { sitting: 1, host_us: 1, trial: Some(0), event: "key".into(), detail: "space".into() };
        log.write(&good).unwrap();
        let row = MarkerRow { detail: format!("{before}{bad}{after}"), ..good.clone() };
        let err = log.write(&row).unwrap_err();
        match &err {
            SessionFileError::Write { path, row, column, .. } => {
                prop_assert_eq!(path, &p);
                prop_assert_eq!(*row, 2);
                prop_assert_eq!(column.as_deref(), Some("detail"));
            }
            other => prop_assert!(false, "unexpected {:?}", other),
        }
        log.write(&good).unwrap();
        drop(log);
        // Nothing of the refused row reached the file.
        let back = read_tsv::<MarkerRow>(&p).unwrap();
        prop_assert_eq!(back.rows, vec![good.clone(), good]);
        prop_assert!(back.warnings.is_empty());
    }
}

#[test]
fn nan_and_infinities_round_trip() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("frames.tsv");
    let rows: Vec<FrameRow> = [f64::NAN, f64::INFINITY, f64::NEG_INFINITY]
        .iter()
        .map(|&v| FrameRow {
            sitting: 1,
            host_us: 0,
            trial: None,
            phase: "x".into(),
            rays: 0,
            render_ms: v,
            interval_ms: Some(v),
            late: false,
            plan: None,
            gpu_uploaded_bytes: None,
            gpu_read_back_bytes: None,
            gpu_dispatches: None,
            gpu_draws: None,
            gpu_submits: None,
        })
        .collect();
    write_rows(&p, &rows);
    let back = read_tsv::<FrameRow>(&p).unwrap().rows;
    assert!(back[0].render_ms.is_nan() && back[0].interval_ms.unwrap().is_nan());
    assert_eq!(back[1].render_ms, f64::INFINITY);
    assert_eq!(back[1].interval_ms, Some(f64::INFINITY));
    assert_eq!(back[2].render_ms, f64::NEG_INFINITY);
    assert_eq!(back[2].interval_ms, Some(f64::NEG_INFINITY));
}

#[test]
fn killed_writer_half_line_is_a_warning_and_append_cuts_it() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("trials.tsv");
    write_rows(&p, &[trial(0), trial(1), trial(2)]);
    // A killed writer: half of the fourth row, no line end.
    let full = std::fs::read_to_string(&p).unwrap();
    let row3 = full.lines().nth(3).unwrap().to_string();
    let mut f = std::fs::OpenOptions::new().append(true).open(&p).unwrap();
    f.write_all(&row3.as_bytes()[..row3.len() / 2]).unwrap();
    drop(f);

    let read = read_tsv::<TrialRow>(&p).unwrap();
    assert_eq!(read.rows, vec![trial(0), trial(1), trial(2)]);
    assert_eq!(read.warnings.len(), 1);
    let w = &read.warnings[0];
    assert_eq!(w.path, p);
    assert_eq!(w.line, 5);
    let shown = w.to_string();
    assert!(
        shown.contains("trials.tsv") && shown.contains("line 5") && shown.contains("incomplete"),
        "{shown}"
    );

    // Resuming cuts the half line off, then appends cleanly.
    let mut log = TsvLog::<TrialRow>::append_to(&p).unwrap();
    assert_eq!(log.dropped_partial_line(), Some(&row3[..row3.len() / 2]));
    assert_eq!(log.rows(), 3);
    log.write(&trial(3)).unwrap();
    drop(log);
    let read = read_tsv::<TrialRow>(&p).unwrap();
    assert_eq!(read.rows, vec![trial(0), trial(1), trial(2), trial(3)]);
    assert!(read.warnings.is_empty());
}

#[test]
fn a_half_header_is_a_warning_and_is_rewritten() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("markers.tsv");
    std::fs::write(&p, "sitting\thost_us\ttri").unwrap();
    let read = read_tsv::<MarkerRow>(&p).unwrap();
    assert!(read.rows.is_empty());
    assert_eq!(read.warnings.len(), 1);
    assert_eq!(read.warnings[0].line, 1);
    let row = MarkerRow {
        sitting: 3,
        host_us: 5,
        trial: None,
        event: "phase".into(),
        detail: "calibration".into(),
    };
    write_rows(&p, std::slice::from_ref(&row));
    assert_eq!(read_tsv::<MarkerRow>(&p).unwrap().rows, vec![row]);
    // An empty file: a warning, no rows.
    std::fs::write(&p, "").unwrap();
    let read = read_tsv::<MarkerRow>(&p).unwrap();
    assert!(read.rows.is_empty() && read.warnings.len() == 1);
}

/// `text` as a file written before the `plan` column: the last field of
/// every line left off.
fn without_last_column(text: &str) -> String {
    without_last_columns(text, 1)
}

/// `text` with the last `n` fields of every line left off.
fn without_last_columns(text: &str, n: usize) -> String {
    text.lines()
        .map(|l| {
            let mut l = l;
            for _ in 0..n {
                l = l.rsplit_once('\t').expect("a tab").0;
            }
            l.to_string() + "\n"
        })
        .collect()
}

/// Trial tables written before the reference and cost columns (header
/// ending in `plan`) read with those `None`, and a resume adds them
/// (`n/a`) before appending.
#[test]
fn trial_files_without_the_reference_and_costs_read_and_resume() {
    let dir = tempfile::tempdir().unwrap();
    let t = dir.path().join("trials.tsv");
    write_rows(&t, &[trial(0), trial(1)]);
    let old = without_last_columns(&std::fs::read_to_string(&t).unwrap(), AFTER_PLAN.len());
    assert!(old.lines().next().unwrap().ends_with("\tplan"));
    std::fs::write(&t, &old).unwrap();
    let back = read_tsv::<TrialRow>(&t).unwrap();
    assert_eq!(
        back.rows,
        vec![without_costs(trial(0)), without_costs(trial(1))]
    );
    assert!(back.warnings.is_empty());
    let mut log = TsvLog::<TrialRow>::append_to(&t).unwrap();
    assert_eq!(log.added_columns(), &AFTER_PLAN);
    log.write(&trial(2)).unwrap();
    drop(log);
    let text = std::fs::read_to_string(&t).unwrap();
    assert!(text
        .lines()
        .nth(1)
        .unwrap()
        .ends_with("\tn/a\tn/a\tn/a\tn/a\tn/a\tn/a"));
    let back = read_tsv::<TrialRow>(&t).unwrap().rows;
    assert_eq!(
        back,
        vec![without_costs(trial(0)), without_costs(trial(1)), trial(2)]
    );
}

fn frame(k: u64, plan: Option<&str>) -> FrameRow {
    FrameRow {
        sitting: 1,
        host_us: 1_000 + k,
        trial: (k > 0).then_some(k as usize),
        phase: if k > 0 { "search" } else { "instructions" }.into(),
        rays: 10 * k,
        render_ms: 0.5,
        interval_ms: (k > 0).then_some(16.5),
        late: false,
        plan: plan.map(String::from),
        gpu_uploaded_bytes: None,
        gpu_read_back_bytes: None,
        gpu_dispatches: None,
        gpu_draws: None,
        gpu_submits: None,
    }
}

/// The frames.tsv columns added after `plan`: the GPU traffic.
const FRAME_GPU: [&str; 5] = [
    "gpu_uploaded_bytes",
    "gpu_read_back_bytes",
    "gpu_dispatches",
    "gpu_draws",
    "gpu_submits",
];

/// Session folders written before the `plan` column (its header one column
/// short) still read: every row with `plan` `None`, everything else as
/// written. A header missing more than the later columns is still refused.
#[test]
fn files_without_the_plan_column_read_with_no_plan() {
    let dir = tempfile::tempdir().unwrap();
    let t = dir.path().join("trials.tsv");
    write_rows(&t, &[trial(0), trial(1)]);
    let old = without_last_columns(&std::fs::read_to_string(&t).unwrap(), 1 + AFTER_PLAN.len());
    assert!(!old.contains("plan") && old.lines().next().unwrap().ends_with("\tsynthetic"));
    std::fs::write(&t, &old).unwrap();
    let back = read_tsv::<TrialRow>(&t).unwrap();
    let want: Vec<TrialRow> = (0..2)
        .map(|i| TrialRow {
            plan: None,
            ..without_costs(trial(i))
        })
        .collect();
    assert_eq!(back.rows, want);
    assert!(back.warnings.is_empty());

    let f = dir.path().join("frames.tsv");
    write_rows(
        &f,
        &[
            frame(0, None),
            frame(1, Some("image-based on cpu; passes: none")),
        ],
    );
    std::fs::write(
        &f,
        without_last_columns(&std::fs::read_to_string(&f).unwrap(), 1 + FRAME_GPU.len()),
    )
    .unwrap();
    let back = read_tsv::<FrameRow>(&f).unwrap();
    assert_eq!(back.rows, vec![frame(0, None), frame(1, None)]);

    // One column fewer than that is no known header.
    std::fs::write(&t, without_last_column(&old)).unwrap();
    assert!(matches!(
        read_tsv::<TrialRow>(&t),
        Err(SessionFileError::Header { .. })
    ));
    // Nor is a row one field short under the current header.
    let mut text = std::fs::read_to_string(&f).unwrap();
    let current = FrameRow::header_line();
    let (_, rows) = text.split_once('\n').unwrap();
    text = format!("{current}\n{rows}");
    std::fs::write(&f, text).unwrap();
    assert!(matches!(
        read_tsv::<FrameRow>(&f),
        Err(SessionFileError::Parse { line: 2, .. })
    ));
}

/// A sitting resumed on a file written before the `plan` column adds the
/// column first: the current header, `n/a` at the end of each earlier row
/// (every other byte kept), a killed writer's half line cut off and
/// reported; then the new rows append under the one header.
#[test]
fn resuming_an_old_file_adds_the_plan_column() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("frames.tsv");
    write_rows(&p, &[frame(0, None), frame(1, None), frame(2, None)]);
    let old = without_last_columns(&std::fs::read_to_string(&p).unwrap(), 1 + FRAME_GPU.len());
    let half = "1\t5000\t3\tsea";
    std::fs::write(&p, format!("{old}{half}")).unwrap();

    let mut log = TsvLog::<FrameRow>::append_to(&p).unwrap();
    let mut added = vec!["plan"];
    added.extend(FRAME_GPU);
    assert_eq!(log.added_columns(), added.as_slice());
    assert_eq!(log.dropped_partial_line(), Some(half));
    assert_eq!(log.rows(), 3);
    let new = FrameRow {
        gpu_uploaded_bytes: Some(128),
        gpu_read_back_bytes: Some(4096),
        gpu_dispatches: Some(7),
        gpu_draws: Some(0),
        gpu_submits: Some(1),
        ..frame(
            3,
            Some("image-based on gpu; passes: image-based foveation (gpu)"),
        )
    };
    log.write(&new).unwrap();
    drop(log);

    let text = std::fs::read_to_string(&p).unwrap();
    let lines: Vec<&str> = text.lines().collect();
    assert_eq!(lines[0], FrameRow::header_line());
    for (k, l) in old.lines().skip(1).enumerate() {
        assert_eq!(lines[1 + k], format!("{l}{}", "\tn/a".repeat(6)));
    }
    assert!(lines[4].ends_with(
        "\timage-based on gpu; passes: image-based foveation (gpu)\t128\t4096\t7\t0\t1"
    ));
    let back = read_tsv::<FrameRow>(&p).unwrap();
    assert_eq!(
        back.rows,
        vec![frame(0, None), frame(1, None), frame(2, None), new]
    );
    assert!(back.warnings.is_empty());
    // No temporary file is left beside it.
    let names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert_eq!(names, vec!["frames.tsv".to_string()]);
    // Reopening the upgraded file adds nothing.
    let log = TsvLog::<FrameRow>::append_to(&p).unwrap();
    assert!(log.added_columns().is_empty());
    assert_eq!(log.rows(), 4);

    // An old trial table as a resume finds it.
    let t = dir.path().join("trials.tsv");
    write_rows(&t, &[trial(0)]);
    std::fs::write(
        &t,
        without_last_columns(&std::fs::read_to_string(&t).unwrap(), 1 + AFTER_PLAN.len()),
    )
    .unwrap();
    let mut log = TsvLog::<TrialRow>::append_to(&t).unwrap();
    let mut added = vec!["plan"];
    added.extend(AFTER_PLAN);
    assert_eq!(log.added_columns(), added.as_slice());
    log.write(&trial(1)).unwrap();
    drop(log);
    let back = read_tsv::<TrialRow>(&t).unwrap().rows;
    assert_eq!(
        back,
        vec![
            TrialRow {
                plan: None,
                ..without_costs(trial(0))
            },
            trial(1)
        ]
    );
}

/// An old file with a row of the wrong length is not rewritten: the error
/// names the file and line, and the file is left as it was.
#[test]
fn an_old_file_with_a_bad_row_is_left_untouched() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("frames.tsv");
    write_rows(&p, &[frame(0, None), frame(1, None)]);
    let mut old = without_last_columns(&std::fs::read_to_string(&p).unwrap(), 1 + FRAME_GPU.len());
    old.push_str("1\t2\tn/a\n");
    std::fs::write(&p, &old).unwrap();
    let err = match TsvLog::<FrameRow>::append_to(&p) {
        Err(e) => e,
        Ok(_) => panic!("a bad row was accepted"),
    };
    match &err {
        SessionFileError::Parse { path, line, .. } => {
            assert_eq!(path, &p);
            assert_eq!(*line, 4);
        }
        other => panic!("unexpected {other:?}"),
    }
    assert!(err.to_string().contains("plan"), "{err}");
    assert_eq!(std::fs::read_to_string(&p).unwrap(), old);
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
}

#[test]
fn header_mismatch_is_an_error_naming_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("events.tsv");
    std::fs::write(&p, "trial\tkind\tonset_us\n1\tfixation\t5\n").unwrap();
    let before = std::fs::read(&p).unwrap();
    let err = match TsvLog::<EventRow>::append_to(&p) {
        Err(e) => e,
        Ok(_) => panic!("a mismatched header was accepted"),
    };
    assert!(matches!(&err, SessionFileError::Header { path, .. } if path == &p));
    let msg = err.to_string();
    assert!(
        msg.contains("events.tsv") && msg.contains("header"),
        "{msg}"
    );
    assert_eq!(std::fs::read(&p).unwrap(), before, "file untouched");
    // Reading too.
    let err = read_tsv::<EventRow>(&p).unwrap_err();
    assert!(matches!(&err, SessionFileError::Header { path, .. } if path == &p));
    // A trials header offered to the samples reader.
    let t = dir.path().join("trials.tsv");
    write_rows(&t, &[trial(0)]);
    assert!(matches!(
        read_tsv::<SampleRow>(&t),
        Err(SessionFileError::Header { .. })
    ));
    // A partial header that is not a prefix of the expected one.
    std::fs::write(&p, "nonsense").unwrap();
    assert!(matches!(
        TsvLog::<EventRow>::append_to(&p),
        Err(SessionFileError::Header { .. })
    ));
}

#[test]
fn parse_errors_name_file_line_and_column() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("trials.tsv");
    write_rows(&p, &[trial(0), trial(1), trial(2)]);
    let text = std::fs::read_to_string(&p).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let mut fields: Vec<String> = lines[2].split('\t').map(String::from).collect();
    fields[14] = "fast".into(); // rt_s
    lines[2] = fields.join("\t");
    std::fs::write(&p, lines.join("\n") + "\n").unwrap();
    let err = read_tsv::<TrialRow>(&p).unwrap_err();
    match &err {
        SessionFileError::Parse {
            path, line, column, ..
        } => {
            assert_eq!(path, &p);
            assert_eq!(*line, 3);
            assert_eq!(column.as_deref(), Some("rt_s"));
        }
        other => panic!("unexpected {other:?}"),
    }
    let msg = err.to_string();
    assert!(
        msg.contains("trials.tsv") && msg.contains("line 3") && msg.contains("rt_s"),
        "{msg}"
    );

    // n/a where a value is required.
    fields[14] = "8.5".into();
    fields[9] = "n/a".into(); // target_mesh
    lines[2] = fields.join("\t");
    std::fs::write(&p, lines.join("\n") + "\n").unwrap();
    let err = read_tsv::<TrialRow>(&p).unwrap_err();
    assert!(
        matches!(&err, SessionFileError::Parse { line: 3, column: Some(c), .. } if c == "target_mesh"),
        "{err}"
    );

    // Too few fields on a complete line.
    lines[2] = "P 01\t0\t1".into();
    std::fs::write(&p, lines.join("\n") + "\n").unwrap();
    let err = read_tsv::<TrialRow>(&p).unwrap_err();
    assert!(
        matches!(&err, SessionFileError::Parse { line: 3, .. }),
        "{err}"
    );

    // A bad Option value names its column too.
    fields[9] = "3".into();
    fields[17] = "maybe".into(); // correct
    lines[2] = fields.join("\t");
    std::fs::write(&p, lines.join("\n") + "\n").unwrap();
    let err = read_tsv::<TrialRow>(&p).unwrap_err();
    assert!(
        matches!(&err, SessionFileError::Parse { line: 3, column: Some(c), .. } if c == "correct"),
        "{err}"
    );

    // A missing file names it.
    let missing = dir.path().join("nope.tsv");
    let err = read_tsv::<TrialRow>(&missing).unwrap_err();
    assert!(matches!(&err, SessionFileError::Io { path, .. } if path == &missing));
    assert!(err.to_string().contains("nope.tsv"));
}

#[test]
fn every_row_reaches_the_os_by_default_and_batches_flush_on_drop() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("samples.tsv");
    let s = |i: u64| SampleRow {
        sitting: 1,
        mapped_us: i,
        device_us: Some(i * 2),
        arrival_us: i + 10,
        time_order: "ok".into(),
        segment: 0,
        trial: Some(0),
        phase: "search".into(),
        raw_x: Some(0.5),
        raw_y: None,
        x_px: Some(640.25),
        y_px: None,
        left_x_px: None,
        left_y_px: None,
        left_pupil: None,
        right_x_px: None,
        right_y_px: None,
        right_pupil: None,
    };
    let mut log = TsvLog::<SampleRow>::append_to(&p).unwrap();
    log.write(&s(1)).unwrap();
    // Still open: another reader already sees the row.
    assert_eq!(read_tsv::<SampleRow>(&p).unwrap().rows, vec![s(1)]);
    drop(log);

    let mut log = TsvLog::<SampleRow>::append_to(&p)
        .unwrap()
        .flush_every(100, Duration::from_secs(3600));
    log.write(&s(2)).unwrap();
    log.write(&s(3)).unwrap();
    assert_eq!(
        read_tsv::<SampleRow>(&p).unwrap().rows.len(),
        1,
        "batched rows still pending"
    );
    log.flush().unwrap();
    assert_eq!(read_tsv::<SampleRow>(&p).unwrap().rows.len(), 3);
    log.write(&s(4)).unwrap();
    log.sync().unwrap();
    assert_eq!(read_tsv::<SampleRow>(&p).unwrap().rows.len(), 4);
    log.write(&s(5)).unwrap();
    drop(log);
    assert_eq!(
        read_tsv::<SampleRow>(&p).unwrap().rows,
        vec![s(1), s(2), s(3), s(4), s(5)]
    );

    // Time-based batching: an elapsed interval flushes at the next write.
    let mut log = TsvLog::<SampleRow>::append_to(&p)
        .unwrap()
        .flush_every(1000, Duration::from_millis(1));
    std::thread::sleep(Duration::from_millis(5));
    log.write(&s(6)).unwrap();
    assert_eq!(read_tsv::<SampleRow>(&p).unwrap().rows.len(), 6);
    std::mem::forget(log); // as if killed: nothing pending is lost
    assert_eq!(read_tsv::<SampleRow>(&p).unwrap().rows.len(), 6);
}

fn info() -> SessionInfo {
    SessionInfo {
        participant: "P01".into(),
        participant_index: 3,
        design_name: "murphy2007-search".into(),
        software: "gazecast 0.1.0".into(),
        display: DisplayInfo {
            name: "17\" LCD".into(),
            width_px: 1280,
            height_px: 1024,
            width_mm: 337.9,
            height_mm: 270.3,
            distance_mm: 540.0,
        },
        tracker: "Tobii ET-1750".into(),
        tracker_rate_hz: Some(50.0),
        started_unix_s: 1_700_000_000.123456,
        synthetic: false,
        notes: vec!["chin rest".into(), "tab\there".into()],
        sittings: Vec::new(),
    }
}

#[test]
fn session_json_round_trips_through_a_rename() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("session.json");
    info().write(&p).unwrap();
    assert_eq!(SessionInfo::read(&p).unwrap(), info());
    // Overwrite: no temporary files left behind.
    let mut other = info();
    other.tracker_rate_hz = None;
    other.write(&p).unwrap();
    assert_eq!(SessionInfo::read(&p).unwrap(), other);
    let names: Vec<_> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, vec![std::ffi::OsString::from("session.json")]);
    let text = std::fs::read_to_string(&p).unwrap();
    assert!(text.contains("\"tracker_rate_hz\": null"), "{text}");
}

#[test]
fn corrupt_session_json_names_file_and_line() {
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("session.json");
    info().write(&p).unwrap();
    let text = std::fs::read_to_string(&p).unwrap();
    std::fs::write(
        &p,
        text.replace(
            "\"participant_index\": 3",
            "\"participant_index\": \"three\"",
        ),
    )
    .unwrap();
    let err = SessionInfo::read(&p).unwrap_err();
    let msg = err.to_string();
    assert!(matches!(&err, SessionFileError::Json { path, .. } if path == &p));
    assert!(
        msg.contains("session.json") && msg.contains("line 3"),
        "{msg}"
    );
    let missing = dir.path().join("none.json");
    assert!(SessionInfo::read(&missing)
        .unwrap_err()
        .to_string()
        .contains("none.json"));
}

#[test]
fn stimulus_names_are_zero_padded() {
    assert_eq!(experiment::session::stimulus_file_name(7), "trial-007.png");
    assert_eq!(experiment::session::stimulus_file_name(43), "trial-043.png");
    assert_eq!(
        experiment::session::stimulus_file_name(1234),
        "trial-1234.png"
    );
    assert_eq!(
        experiment::session::stimulus_path(Path::new("s"), 5),
        Path::new("s/stimuli/trial-005.png")
    );
}
