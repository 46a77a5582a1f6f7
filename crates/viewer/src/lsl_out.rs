//! Lab Streaming Layer outlets (`--lsl` on `view`, `demo` and `experiment
//! run`): the gaze, one marker per presented frame and, in an experiment,
//! the session's markers (`markers.tsv`'s rows), for LabRecorder or any
//! other LSL consumer. All `labstream` use is here (cargo feature `lsl`,
//! on by default); built without it, [`Outlets::open`] says so.
//!
//! Streams (`<cmd>`: `view`, `demo`, `experiment`; the source ids are
//! stable across runs and hosts: the command, plus the design and the
//! participant for an experiment, so a consumer re-attaches after a
//! restart):
//!
//! * `gazecast-<cmd>-gaze`, type `Gaze`, float32, irregular rate, channels
//!   (label, unit, type): `gaze_x` / `gaze_y` (pixels, `ScreenX` /
//!   `ScreenY`): the gaze on the screen, pixels from the top left;
//!   `left_gaze_x`, `left_gaze_y`, `right_gaze_x`, `right_gaze_y` (pixels,
//!   `ScreenX` / `ScreenY`): each eye's point when the tracker measured
//!   both (NaN otherwise; always NaN in an experiment, whose gaze is the
//!   runner's own calibration of the combined raw gaze). NaN marks an
//!   invalid sample (blink, off the screen). Every sample the tracker
//!   delivers is pushed, stamped with its capture time (`mapped_us`).
//! * `gazecast-<cmd>-frames`, type `Markers`, one string channel,
//!   irregular: one marker per presented frame, stamped when its present
//!   call returned (frames.tsv's `host_us` in an experiment).
//! * `gazecast-experiment-events` (experiment only), type `Markers`: each
//!   markers.tsv row as `<event>; trial=<n or ->; <detail>`, stamped with
//!   its `host_us`.
//!
//! Known gap: labstream's description builder writes only a label, unit
//! and type per channel: no further `<desc>` nodes (XDF's per-channel
//! `eye`, an `acquisition` block) are published.
//!
//! Clocks: LSL stamps with `labstream::clock()`, which on Linux reads
//! `CLOCK_MONOTONIC` (as liblsl's `steady_clock`); gazecast's
//! `tracker_hal::clock::monotonic_us` counts from a `std::time::Instant`,
//! also `CLOCK_MONOTONIC` on Linux. So they differ by a constant,
//! [`offset_s`], measured once per process by reading both back to back
//! (the closest of several brackets); `lsl seconds = monotonic_us / 1e6 +
//! offset_s`. A replayed recording's times are on the recording's clock:
//! they are moved onto this process's by one constant, the first sample's
//! delivery minus its recorded arrival, so the recorded intervals stay
//! exact.

use std::sync::OnceLock;

/// How far apart the two clocks are: `(offset_s, uncertainty_s)`, with
/// `lsl seconds = monotonic_us / 1e6 + offset_s`.
pub fn offset_s() -> (f64, f64) {
    static OFFSET: OnceLock<(f64, f64)> = OnceLock::new();
    *OFFSET.get_or_init(measure_offset)
}

/// The best of 20 brackets `lsl clock, monotonic_us, lsl clock`.
pub fn measure_offset() -> (f64, f64) {
    let mut best = (0.0, f64::INFINITY);
    for _ in 0..20 {
        let a = lsl_clock();
        let m = tracker_hal::clock::monotonic_us();
        let b = lsl_clock();
        // monotonic_us truncates to whole µs: up to 1 µs more.
        let err = (b - a) / 2.0 + 1e-6;
        if err < best.1 {
            best = ((a + b) / 2.0 - m as f64 / 1e6, err);
        }
    }
    best
}

/// A time on gazecast's monotonic clock (µs) in LSL seconds.
pub fn lsl_seconds(us: u64) -> f64 {
    us as f64 / 1e6 + offset_s().0
}

/// Whether this gazecast was built with LSL.
pub const BUILT_IN: bool = cfg!(feature = "lsl");

/// What `--lsl` asks of a command.
#[derive(Debug, Clone, PartialEq)]
pub struct LslOptions {
    /// `view`, `demo`, `experiment`.
    pub command: String,
    /// Appended to each stream's source id (an experiment's design and
    /// participant); empty for none.
    pub source_suffix: String,
    /// Wait up to this long (s) for a consumer on every stream before the
    /// session starts (0: do not wait).
    pub wait_s: f64,
    /// Publish the experiment's event markers.
    pub events: bool,
}

