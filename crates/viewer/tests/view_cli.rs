//! `gazecast view` in a real window under a virtual X server (Xvfb, which
//! `scripts/system-deps.sh` installs), rendering with the replayed gaze of a
//! recording: the POR box must be where the replayed gaze says.

mod common;

use common::{gazecast, succeed_windowed, windowed, Run, Xvfb};

/// `gazecast view` of the search task on the seed's display, CPU backend, in
/// the given X display.
fn view(x: &Xvfb) -> std::process::Command {
    let mut c = windowed(x);
    c.args([
        "view",
        "--scene",
        "config/scenes/search-task.ron",
        "--display",
        "config/displays/tobii-et1750-17in.ron",
        "--backend",
        "cpu",
    ]);
    c
}

#[test]
fn a_replayed_session_renders_in_a_window_with_the_por_box_at_the_gaze() {
    let x = Xvfb::start();
    let dir = tempfile::tempdir().expect("tempdir");
    let shot = dir.path().join("shot.png");
    let out = view(&x)
        .args([
            "--replay",
            "tests/data/mouse-120hz.gzrec",
            "--frames",
            "4",
            "--overlay",
            "por",
            "--screenshot",
        ])
        .arg(&shot)
        .succeed();
    let text = String::from_utf8_lossy(&out.stdout);
    let frames: Vec<&str> = text.lines().filter(|l| l.starts_with("frame ")).collect();
    assert_eq!(frames.len(), 4, "{text}");
    assert!(text.contains("gaze age at submit p50"), "{text}");
    // What drew the frames: the plan before the first frame, and on each
    // frame's line (it never changed: no key was pressed).
    let plan = text
        .lines()
        .find_map(|l| l.strip_prefix("plan: "))
        .unwrap_or_else(|| panic!("no plan line: {text}"));
    assert_eq!(plan, "hybrid on cpu; passes: POR box (cpu)", "{text}");
    assert!(
        text.find("\nplan: ") < text.find("\nframe 0 "),
        "the plan comes before the first frame: {text}"
    );
    assert!(!text.contains("plan changed"), "{text}");
    for f in &frames {
        assert!(f.ends_with(&format!(" [plan: {plan}]")), "{f}");
    }
    // The last frame's gaze, from the session log: "frame 3 gaze (x, y) …".
    let last = frames[3];
    let inner = &last[last.find('(').expect("(") + 1..last.find(')').expect(")")];
    let xy: Vec<f64> = inner
        .split(',')
        .map(|v| v.trim().parse().expect("number"))
        .collect();
    let png = std::fs::File::open(&shot).expect("screenshot");
    let mut reader = png::Decoder::new(std::io::BufReader::new(png))
        .read_info()
        .expect("png");
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).expect("frame");
    assert_eq!((info.width, info.height), (1280, 1024));
    let rgb = |px: i64, py: i64| -> [u8; 3] {
        let i = (py as usize * info.width as usize + px as usize) * info.color_type.samples();
        match info.color_type {
            png::ColorType::Rgb => [buf[i], buf[i + 1], buf[i + 2]],
            other => panic!("unexpected colour type {other:?}"),
        }
    };
    let (cx, cy) = (xy[0].round() as i64, xy[1].round() as i64);
    // The box's top and left edges, 32 px from the gaze.
    assert_eq!(
        rgb(cx, cy - 32),
        [255, 220, 0],
        "top edge at the gaze {xy:?}"
    );
    assert_eq!(
        rgb(cx - 32, cy),
        [255, 220, 0],
        "left edge at the gaze {xy:?}"
    );
}

#[test]
fn without_a_tracker_or_a_display_the_viewer_says_what_to_do() {
    let out = gazecast()
        .args([
            "view",
            "--scene",
            "config/scenes/search-task.ron",
            "--display",
            "config/displays/tobii-et1750-17in.ron",
        ])
        .output()
        .expect("runs");
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--tracker"));
}

