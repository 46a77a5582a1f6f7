//! `--lsl` end to end, with pylsl (the reference liblsl) as the consumer
//! (tests/lsl/inlet_record.py): `view --replay` and a simulated
//! `experiment run` under Xvfb publish streams whose metadata, values and
//! timestamps match what gazecast itself logs and writes. Every process
//! runs with LSLAPICFG=tests/lsl/lsl_api.cfg (127.0.0.1 only). The Python
//! interpreter: $GAZECAST_PYLSL, else what scripts/lsl-venv.sh prints.
#![cfg(feature = "lsl")]

mod common;

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use common::{windowed, Xvfb};
use serde_json::Value;

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../..")
}

fn lsl_cfg() -> PathBuf {
    root().join("tests/lsl/lsl_api.cfg")
}

fn python() -> PathBuf {
    if let Some(p) = std::env::var_os("GAZECAST_PYLSL").filter(|p| !p.is_empty()) {
        return p.into();
    }
    let out = Command::new("scripts/lsl-venv.sh")
        .current_dir(root())
        .output()
        .expect("scripts/lsl-venv.sh runs");
    assert!(
        out.status.success(),
        "scripts/lsl-venv.sh: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let s = String::from_utf8_lossy(&out.stdout);
    s.lines().last().expect("it prints the interpreter").into()
}

/// Runs `gazecast ARGS --lsl --lsl-wait 60` in a window on `x` and the
/// Python inlet on `streams` together; returns (exit ok, the session log,
/// the inlet's JSON).
fn run_with_inlet(x: &Xvfb, args: &[&str], streams: &[&str], dir: &Path) -> (String, Value) {
    let mut g = windowed(x);
    g.args(args)
        .args(["--lsl", "--lsl-wait", "60"])
        .env("LSLAPICFG", lsl_cfg())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    let mut child = g.spawn().expect("gazecast starts");
    // Read the log while it runs: the pipe never fills.
    let mut stdout = child.stdout.take().expect("piped");
    let reader = std::thread::spawn(move || {
        let mut s = String::new();
        let _ = stdout.read_to_string(&mut s);
        s
    });
    let json = dir.join("inlet.json");
    let mut py = Command::new(python());
    py.arg(root().join("tests/lsl/inlet_record.py"))
        .args(["--out"])
        .arg(&json)
        .args([
            "--resolve-timeout",
            "60",
            // The inlet stops when gazecast's outlets are gone (lost);
            // a loaded machine can keep every stream quiet for seconds
            // while a trial is built, so silence alone must not end it.
            "--idle",
            "60",
            "--duration",
            "300",
        ])
        .env("LSLAPICFG", lsl_cfg());
    for s in streams {
        py.args(["--stream", s]);
    }
    let py_out = py.output().expect("the inlet runs");
    let status = child.wait().expect("gazecast ends");
    let log = reader.join().expect("log reader");
    let mut err = String::new();
    if let Some(mut e) = child.stderr.take() {
        let _ = e.read_to_string(&mut err);
    }
    assert!(status.success(), "gazecast failed:\n{log}\n{err}");
    assert!(
        py_out.status.success(),
        "inlet failed: {}\nlog:\n{log}",
        String::from_utf8_lossy(&py_out.stderr)
    );
    let text = std::fs::read_to_string(&json).expect("the inlet's JSON");
    (log, serde_json::from_str(&text).expect("JSON"))
}

/// The offset the session logged: LSL seconds = monotonic_us / 1e6 + it.
fn logged_offset(log: &str) -> f64 {
    let l = log
        .lines()
        .find(|l| l.starts_with("lsl: clock: LSL seconds = monotonic_us / 1e6 + "))
        .unwrap_or_else(|| panic!("no clock line:\n{log}"));
    l["lsl: clock: LSL seconds = monotonic_us / 1e6 + ".len()..]
        .split_whitespace()
        .next()
        .and_then(|v| v.parse().ok())
        .expect("an offset")
}

fn samples<'a>(j: &'a Value, stream: &str) -> &'a Vec<Value> {
    j["streams"][stream]["samples"]
        .as_array()
        .unwrap_or_else(|| panic!("no stream {stream}"))
}