impl LslOptions {
    /// The stream names (= the start of their source ids).
    pub fn name(&self, kind: &str) -> String {
        format!("gazecast-{}-{kind}", self.command)
    }
    /// A stream's source id: its name, then the source suffix when there is one.
    pub fn source_id(&self, kind: &str) -> String {
        if self.source_suffix.is_empty() {
            self.name(kind)
        } else {
            format!("{}-{}", self.name(kind), self.source_suffix)
        }
    }
}

/// A source id part from free text: letters, digits, `-`, `_`, `.`.
pub fn id_part(s: &str) -> String {
    s.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.') {
                c
            } else {
                '_'
            }
        })
        .collect()
}

/// One gaze sample: the combined point and each eye's, screen px.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GazeValues {
    /// The combined gaze, screen px; `None` when invalid.
    pub gaze_px: Option<[f64; 2]>,
    /// Left and right eyes' points, screen px, when the sample has both.
    pub eyes_px: Option<[[f64; 2]; 2]>,
}

impl GazeValues {
    /// The channel values, NaN where invalid.
    pub fn channels(&self) -> [f32; 6] {
        let p = |v: Option<[f64; 2]>| match v.filter(|g| g[0].is_finite() && g[1].is_finite()) {
            Some(g) => [g[0] as f32, g[1] as f32],
            None => [f32::NAN; 2],
        };
        let [g, l, r] = [
            p(self.gaze_px),
            p(self.eyes_px.map(|e| e[0])),
            p(self.eyes_px.map(|e| e[1])),
        ];
        [g[0], g[1], l[0], l[1], r[0], r[1]]
    }
}

/// The gaze stream's channels: (label, unit, type).
pub const GAZE_CHANNELS: [(&str, &str, &str); 6] = [
    ("gaze_x", "pixels", "ScreenX"),
    ("gaze_y", "pixels", "ScreenY"),
    ("left_gaze_x", "pixels", "ScreenX"),
    ("left_gaze_y", "pixels", "ScreenY"),
    ("right_gaze_x", "pixels", "ScreenX"),
    ("right_gaze_y", "pixels", "ScreenY"),
];

/// The open outlets of a session.
pub struct Outlets {
    imp: imp::Outlets,
    /// The first push failure (the session goes on; reported at the end).
    pub error: Option<String>,
    pushed: [u64; 3],
}

impl Outlets {
    /// Opens the streams (and waits for consumers when asked); the log
    /// lines to write.
    pub fn open(opts: &LslOptions) -> Result<(Self, Vec<String>), String> {
        let (imp, mut lines) = imp::Outlets::open(opts)?;
        let (off, err) = offset_s();
        lines.push(format!(
            "lsl: clock: LSL seconds = monotonic_us / 1e6 + {off:.6} (both CLOCK_MONOTONIC; offset measured to ±{:.1} µs)",
            err * 1e6
        ));
        Ok((
            Self {
                imp,
                error: None,
                pushed: [0; 3],
            },
            lines,
        ))
    }

    fn keep(&mut self, r: Result<(), String>) {
        if let Err(e) = r {
            self.error.get_or_insert(format!("lsl: {e}"));
        }
    }

    /// One gaze sample, captured at `us` (this process's clock).
    pub fn gaze(&mut self, us: u64, g: GazeValues) {
        let r = self.imp.gaze(&g.channels(), lsl_seconds(us));
        self.pushed[0] += 1;
        self.keep(r);
    }

    /// One frame marker, presented at `us`.
    pub fn frame(&mut self, us: u64, text: &str) {
        let r = self.imp.frame(text, lsl_seconds(us));
        self.pushed[1] += 1;
        self.keep(r);
    }

    /// One event marker at `us` (no-op without the events stream).
    pub fn event(&mut self, us: u64, text: &str) {
        let r = self.imp.event(text, lsl_seconds(us));
        self.pushed[2] += 1;
        self.keep(r);
    }