#[test]
fn explain_prints_the_passes_of_the_scene_effects() {
    let out = gazecast()
        .args([
            "view",
            "--explain",
            "--scene",
            "config/scenes/search-task.ron",
            "--display",
            "config/displays/tobii-et1750-17in.ron",
        ])
        .succeed();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("cast vertices → classify cells → silhouette margin"),
        "{text}"
    );
    assert!(text.contains("crease > 30°"), "{text}");
    // --method image names its blur after the full cast.
    let out = gazecast()
        .args([
            "view",
            "--explain",
            "--method",
            "image",
            "--scene",
            "config/scenes/search-task.ron",
            "--display",
            "config/displays/tobii-et1750-17in.ron",
        ])
        .succeed();
    let image = String::from_utf8_lossy(&out.stdout);
    assert!(image.contains("method: image on"), "{image}");
    assert!(image.contains("then image-based foveation"), "{image}");
    assert!(!image.contains("classify"), "{image}");
    // A scene without FoveatedSampling runs the full-resolution pass only.
    let dir = tempfile::tempdir().expect("tempdir");
    let plain = dir.path().join("plain.ron");
    let text = std::fs::read_to_string("../../config/scenes/bunny.ron").expect("bunny");
    let text = text.replace(
        "sampling: Foveated(refine: [Silhouette, Crease(angle_deg: 30.0), Depth(jump: 0.05)]),\n    passes: [],",
        "effects: [],",
    );
    std::fs::write(&plain, text).expect("write");
    let out = gazecast()
        .args(["view", "--explain", "--scene"])
        .arg(&plain)
        .args(["--display", "config/displays/tobii-et1750-17in.ron"])
        .succeed();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("cast and shade every pixel"), "{text}");
    assert!(!text.contains("classify"), "{text}");
}

#[test]
fn a_lost_or_ended_tracker_keeps_the_viewer_rendering_with_a_status_line() {
    let x = Xvfb::start();
    let dir = tempfile::tempdir().expect("tempdir");
    // A tracker whose serial port does not exist: reopened with backoff.
    let tracker = dir.path().join("gone.ron");
    std::fs::write(
        &tracker,
        std::fs::read_to_string("../../config/trackers/iscan-binary.ron")
            .expect("tracker")
            .replace("Some(\"/dev/ttyUSB0\")", "Some(\"/nonexistent/tty\")"),
    )
    .expect("write");
    let out = view(&x)
        .args(["--frames", "3", "--tracker"])
        .arg(&tracker)
        .succeed();
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        text.lines().filter(|l| l.starts_with("frame ")).count(),
        3,
        "{text}"
    );
    assert!(
        text.contains("tracker: ") && text.contains("retrying"),
        "{text}"
    );
    assert!(text.contains("no gaze sample arrived"), "{text}");
    // A recording that ends after 0.2 s: the last gaze stays, a status says so.
    let rec = dir.path().join("short.gzrec");
    gazecast()
        .args([
            "simulate",
            "--tracker",
            "tests/data/mouse-realistic.ron",
            "--seconds",
            "0.2",
            "--out",
        ])
        .arg(&rec)
        .succeed();
    let out = view(&x)
        .args(["--frames", "5", "--replay"])
        .arg(&rec)
        .succeed();
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        text.lines().filter(|l| l.starts_with("frame ")).count(),
        5,
        "{text}"
    );
    assert!(
        text.contains("end of stream; keeping the last gaze"),
        "{text}"
    );
}

/// Reads a child's pipe to its end on a thread, so the child never blocks
/// on a full pipe.
fn drain<R: std::io::Read + Send + 'static>(pipe: Option<R>) -> std::thread::JoinHandle<String> {
    std::thread::spawn(move || {
        let mut s = String::new();
        if let Some(mut p) = pipe {
            let _ = p.read_to_string(&mut s);
        }
        s
    })
}

/// A 640×512 display with the seed's pixel pitch (a quarter of the pixels,
/// so the CPU renderer keeps up in a debug build).
fn small_display(dir: &std::path::Path) -> std::path::PathBuf {
    let path = dir.join("small.ron");
    std::fs::write(
        &path,
        "Display(name: \"small\", resolution_px: (640, 512), size_mm: (168.95, 135.15), eye_distance_mm: 600.0)",
    )
    .expect("write display");
    path
}