fn ts(s: &Value) -> f64 {
    s["ts"].as_f64().expect("ts")
}

fn text(s: &Value) -> &str {
    s["values"][0].as_str().expect("a string marker")
}

/// The float32 value of channel `k` (NaN: null).
fn value(s: &Value, k: usize) -> f32 {
    let bits = s["bits"][k].as_str().expect("bits");
    f32::from_bits(u32::from_str_radix(bits, 16).expect("hex"))
}

/// Checks the stream's description: name, type, format, source id and
/// the channels (label, unit, type).
fn check_info(j: &Value, stream: &str, kind: &str, format: &str, source_id: &str) -> String {
    let xml = j["streams"][stream]["info_xml"]
        .as_str()
        .expect("info xml")
        .to_string();
    for want in [
        format!("<name>{stream}</name>"),
        format!("<type>{kind}</type>"),
        format!("<channel_format>{format}</channel_format>"),
        format!("<source_id>{source_id}</source_id>"),
    ] {
        assert!(xml.contains(&want), "{want} not in\n{xml}");
    }
    xml
}

const GAZE_CHANNELS: [(&str, &str, &str); 6] = [
    ("gaze_x", "pixels", "ScreenX"),
    ("gaze_y", "pixels", "ScreenY"),
    ("left_gaze_x", "pixels", "ScreenX"),
    ("left_gaze_y", "pixels", "ScreenY"),
    ("right_gaze_x", "pixels", "ScreenX"),
    ("right_gaze_y", "pixels", "ScreenY"),
];

fn check_gaze_channels(xml: &str) {
    let compact: String = xml.split_whitespace().collect();
    let want: String = GAZE_CHANNELS
        .iter()
        .map(|(l, u, t)| {
            format!("<channel><label>{l}</label><unit>{u}</unit><type>{t}</type></channel>")
        })
        .collect();
    assert!(
        compact.contains(&format!("<channels>{want}</channels>")),
        "{xml}"
    );
}

/// A TSV file as header → column index and rows.
fn tsv(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let s = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut lines = s.lines();
    let header = lines
        .next()
        .expect("a header")
        .split('\t')
        .map(str::to_string)
        .collect();
    let rows = lines
        .map(|l| l.split('\t').map(str::to_string).collect())
        .collect();
    (header, rows)
}

fn col(header: &[String], name: &str) -> usize {
    header
        .iter()
        .position(|h| h == name)
        .unwrap_or_else(|| panic!("no column {name} in {header:?}"))
}

/// The LSL time of a host µs reading, on the logged offset.
fn lsl_of(us: &str, offset: f64) -> f64 {
    us.parse::<u64>().expect("µs") as f64 / 1e6 + offset
}