    /// At the session's end: when a consumer is connected, keeps the
    /// streams up a moment longer (0.5 s) so it reads the last samples
    /// before the outlets go.
    pub fn linger(&self) {
        if self.imp.has_consumers() {
            std::thread::sleep(std::time::Duration::from_millis(500));
        }
    }

    /// The session log's closing line.
    pub fn summary(&self) -> String {
        let [g, f, e] = self.pushed;
        match &self.error {
            None => format!("lsl: pushed {g} gaze samples, {f} frame markers, {e} event markers"),
            Some(err) => {
                format!("lsl: pushed {g} gaze samples, {f} frame markers, {e} event markers; {err}")
            }
        }
    }
}

/// The event marker text of a markers.tsv row.
pub fn event_text(event: &str, trial: Option<usize>, detail: &str) -> String {
    let t = trial.map_or("-".to_string(), |t| t.to_string());
    format!("{event}; trial={t}; {detail}")
}

#[cfg(feature = "lsl")]
fn lsl_clock() -> f64 {
    labstream::clock()
}

#[cfg(not(feature = "lsl"))]
fn lsl_clock() -> f64 {
    // Without labstream: the same clock read directly is not available
    // here; monotonic_us itself (offset 0).
    tracker_hal::clock::monotonic_us() as f64 / 1e6
}

#[cfg(feature = "lsl")]
mod imp {
    use super::{LslOptions, GAZE_CHANNELS};
    use labstream::{Channel, Format, Outlet, StreamInfo};
    use std::time::Duration;

    pub struct Outlets {
        gaze: Outlet,
        frames: Outlet,
        events: Option<Outlet>,
    }

    fn markers(opts: &LslOptions, kind: &str) -> Result<Outlet, String> {
        let info = StreamInfo::builder(&opts.name(kind), "Markers", Format::String)
            .irregular()
            .source_id(&opts.source_id(kind))
            .channel_count(1)
            .build()
            .map_err(|e| format!("lsl: the {kind} stream: {e}"))?;
        Outlet::new(info).map_err(|e| format!("lsl: the {kind} stream: {e}"))
    }

    impl Outlets {
        pub fn open(opts: &LslOptions) -> Result<(Self, Vec<String>), String> {
            let info = StreamInfo::builder(&opts.name("gaze"), "Gaze", Format::Float32)
                .irregular()
                .source_id(&opts.source_id("gaze"))
                .channels(
                    GAZE_CHANNELS
                        .iter()
                        .map(|(l, u, k)| Channel::new(l).unit(u).kind(k)),
                )
                .build()
                .map_err(|e| format!("lsl: the gaze stream: {e}"))?;
            let gaze = Outlet::new(info).map_err(|e| format!("lsl: the gaze stream: {e}"))?;
            let frames = markers(opts, "frames")?;
            let events = if opts.events {
                Some(markers(opts, "events")?)
            } else {
                None
            };
            let mut lines = Vec::new();
            let mut names = vec![opts.source_id("gaze"), opts.source_id("frames")];
            if opts.events {
                names.push(opts.source_id("events"));
            }
            lines.push(format!("lsl: publishing {}", names.join(", ")));
            if opts.wait_s > 0.0 {
                let until = std::time::Instant::now() + Duration::from_secs_f64(opts.wait_s);
                let left = || until.saturating_duration_since(std::time::Instant::now());
                let mut all = gaze.wait_for_consumers(left());
                all &= frames.wait_for_consumers(left());
                if let Some(e) = &events {
                    all &= e.wait_for_consumers(left());
                }
                lines.push(if all {
                    "lsl: every stream has a consumer".to_string()
                } else {
                    format!(
                        "lsl: not every stream had a consumer within {} s; going on",
                        opts.wait_s
                    )
                });
            }
            Ok((
                Self {
                    gaze,
                    frames,
                    events,
                },
                lines,
            ))
        }

        pub fn has_consumers(&self) -> bool {
            self.gaze.has_consumers()
                || self.frames.has_consumers()
                || self.events.as_ref().is_some_and(Outlet::has_consumers)
        }

        pub fn gaze(&self, v: &[f32], t: f64) -> Result<(), String> {
            self.gaze.push_at(v, t).map_err(|e| e.to_string())
        }

        pub fn frame(&self, text: &str, t: f64) -> Result<(), String> {
            self.frames.push_text_at(text, t).map_err(|e| e.to_string())
        }