/// A 160 × 128 display file in `dir` (the GPU tests' frames).
fn tiny_display(dir: &std::path::Path) -> std::path::PathBuf {
    let path = dir.join("tiny.ron");
    std::fs::write(
        &path,
        "Display(name: \"tiny\", resolution_px: (160, 128), size_mm: (42.24, 33.79), eye_distance_mm: 600.0)",
    )
    .expect("write display");
    path
}

/// `gazecast view` of the search task on [`small_display`], CPU backend.
fn small_view(x: &Xvfb, dir: &std::path::Path) -> std::process::Command {
    small_view_on(x, dir, "cpu")
}

/// [`small_view`] on `backend`.
fn small_view_on(x: &Xvfb, dir: &std::path::Path, backend: &str) -> std::process::Command {
    let mut c = windowed(x);
    c.args([
        "view",
        "--scene",
        "config/scenes/search-task.ron",
        "--backend",
        backend,
        "--display",
    ])
    .arg(small_display(dir));
    c
}

/// A live ISCAN session over a real pseudo-terminal: the viewer records it,
/// the device disconnects mid-session (rendering goes on, with a status
/// line), then Ctrl-C ends the session and the recording is closed
/// properly and holds every byte the device sent.
#[test]
#[ignore = "slow tier: a windowed live session under Xvfb with a tracker that disconnects"]
fn a_live_session_survives_a_disconnect_and_ctrl_c_leaves_a_valid_recording() {
    use serialport::SerialPort;
    use std::io::{Read, Write};
    use std::time::{Duration, Instant};

    let x = Xvfb::start();
    let dir = tempfile::tempdir().expect("tempdir");
    let (mut master, slave) = serialport::TTYPort::pair().expect("pty pair");
    let slave_name = slave.name().expect("pty name");
    drop(slave); // ports are locked exclusively: the viewer opens it by path
    master
        .set_timeout(Duration::from_millis(100))
        .expect("timeout");
    let tracker = dir.path().join("iscan.ron");
    std::fs::write(
        &tracker,
        std::fs::read_to_string("../../config/trackers/iscan-binary.ron")
            .expect("tracker")
            .replace("Some(\"/dev/ttyUSB0\")", &format!("Some({slave_name:?})"))
            .replace("screen_px: (1280, 1024)", "screen_px: (640, 512)"),
    )
    .expect("write tracker");
    // What the device sends: a simulated ISCAN stream, 1.5 s at 60 Hz.
    let stream = dir.path().join("device.gzrec");
    gazecast()
        .args([
            "simulate",
            "--tracker",
            "config/trackers/iscan-binary.ron",
            "--seconds",
            "1.5",
            "--out",
        ])
        .arg(&stream)
        .succeed();
    let device = tracker_hal::Recording::read(&stream).expect("simulated stream");
    let record = dir.path().join("session.gzrec");
    let mut child = small_view(&x, dir.path())
        .arg("--tracker")
        .arg(&tracker)
        .arg("--record")
        .arg(&record)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("viewer starts");
    // The session log is read as it is written: a pipe nobody reads fills
    // (64 KiB, a few hundred frame lines) and blocks the viewer's log.
    let out_reader = drain(child.stdout.take());
    let err_reader = drain(child.stderr.take());
    // The driver's start command (0x84) says the viewer has the port open.
    let deadline = Instant::now() + Duration::from_secs(60);
    let mut byte = [0u8; 1];
    loop {
        assert!(
            Instant::now() < deadline,
            "no start command from the viewer"
        );
        if let Ok(1) = master.read(&mut byte) {
            if byte[0] == 0x84 {
                break;
            }
        }
    }
    let mut sent = Vec::new();
    let t0 = device.device_chunks().next().map_or(0, |c| c.time_us);
    let start = Instant::now();
    for c in device.device_chunks() {
        let due = Duration::from_micros(c.time_us - t0);
        if let Some(wait) = due.checked_sub(start.elapsed()) {
            std::thread::sleep(wait);
        }
        master.write_all(&c.payload).expect("write to the pty");
        sent.extend_from_slice(&c.payload);
    }
    std::thread::sleep(Duration::from_millis(500)); // let the viewer read it all
    drop(master); // the device goes away
                  // Silent for 2 s, the device is reopened (and the pty is gone).
    std::thread::sleep(Duration::from_millis(3500));
    let ok = std::process::Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .expect("kill runs");
    assert!(ok.success());
    let deadline = Instant::now() + Duration::from_secs(60);
    while child.try_wait().expect("wait").is_none() {
        if Instant::now() > deadline {
            let _ = child.kill();
            let _ = child.wait();
            panic!(
                "the viewer did not stop on Ctrl-C:\n{}\n{}",
                out_reader.join().expect("stdout"),
                err_reader.join().expect("stderr")
            );
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    let status = child.wait().expect("wait");
    let stdout = out_reader.join().expect("stdout");
    let stderr = err_reader.join().expect("stderr");
    let text = stdout.as_str();
    assert!(status.success(), "{text}\n{stderr}");
    // Rendering went on after the disconnect, with a status line.
    let lines: Vec<&str> = text.lines().collect();
    let lost = lines
        .iter()
        .position(|l| l.starts_with("tracker: ") && l.contains("keeping the last gaze"))
        .unwrap_or_else(|| panic!("no disconnect status: {text}"));
    assert!(
        lines[lost..].iter().any(|l| l.starts_with("frame ")),
        "no frame after the disconnect: {text}"
    );
    assert!(text.contains("interrupted (Ctrl-C or SIGTERM)"), "{text}");
    assert!(text.contains("gaze age at submit p50"), "{text}");
    assert!(text.contains("closed"), "{text}");
    // The recording is closed and holds exactly what the device sent, and
    // the start command the viewer wrote.
    let rec = tracker_hal::Recording::read(&record).expect("the recording reads");
    assert!(rec.closed, "no end chunk");
    assert!(rec.torn_tail.is_none(), "{:?}", rec.torn_tail);
    assert_eq!(rec.lost_chunks, 0);
    let got: Vec<u8> = rec
        .device_chunks()
        .flat_map(|c| c.payload.iter().copied())
        .collect();
    assert_eq!(got.len(), sent.len());
    assert!(got == sent, "the recorded bytes differ from the sent ones");
    assert!(rec
        .chunks
        .iter()
        .any(|c| c.kind == tracker_hal::recording::ChunkKind::HostToDevice && c.payload == [0x84]));
}

/// A 1000 Hz tracker floods the channel; the window still takes the newest
/// sample each frame, so every frame shows a new gaze.
#[test]
fn a_1000_hz_replay_gives_every_frame_a_new_sample() {
    let x = Xvfb::start();
    let dir = tempfile::tempdir().expect("tempdir");
    let rec = dir.path().join("fast.gzrec");
    gazecast()
        .args([
            "simulate",
            "--tracker",
            "config/trackers/mouse.ron",
            "--rate",
            "1000",
            "--seconds",
            "30",
            "--out",
        ])
        .arg(&rec)
        .succeed();
    let out = small_view(&x, dir.path())
        .args(["--frames", "6", "--replay"])
        .arg(&rec)
        .succeed();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("6 frames, 6 showed a new gaze sample"),
        "{text}"
    );
    assert!(text.contains("software-added latency"), "{text}");
}

/// With a display, the demo opens the window on the search task in mouse
/// mode.
#[test]
fn the_demo_opens_the_window_in_mouse_mode_when_there_is_a_display() {
    let mut x = Xvfb::start();
    let out = succeed_windowed(&mut x, &["demo", "--frames", "2"]);
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("gazecast view: search-task")
            && text.contains("mouse (config/trackers/mouse.ron)"),
        "{text}"
    );
    assert_eq!(
        text.lines().filter(|l| l.starts_with("frame ")).count(),
        2,
        "{text}"
    );
    // The attention model can lead the demo instead.
    let out = succeed_windowed(
        &mut x,
        &[
            "demo",
            "--frames",
            "2",
            "--tracker",
            "config/trackers/attention.ron",
        ],
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        text.contains("attention (config/trackers/attention.ron)"),
        "{text}"
    );
}