#[test]
#[ignore = "slow tier: peer test against pylsl"]
fn view_replay_publishes_every_gaze_sample_and_a_marker_per_frame() {
    let dir = tempfile::tempdir().expect("tempdir");
    // What the recording decodes to (the viewer's gaze and mapped times).
    let csv = dir.path().join("replay.csv");
    common::gazecast()
        .args(["replay", "--input", "tests/data/mouse-120hz.gzrec", "--csv"])
        .arg(&csv)
        .output()
        .expect("replay runs");
    let (h, rows) = {
        let s = std::fs::read_to_string(&csv).expect("replay csv");
        let mut l = s.lines();
        let h: Vec<String> = l
            .next()
            .expect("header")
            .split(',')
            .map(str::to_string)
            .collect();
        let rows: Vec<Vec<String>> = l
            .map(|r| r.split(',').map(str::to_string).collect())
            .collect();
        (h, rows)
    };
    let x = Xvfb::start();
    let (log, j) = run_with_inlet(
        &x,
        &[
            "view",
            "--scene",
            "config/scenes/search-task.ron",
            "--display",
            "config/displays/tobii-et1750-17in.ron",
            "--replay",
            "tests/data/mouse-120hz.gzrec",
            "--frames",
            "60",
            "--backend",
            "cpu",
        ],
        &["gazecast-view-gaze:Gaze", "gazecast-view-frames:Markers"],
        dir.path(),
    );
    assert!(log.contains("lsl: every stream has a consumer"), "{log}");
    let offset = logged_offset(&log);

    // The gaze stream: its description, then every recorded sample.
    let xml = check_info(
        &j,
        "gazecast-view-gaze",
        "Gaze",
        "float32",
        "gazecast-view-gaze",
    );
    check_gaze_channels(&xml);
    let gaze = samples(&j, "gazecast-view-gaze");
    // The session may end before the replay does: every sample the viewer
    // drained is pushed, the recording's first ones in order.
    let pushed = format!("lsl: pushed {} gaze samples, 60 frame markers", gaze.len());
    assert!(log.contains(&pushed), "{pushed} not in\n{log}");
    assert!(
        gaze.len() > 100 && gaze.len() <= rows.len(),
        "{} gaze samples of {} recorded",
        gaze.len(),
        rows.len()
    );
    let (mt, gx, gy, gv) = (
        col(&h, "mapped_time_us"),
        col(&h, "gaze_x"),
        col(&h, "gaze_y"),
        col(&h, "gaze_valid"),
    );
    let t0 = ts(&gaze[0]);
    let m0: f64 = rows[0][mt].parse().expect("µs");
    let mut worst_dt = 0.0f64;
    for (s, r) in gaze.iter().zip(&rows) {
        // Intervals: as recorded (the replay is moved by one constant).
        let m: f64 = r[mt].parse().expect("µs");
        let dt = ((ts(s) - t0) - (m - m0) / 1e6).abs();
        worst_dt = worst_dt.max(dt);
        let (x, y) = (value(s, 0), value(s, 1));
        if r[gv] == "1" {
            let want: [f32; 2] = [
                r[gx].parse::<f64>().expect("x") as f32,
                r[gy].parse::<f64>().expect("y") as f32,
            ];
            assert_eq!([x, y], want, "sample {}", r[0]);
        } else {
            assert!(x.is_nan() && y.is_nan(), "invalid sample {}: {x} {y}", r[0]);
        }
    }
    assert!(worst_dt < 1e-3, "gaze timestamps off by {worst_dt} s");
    // Stamped at capture, before the consumer got them (pylsl's clock);
    // a few ms allow for the replay's pacing.
    for g in gaze {
        let recv = g["recv"].as_f64().expect("recv");
        assert!(
            recv >= ts(g) - 5e-3,
            "received {recv} before stamped {}",
            ts(g)
        );
    }
    eprintln!(
        "gaze: {} samples, worst interval error {:.3} µs",
        gaze.len(),
        worst_dt * 1e6
    );

    // The frame markers: one per logged frame, at its present time.
    check_info(
        &j,
        "gazecast-view-frames",
        "Markers",
        "string",
        "gazecast-view-frames",
    );
    let frames = samples(&j, "gazecast-view-frames");
    let logged: Vec<&str> = log.lines().filter(|l| l.starts_with("frame ")).collect();
    assert_eq!(logged.len(), 60, "{log}");
    assert_eq!(frames.len(), logged.len());
    let mut worst = 0.0f64;
    for (k, (m, l)) in frames.iter().zip(&logged).enumerate() {
        let t = text(m);
        assert!(t.starts_with(&format!("frame={k} ")), "{t}");
        // The same gaze the log line shows.
        let gaze_in_log = l
            .split_once("gaze (")
            .and_then(|(_, r)| r.split_once(')'))
            .map(|(g, _)| g.replace(' ', ""))
            .expect("a gaze in the log line");
        let field = |name: &str| {
            t.split_whitespace()
                .find_map(|f| f.strip_prefix(name))
                .unwrap_or_else(|| panic!("no {name} in {t}"))
                .to_string()
        };
        assert_eq!(
            format!("{},{}", field("gaze_x="), field("gaze_y=")),
            gaze_in_log
        );
        // Across streams: the frame's gaze is a sample captured before it
        // was presented.
        let (fx, fy): (f32, f32) = (
            field("gaze_x=").parse().expect("x"),
            field("gaze_y=").parse().expect("y"),
        );
        if k > 0 || field("fresh=") == "1" {
            assert!(
                gaze.iter().any(|g| ts(g) < ts(m)
                    && (value(g, 0) - fx).abs() < 0.051
                    && (value(g, 1) - fy).abs() < 0.051),
                "frame {k}: no gaze sample ({fx}, {fy}) before it"
            );
        }
        let want = lsl_of(&field("present_us="), offset);
        worst = worst.max((ts(m) - want).abs());
        // Pushed after its present, pulled soon after (pylsl's own clock).
        let recv = m["recv"].as_f64().expect("recv");
        assert!(
            recv >= ts(m) - 1e-3,
            "received {recv} before stamped {}",
            ts(m)
        );
        assert!(recv - ts(m) < 2.0, "received {recv}, stamped {}", ts(m));
    }
    assert!(worst < 1e-3, "frame stamps off by {worst} s");
    eprintln!(
        "frames: {} markers, worst stamp error {:.3} µs",
        frames.len(),
        worst * 1e6
    );
}