        pub fn event(&self, text: &str, t: f64) -> Result<(), String> {
            match &self.events {
                Some(o) => o.push_text_at(text, t).map_err(|e| e.to_string()),
                None => Ok(()),
            }
        }
    }
}

#[cfg(not(feature = "lsl"))]
mod imp {
    use super::LslOptions;

    pub struct Outlets;

    impl Outlets {
        pub fn open(_: &LslOptions) -> Result<(Self, Vec<String>), String> {
            Err("--lsl: this gazecast was built without LSL (cargo feature `lsl` of gazecast-viewer)".into())
        }
        pub fn has_consumers(&self) -> bool {
            false
        }
        pub fn gaze(&self, _: &[f32], _: f64) -> Result<(), String> {
            Ok(())
        }
        pub fn frame(&self, _: &str, _: f64) -> Result<(), String> {
            Ok(())
        }
        pub fn event(&self, _: &str, _: f64) -> Result<(), String> {
            Ok(())
        }
    }
}

/// Moves a replay's recorded times onto this process's clock: a constant
/// fixed by the first sample (its delivery minus its recorded arrival).
/// Live sources (already on this clock) pass unchanged.
#[derive(Debug, Clone, Copy, Default)]
pub struct ReplayShift {
    replay: bool,
    shift_us: Option<i64>,
}

impl ReplayShift {
    /// A shift for a replay (`replay`) or a live source (times pass unchanged).
    pub fn new(replay: bool) -> Self {
        Self {
            replay,
            shift_us: None,
        }
    }

    /// `mapped_us` on this process's clock.
    pub fn host_us(&mut self, received_us: u64, arrival_us: u64, mapped_us: u64) -> u64 {
        if !self.replay {
            return mapped_us;
        }
        let s = *self
            .shift_us
            .get_or_insert(received_us as i64 - arrival_us as i64);
        (mapped_us as i64 + s).max(0) as u64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Both clocks are CLOCK_MONOTONIC: the offset is the same measured
    /// now and 200 ms later (a different rate or a wall clock would move
    /// it), and a monotonic_us reading maps onto the LSL clock's reading.
    #[test]
    fn the_two_clocks_differ_by_a_constant() {
        let (a, ea) = measure_offset();
        std::thread::sleep(std::time::Duration::from_millis(200));
        let (b, eb) = measure_offset();
        assert!(ea < 1e-3 && eb < 1e-3, "{ea} {eb}");
        assert!((a - b).abs() < 50e-6 + ea + eb, "{a} {b}");
        let mapped = lsl_seconds(tracker_hal::clock::monotonic_us());
        let direct = lsl_clock();
        assert!((direct - mapped).abs() < 1e-3, "{direct} {mapped}");
    }

    #[test]
    fn gaze_channels_are_nan_where_invalid() {
        let v = GazeValues {
            gaze_px: Some([1.5, f64::NAN]),
            eyes_px: Some([[1.0, 2.0], [3.0, 4.0]]),
        }
        .channels();
        assert!(v[0].is_nan() && v[1].is_nan());
        assert_eq!(&v[2..], &[1.0, 2.0, 3.0, 4.0]);
        let v = GazeValues {
            gaze_px: Some([10.0, 20.0]),
            eyes_px: None,
        }
        .channels();
        assert_eq!(&v[..2], &[10.0, 20.0]);
        assert!(v[2..].iter().all(|x| x.is_nan()));
    }

    #[test]
    fn a_replay_keeps_its_recorded_intervals() {
        let mut s = ReplayShift::new(true);
        assert_eq!(s.host_us(5_000, 1_000, 900), 4_900);
        assert_eq!(s.host_us(9_999, 2_000, 1_900), 5_900);
        let mut live = ReplayShift::new(false);
        assert_eq!(live.host_us(5_000, 1_000, 900), 900);
    }

    #[test]
    fn names_and_ids() {
        let o = LslOptions {
            command: "experiment".into(),
            source_suffix: id_part("murphy 2007/P01"),
            wait_s: 0.0,
            events: true,
        };
        assert_eq!(o.name("gaze"), "gazecast-experiment-gaze");
        assert_eq!(
            o.source_id("events"),
            "gazecast-experiment-events-murphy_2007_P01"
        );
        assert_eq!(event_text("key", None, "space 1"), "key; trial=-; space 1");
    }
}