/// The attention gaze source (`config/trackers/attention.ron`): no eye
/// tracker, the point of regard is the attended object's saliency peak,
/// predicted from each rendered frame. The gaze leaves the screen centre
/// for an object, and the recording holds its samples as a mouse stream
/// that decodes to valid on-screen points.
#[test]
#[ignore = "slow tier: a windowed session under Xvfb"]
fn the_attention_source_moves_the_gaze_to_an_object_and_records_it() {
    for backend in ["cpu", "gpu"] {
        attention_source_on(backend);
    }
}

/// [`the_attention_source_moves_the_gaze_to_an_object_and_records_it`] on
/// `backend`; on the GPU the model runs on the GPU frame, which stays
/// there and is drawn into the window.
fn attention_source_on(backend: &str) {
    let x = Xvfb::start();
    let dir = tempfile::tempdir().expect("tempdir");
    let record = dir.path().join("attention.gzrec");
    let out = small_view_on(&x, dir.path(), backend)
        .args([
            "--tracker",
            "config/trackers/attention.ron",
            "--frames",
            "25",
            "--record",
        ])
        .arg(&record)
        .succeed();
    let text = String::from_utf8_lossy(&out.stdout);
    let gazes: Vec<[f64; 2]> = text
        .lines()
        .filter(|l| l.starts_with("frame "))
        .map(|l| {
            let inner = &l[l.find('(').expect("(") + 1..l.find(')').expect(")")];
            let v: Vec<f64> = inner
                .split(',')
                .map(|v| v.trim().parse().expect("number"))
                .collect();
            [v[0], v[1]]
        })
        .collect();
    assert_eq!(gazes.len(), 25, "{text}");
    assert_eq!(
        gazes[0],
        [320.0, 256.0],
        "the first frame has no prediction yet"
    );
    let last = gazes[24];
    assert!(last != gazes[0], "the gaze never left the centre: {text}");
    assert!(
        (0.0..640.0).contains(&last[0]) && (0.0..512.0).contains(&last[1]),
        "{last:?}"
    );
    let rec = tracker_hal::Recording::read(&record).expect("the recording reads");
    assert!(rec.closed);
    assert!(matches!(
        rec.header.tracker.driver,
        tracker_hal::Driver::Attention(_)
    ));
    let mut decoder = rec.header.tracker.decoder();
    let mut samples = std::collections::VecDeque::new();
    for c in rec.device_chunks() {
        tracker_hal::Decoder::push(&mut decoder, &c.payload, 0, &mut samples);
    }
    let valid: Vec<[f64; 2]> = samples.iter().filter_map(|s| s.gaze()).collect();
    assert!(!valid.is_empty(), "no valid sample recorded");
    assert!(
        valid
            .iter()
            .any(|p| (p[0] - last[0]).abs() < 1.0 && (p[1] - last[1]).abs() < 1.0),
        "the shown gaze {last:?} is not among the recorded samples"
    );
    if backend == "gpu" {
        assert!(
            text.contains("presenting: 25 frames drawn from the GPU's buffers"),
            "{text}"
        );
    }
}

