//! [`GazeSetup`]: the gaze source the command line names (a tracker file
//! or a recording to replay), and how it is started as a [`GazeFeed`].

use std::path::Path;
use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Mutex};

use crossbeam_channel::Sender;
use tracker_hal::calibration::Calibration;
use tracker_hal::supervisor::{self, Faults, Map, Supervisor, TrackerMsg};
use tracker_hal::virtual_mouse::VirtualMouse;
use tracker_hal::{DeviceClock, Driver, Recorder, Recording, RecordingHeader, TrackerConfig};

use super::open::opener;
use super::{recordings, GazeFeed};
use crate::config;

/// A gaze source chosen from the command line, not yet started.
pub struct GazeSetup {
    /// The tracker configuration (from the recording's header in a replay).
    pub tracker: TrackerConfig,
    replay: Option<Recording>,
    /// For messages: the driver and file.
    pub name: String,
    /// The screen (px), to mark gaze far off it invalid.
    screen_px: Option<[f64; 2]>,
}

impl GazeSetup {
    /// `--replay FILE` (the tracker from its header) or `--tracker FILE.ron`.
    pub fn resolve(tracker: Option<&Path>, replay: Option<&Path>) -> Result<Self, String> {
        if let Some(path) = replay {
            let rec = Recording::read(path).map_err(|e| e.to_string())?;
            for w in rec.warnings() {
                eprintln!("warning: {}: {w}", path.display());
            }
            return Ok(Self {
                tracker: rec.header.tracker.clone(),
                replay: Some(rec),
                name: format!("replay of {}", path.display()),
                screen_px: None,
            });
        }
        let Some(path) = tracker else {
            return Err(
                "give --tracker FILE.ron (config/trackers/mouse.ron for the mouse) or --replay FILE"
                    .into(),
            );
        };
        let tracker: TrackerConfig = config::load_tracker(path).map_err(|e| e.to_string())?;
        let name = format!("{} ({})", tracker.driver_name(), path.display());
        Ok(Self {
            tracker,
            replay: None,
            name,
            screen_px: None,
        })
    }

    /// The screen's size (px): mapped gaze that is not finite or more than
    /// one screen diagonal outside it is then marked invalid and counted
    /// (without it only non-finite gaze is).
    pub fn with_screen(mut self, size_px: [f64; 2]) -> Self {
        self.screen_px = Some(size_px);
        self
    }

    /// How the tracker's device times are obtained.
    pub fn device_clock(&self) -> DeviceClock {
        self.tracker.decoder().device_clock()
    }

    /// Whether the gaze comes from a replayed recording.
    pub fn is_replay(&self) -> bool {
        self.replay.is_some()
    }

    /// Whether the tracker is the mouse.
    pub fn is_mouse(&self) -> bool {
        matches!(self.tracker.driver, Driver::Mouse(_))
    }

    /// The recording of this source at `record` (path, display name),
    /// started.
    fn recorder(&self, record: Option<(&Path, &str)>) -> Result<Option<Recorder>, String> {
        let Some((path, display)) = record else {
            return Ok(None);
        };
        let header = RecordingHeader {
            tracker: self.tracker.clone(),
            display: Some(display.to_string()),
            note: format!("recorded by gazecast from {}", self.name),
        };
        let recorder =
            Recorder::start(path, &header, 1 << 16).map_err(|e| format!("--record: {e}"))?;
        recordings::remember(&recorder.tap());
        Ok(Some(recorder))
    }

    /// The mouse tracker on a virtual clock, for a headless simulation: no
    /// thread; the caller ticks the [`VirtualMouse`] (whose record bytes go
    /// to the recording at `record`, as a live device's would) and sends
    /// its samples to the feed's channel through the returned sender.
    pub fn virtual_mouse(
        self,
        start_us: u64,
        record: Option<(&Path, &str)>,
    ) -> Result<(GazeFeed, VirtualMouse, Sender<TrackerMsg>), String> {
        let Driver::Mouse(config) = &self.tracker.driver else {
            return Err(format!(
                "{}: a headless simulation drives the mouse tracker (config/trackers/mouse.ron)",
                self.name
            ));
        };
        let recorder = self.recorder(record)?;
        let device = VirtualMouse::new(
            config.clone(),
            start_us,
            recorder.as_ref().map(Recorder::tap),
        );
        let (tx, rx) = crossbeam_channel::unbounded();
        let feed = GazeFeed {
            rx,
            cursor_tx: None,
            stop: Arc::new(AtomicBool::new(false)),
            thread: None,
            recorder,
            faults: Arc::new(Mutex::new(Faults::default())),
            stopped: None,
            mouse_timing: Arc::new(Mutex::new(None)),
            attention: None,
        };
        Ok((feed, device, tx))
    }

    /// Starts the tracker thread. With `calibration`, raw gaze maps through
    /// it instead of the tracker file's mapping; with `record`, every byte
    /// from and to the device goes to that recording (its own writer
    /// thread), which [`GazeFeed::finish`] closes properly.
    pub fn spawn(
        self,
        calibration: Option<Calibration>,
        record: Option<(&Path, &str)>,
    ) -> Result<GazeFeed, String> {
        let recorder = self.recorder(record)?;
        let tap = recorder.as_ref().map(Recorder::tap);
        let (cursor_tx, cursor_rx) = crossbeam_channel::unbounded();
        let (frame, mapping) = (self.tracker.frame(), self.tracker.mapping.clone());
        let map: Map = match calibration {
            Some(c) => Box::new(move |p| c.map(p)),
            None => Box::new(move |p| Some(mapping.to_screen(p, frame))),
        };
        let ends = self.replay.is_some();
        let attention = match &self.tracker.driver {
            Driver::Attention(a) if !ends => Some(a.clone()),
            _ => None,
        };
        let stop = Arc::new(AtomicBool::new(false));
        let binocular = self.tracker.measures_two_eyes();
        let mouse_timing = Arc::new(Mutex::new(None));
        let open = opener(
            self.tracker,
            self.replay,
            tap,
            cursor_rx,
            stop.clone(),
            mouse_timing.clone(),
        );
        let (tx, rx) = crossbeam_channel::unbounded();
        let faults = Arc::new(Mutex::new(Faults::default()));
        let supervisor = Supervisor {
            recording: recorder.as_ref().map(Recorder::tap),
            map,
            screen_px: self.screen_px,
            tx,
            stop: stop.clone(),
            ends,
            faults: faults.clone(),
            binocular,
        };
        let thread = std::thread::Builder::new()
            .name("tracker".into())
            .spawn(move || supervisor::run(open, supervisor))
            .map_err(|e| e.to_string())?;
        Ok(GazeFeed {
            rx,
            cursor_tx: Some(cursor_tx),
            stop,
            thread: Some(thread),
            recorder,
            faults,
            stopped: None,
            mouse_timing,
            attention,
        })
    }
}