#[test]
#[ignore = "slow tier: peer test against pylsl (an experiment session)"]
fn experiment_run_publishes_the_session_files_rows() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("data");
    let x = Xvfb::start();
    let (log, j) = run_with_inlet(
        &x,
        &[
            "experiment",
            "run",
            "tests/data/experiment/design-small.ron",
            "--participant",
            "P01",
            "--tracker",
            "tests/data/mouse-participant.ron",
            "--display",
            "tests/data/experiment/display-small.ron",
            "--backend",
            "cpu",
            "--simulate-participant",
            "1",
            "--max-trials",
            "1",
            "--no-stimulus-pictures",
            "--out",
            out.to_str().expect("utf-8 path"),
        ],
        &[
            "gazecast-experiment-events:Markers",
            "gazecast-experiment-frames:Markers",
            "gazecast-experiment-gaze:Gaze",
        ],
        dir.path(),
    );
    let offset = logged_offset(&log);
    let session = out.join("small-search").join("sub-P01");

    // Events: markers.tsv, row for row, at its host_us.
    check_info(
        &j,
        "gazecast-experiment-events",
        "Markers",
        "string",
        "gazecast-experiment-events-small-search-P01",
    );
    let (h, rows) = tsv(&session.join("markers.tsv"));
    let (hu, tr, ev, de) = (
        col(&h, "host_us"),
        col(&h, "trial"),
        col(&h, "event"),
        col(&h, "detail"),
    );
    let events = samples(&j, "gazecast-experiment-events");
    assert_eq!(
        events.len(),
        rows.len(),
        "one LSL marker per markers.tsv row"
    );
    assert!(rows.iter().any(|r| r[ev] == "search-onset"), "{rows:?}");
    assert!(
        rows.iter().any(|r| r[ev] == "calibration-result"),
        "{rows:?}"
    );
    let mut worst = 0.0f64;
    for (m, r) in events.iter().zip(&rows) {
        let trial = if r[tr] == "n/a" { "-" } else { r[tr].as_str() };
        assert_eq!(text(m), format!("{}; trial={trial}; {}", r[ev], r[de]));
        worst = worst.max((ts(m) - lsl_of(&r[hu], offset)).abs());
        let recv = m["recv"].as_f64().expect("recv");
        assert!(
            recv >= ts(m) - 1e-3,
            "received {recv} before stamped {}",
            ts(m)
        );
        assert!(recv - ts(m) < 2.0, "received {recv}, stamped {}", ts(m));
    }
    assert!(worst < 1e-3, "event stamps off by {worst} s");
    eprintln!(
        "events: {} markers, worst stamp error {:.3} µs",
        events.len(),
        worst * 1e6
    );

    // Frames: frames.tsv, row for row.
    let (h, rows) = tsv(&session.join("frames.tsv"));
    let (hu, ph) = (col(&h, "host_us"), col(&h, "phase"));
    let frames = samples(&j, "gazecast-experiment-frames");
    assert_eq!(frames.len(), rows.len(), "one marker per frames.tsv row");
    let mut worst = 0.0f64;
    for (k, (m, r)) in frames.iter().zip(&rows).enumerate() {
        assert!(
            text(m).starts_with(&format!("frame={k} phase={} ", r[ph])),
            "{}",
            text(m)
        );
        worst = worst.max((ts(m) - lsl_of(&r[hu], offset)).abs());
    }
    assert!(worst < 1e-3, "frame stamps off by {worst} s");
    eprintln!(
        "frames: {} markers, worst stamp error {:.3} µs",
        frames.len(),
        worst * 1e6
    );

    // Gaze: samples.tsv, row for row, at mapped_us.
    let xml = check_info(
        &j,
        "gazecast-experiment-gaze",
        "Gaze",
        "float32",
        "gazecast-experiment-gaze-small-search-P01",
    );
    check_gaze_channels(&xml);
    let (h, rows) = tsv(&session.join("samples.tsv"));
    let (mu, xp, yp) = (col(&h, "mapped_us"), col(&h, "x_px"), col(&h, "y_px"));
    let gaze = samples(&j, "gazecast-experiment-gaze");
    assert_eq!(gaze.len(), rows.len(), "one LSL sample per samples.tsv row");
    let mut worst = 0.0f64;
    for (s, r) in gaze.iter().zip(&rows) {
        worst = worst.max((ts(s) - lsl_of(&r[mu], offset)).abs());
        let (x, y) = (value(s, 0), value(s, 1));
        match (r[xp].parse::<f64>(), r[yp].parse::<f64>()) {
            (Ok(a), Ok(b)) => assert_eq!([x, y], [a as f32, b as f32]),
            _ => assert!(x.is_nan() && y.is_nan(), "{r:?}: {x} {y}"),
        }
    }
    assert!(worst < 1e-3, "gaze stamps off by {worst} s");
    eprintln!(
        "gaze: {} samples, worst stamp error {:.3} µs",
        gaze.len(),
        worst * 1e6
    );
}