#[test]
fn a_fixation_within_the_gaze_tolerance_keeps_its_frame_and_bad_tolerances_are_refused() {
    let x = Xvfb::start();
    // The recording fixates for 200–500 ms at a time (mouse jitter of a
    // few pixels): within the live default of 0.5° (about 18 px here) the
    // mask is kept and, after one frame drawn with it, the frame is copied.
    // 60 frames on the small display span several fixations, however slow
    // the machine (a loaded machine rendering 1280x1024 at 200 ms a frame
    // saw each fixation once in 24 frames).
    let dir = tempfile::tempdir().expect("tempdir");
    let out = small_view(&x, dir.path())
        .args(["--replay", "tests/data/mouse-120hz.gzrec", "--frames", "60"])
        .succeed();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("copied the last frame (mask kept)"), "{text}");
    assert!(text.contains("frames per second"), "{text}");
    assert!(text.contains("(gaze tolerance 0.5°)"), "{text}");
    // The summary counts what the frame lines say.
    let copied = text
        .lines()
        .filter(|l| l.starts_with("frame ") && l.contains("copied the last frame"))
        .count();
    assert!(
        text.contains(&format!("{copied} the last frame copied")),
        "{text}"
    );
    // --explain names the tolerance.
    let out = gazecast()
        .args([
            "view",
            "--explain",
            "--gaze-tolerance",
            "1.5",
            "--scene",
            "config/scenes/search-task.ron",
            "--display",
            "config/displays/tobii-et1750-17in.ron",
        ])
        .succeed();
    let explain = String::from_utf8_lossy(&out.stdout);
    assert!(explain.contains("gaze tolerance 1.5°"), "{explain}");
    for bad in ["-1", "nan", "11", "x"] {
        let out = gazecast()
            .args([
                "view",
                "--explain",
                "--scene",
                "config/scenes/search-task.ron",
                "--display",
                "config/displays/tobii-et1750-17in.ron",
                &format!("--gaze-tolerance={bad}"),
            ])
            .output()
            .expect("runs");
        assert!(!out.status.success(), "{bad} accepted");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains("--gaze-tolerance"), "{bad}: {err}");
    }
}

#[test]
fn masks_follow_the_eye_distance_a_hid_tracker_measures_unless_fixed() {
    let x = Xvfb::start();
    let run = |extra: &[&str]| {
        let mut c = windowed(&x);
        c.args([
            "view",
            "--scene",
            "config/scenes/bunny.ron",
            "--display",
            "config/displays/tobii-et1750-17in.ron",
            "--backend",
            "cpu",
            "--replay",
            "tests/data/tobii-hid-50hz.gzrec",
            "--frames",
            "3",
        ])
        .args(extra);
        String::from_utf8_lossy(&c.succeed().stdout).to_string()
    };
    // The simulated Tobii's eyes are about 600 mm from the screen; the
    // display file says 540.
    let measured = run(&[]);
    let line = measured
        .lines()
        .find(|l| l.starts_with("eye distance "))
        .unwrap_or_else(|| panic!("no eye distance line: {measured}"));
    let mm: f64 = line["eye distance ".len()..]
        .split_whitespace()
        .next()
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("{line}"));
    assert!((560.0..=650.0).contains(&mm), "{line}");
    let fixed = run(&["--eye-distance", "fixed"]);
    assert!(!fixed.contains("eye distance "), "{fixed}");
    // A mouse reports no eye positions: the display file's distance.
    let mouse = view(&x)
        .args(["--replay", "tests/data/mouse-120hz.gzrec", "--frames", "2"])
        .succeed();
    assert!(!String::from_utf8_lossy(&mouse.stdout).contains("eye distance "));
}

/// A full disk during `view --record` is reported at once in the session
/// log (and on the status line), the session goes on rendering without
/// the recording, the file keeps what was written before the error, and
/// the session ends with exit 1 naming it. The write error is real: the
/// viewer runs under a 4 KiB file size limit with SIGXFSZ ignored (EFBIG,
/// as a full disk gives ENOSPC).
#[test]
#[ignore = "slow tier: windowed recording sessions under Xvfb"]
fn a_write_error_during_view_record_is_reported_at_once_and_rendering_goes_on() {
    let x = Xvfb::start();
    let dir = tempfile::tempdir().expect("tempdir");
    let rec = dir.path().join("r.gzrec");
    let mut c = small_view(&x, dir.path());
    c.args([
        "--replay",
        "tests/data/mouse-120hz.gzrec",
        "--frames",
        "240",
        "--record",
    ])
    .arg(&rec);
    let mut limited = common::with_file_limit(&c, 4);
    let out = limited.output().expect("runs");
    let log = String::from_utf8_lossy(&out.stdout);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{log}\n{err}");
    assert!(
        err.contains("--record") && err.contains("File too large"),
        "{err}"
    );
    let lines: Vec<&str> = log.lines().collect();
    let stopped = lines
        .iter()
        .position(|l| l.starts_with("RECORDING STOPPED") && l.contains("File too large"))
        .unwrap_or_else(|| panic!("no RECORDING STOPPED line:\n{log}"));
    let frames_after = lines[stopped..]
        .iter()
        .filter(|l| l.starts_with("frame "))
        .count();
    assert!(frames_after > 0, "no frame after the error:\n{log}");
    let r = tracker_hal::Recording::read(&rec).expect("what was written reads back");
    assert!(r.device_chunks().count() > 10, "{:?}", r.summary());
    assert!(!r.summary().closed);
}