#[test]
fn lsl_wait_needs_lsl_and_a_sane_number_of_seconds() {
    let view = |extra: &[&str]| {
        let out = common::gazecast()
            .args([
                "view",
                "--scene",
                "config/scenes/search-task.ron",
                "--display",
                "config/displays/tobii-et1750-17in.ron",
                "--explain",
            ])
            .args(extra)
            .env("LSLAPICFG", lsl_cfg())
            .output()
            .expect("runs");
        (
            out.status.success(),
            String::from_utf8_lossy(&out.stderr).to_string(),
        )
    };
    let (ok, err) = view(&["--lsl-wait", "5"]);
    assert!(!ok && err.contains("--lsl"), "{err}");
    for bad in ["-1", "nan", "601", "soon"] {
        let (ok, err) = view(&["--lsl", &format!("--lsl-wait={bad}")]);
        assert!(!ok && err.contains("seconds from 0 to 600"), "{bad}: {err}");
    }
    let (ok, err) = view(&["--lsl", "--lsl-wait", "0"]);
    assert!(ok, "{err}");
}

/// The windowed demo (the mouse as the gaze) publishes its own streams;
/// everything it says it pushed arrives.
#[test]
#[ignore = "slow tier: peer test against pylsl, in a window under Xvfb"]
fn windowed_demo_publishes_under_its_own_ids() {
    let dir = tempfile::tempdir().expect("tempdir");
    let x = Xvfb::start();
    let (log, j) = run_with_inlet(
        &x,
        &["demo", "--frames", "10"],
        &["gazecast-demo-gaze:Gaze", "gazecast-demo-frames:Markers"],
        dir.path(),
    );
    let xml = check_info(
        &j,
        "gazecast-demo-gaze",
        "Gaze",
        "float32",
        "gazecast-demo-gaze",
    );
    check_gaze_channels(&xml);
    check_info(
        &j,
        "gazecast-demo-frames",
        "Markers",
        "string",
        "gazecast-demo-frames",
    );
    let (g, f) = (
        samples(&j, "gazecast-demo-gaze").len(),
        samples(&j, "gazecast-demo-frames").len(),
    );
    assert_eq!(f, 10);
    assert!(g > 0, "{log}");
    let pushed = format!("lsl: pushed {g} gaze samples, {f} frame markers");
    assert!(log.contains(&pushed), "{pushed} not in\n{log}");
}