/// The X server going away mid-session (killed, a remote session dropped)
/// ends the process from inside Xlib, where no destructor runs: gazecast's
/// I/O error handler closes the recording first, so it ends with its end
/// chunk like any other session, and says so. Before, the `.gzrec` was
/// left without one ("not closed: the recorder was interrupted").
#[test]
fn a_lost_x_server_still_closes_the_recording() {
    let x = Xvfb::start();
    let dir = tempfile::tempdir().expect("tempdir");
    let rec = dir.path().join("r.gzrec");
    let mut c = small_view(&x, dir.path());
    c.args([
        "--replay",
        "tests/data/mouse-120hz.gzrec",
        "--frames",
        "1000000",
        "--record",
    ])
    .arg(&rec)
    .stdout(std::process::Stdio::null())
    .stderr(std::process::Stdio::piped());
    let mut child = c.spawn().expect("view starts");
    // Running: the recording holds some samples.
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(60);
    while std::fs::metadata(&rec).map_or(0, |m| m.len()) < 2000 {
        assert!(
            std::time::Instant::now() < deadline,
            "view did not start recording"
        );
        assert!(
            child.try_wait().expect("wait").is_none(),
            "view ended early"
        );
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    drop(x);
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(20);
    while child.try_wait().expect("wait").is_none() {
        if std::time::Instant::now() > deadline {
            let _ = child.kill();
            panic!("view went on for 20 s without its X server");
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    let out = child.wait_with_output().expect("output");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(
        err.contains("connection to the X server was lost; closed 1 open recording"),
        "{err}"
    );
    let r = tracker_hal::Recording::read(&rec).expect("reads");
    assert!(r.summary().closed, "no end chunk: {:?}", r.warnings());
    assert!(r.warnings().is_empty(), "{:?}", r.warnings());
    assert!(r.device_chunks().count() > 10);
}

/// The session summary counts what the frames moved: on the GPU backend
/// the renderer's traffic per frame (p50 and max over every frame, counted
/// at the wgpu calls), on either backend the bytes the window's
/// presentation handed to `write_texture` (4 B a pixel, every frame: the
/// CPU frame copied into the surface); the window names its present mode.
#[test]
fn the_summary_counts_the_gpu_traffic_and_the_presentation_upload() {
    let x = Xvfb::start();
    let dir = tempfile::tempdir().expect("tempdir");
    let display = tiny_display(dir.path());
    let run = |backend: &str| {
        let mut c = windowed(&x);
        c.args([
            "view",
            "--scene",
            "config/scenes/search-task.ron",
            "--backend",
            backend,
        ])
        .arg("--display")
        .arg(&display)
        .args(["--replay", "tests/data/mouse-120hz.gzrec", "--frames", "3"]);
        String::from_utf8_lossy(&c.succeed().stdout).to_string()
    };
    let presented = format!(
        "presenting: {} B handed to write_texture in 3 frames",
        3 * 4 * 160 * 128
    );
    let cpu = run("cpu");
    assert!(!cpu.contains("GPU traffic"), "{cpu}");
    assert!(cpu.contains(&presented), "{cpu}");
    // The window says how it presents: auto takes Mailbox where offered,
    // FIFO otherwise, and names what the adapter offers.
    let mode = cpu
        .lines()
        .find(|l| l.starts_with("present mode "))
        .unwrap_or_else(|| panic!("no present mode line: {cpu}"));
    assert!(
        mode.contains("(auto") && mode.contains("the adapter offers"),
        "{mode}"
    );
    assert_eq!(
        mode.starts_with("present mode Mailbox"),
        mode.contains("Mailbox,") || mode.ends_with("Mailbox)"),
        "{mode}"
    );
    let gpu = run("gpu");
    // The GPU frames are drawn into the window on the renderer's device:
    // nothing handed to write_texture.
    assert!(
        gpu.contains("presenting: 3 frames drawn from the GPU's buffers")
            && gpu.contains("0 B handed to write_texture in 0 frames"),
        "{gpu}"
    );
    let line = gpu
        .lines()
        .find(|l| l.starts_with("GPU traffic per frame over 3 frames"))
        .unwrap_or_else(|| panic!("no traffic line: {gpu}"));
    // No frame reads its pixels back: a foveated frame reads its 16 B of
    // ray counters, nothing else.
    let max_read = line
        .split("read back p50 ")
        .nth(1)
        .and_then(|r| r.split(" B").next())
        .and_then(|r| r.split(" max ").nth(1))
        .and_then(|m| m.parse::<u64>().ok())
        .unwrap_or_else(|| panic!("no read-back figure: {line}"));
    assert!(max_read <= 16, "{line}");
}

/// On the GPU backend the live view draws each frame into the window from
/// the GPU's own buffers, and the window shows exactly the frame: the
/// screen's pixels (read from Xvfb's screen file while the viewer runs,
/// the gaze still) equal the frame read back for the screenshot, below
/// the HUD's line. The summary says how many frames were drawn that way
/// and that none was copied. The same frame with the layers view on (a
/// CPU reader) is read back and copied instead.
#[test]
fn gpu_frames_are_drawn_into_the_window_exactly_without_a_read_back() {
    use std::io::BufRead;
    use std::time::{Duration, Instant};
    let x = Xvfb::start_with_screen_file();
    let dir = tempfile::tempdir().expect("tempdir");
    let display = tiny_display(dir.path());
    let shot = dir.path().join("shot.png");
    let mut child = windowed(&x)
        .args([
            "view",
            "--scene",
            "config/scenes/search-task.ron",
            "--backend",
            "gpu",
            "--tracker",
            "config/trackers/mouse.ron",
        ])
        .arg("--display")
        .arg(&display)
        .arg("--screenshot")
        .arg(&shot)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("viewer starts");
    let err_reader = drain(child.stderr.take());
    let mut lines = std::io::BufReader::new(child.stdout.take().expect("stdout")).lines();
    let mut log = String::new();
    let deadline = Instant::now() + Duration::from_secs(120);
    // Twenty frames in: the window is mapped and showing frames.
    while Instant::now() < deadline {
        let Some(Ok(l)) = lines.next() else { break };
        log.push_str(&l);
        log.push('\n');
        if l.starts_with("frame 20 ") {
            break;
        }
    }
    assert!(log.contains("frame 20 "), "{log}");
    let shown = x.screen((160, 128));
    let ok = std::process::Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .expect("kill runs");
    assert!(ok.success());
    for l in lines.map_while(Result::ok) {
        log.push_str(&l);
        log.push('\n');
    }
    let status = child.wait().expect("exits");
    let err = err_reader.join().expect("stderr");
    assert!(status.success(), "{log}\n{err}");
    assert!(log.contains("presenting on the renderer's GPU"), "{log}");
    assert!(
        log.contains("frames drawn from the GPU's buffers")
            && log.contains("0 B handed to write_texture in 0 frames"),
        "{log}"
    );
    let file = std::fs::File::open(&shot).expect("screenshot");
    let mut decoder = png::Decoder::new(std::io::BufReader::new(file));
    // A picture of few colours is saved with a palette.
    decoder.set_transformations(png::Transformations::EXPAND);
    let mut reader = decoder.read_info().expect("png");
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).expect("frame");
    assert_eq!((info.width, info.height), (160, 128));
    assert_eq!(info.color_type, png::ColorType::Rgb);
    let frame = &buf[..3 * 160 * 128];
    // The HUD's one line covers rows 2..=20 (an opaque box in the window,
    // a blended one in the screenshot, and its figures change).
    let below = 3 * 160 * 24;
    let differ = shown[below..]
        .chunks_exact(3)
        .zip(frame[below..].chunks_exact(3))
        .filter(|(a, b)| a != b)
        .count();
    assert_eq!(differ, 0, "of {} pixels below the HUD", 160 * 104);
    // Not a blank window: the frame has the scene's objects in it.
    let colours: std::collections::HashSet<&[u8]> = shown[below..].chunks_exact(3).collect();
    assert!(colours.len() > 50, "{} colours", colours.len());
}
