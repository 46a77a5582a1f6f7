//! How each gaze source is (re)opened for the supervisor: a replay (once,
//! at its original pacing), the mouse emulator on the window's cursor (or
//! the attention model's point), an ISCAN on its serial port, an LSL
//! inlet, a HID tracker; every byte tapped into the recording if any.

use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Mutex};

use crossbeam_channel::Receiver;
use tracker_hal::mouse::{spawn_device, CursorEvent, MouseConfig, MouseTiming};
use tracker_hal::supervisor::{Opener, Source, MAX_WAIT, READ_TIMEOUT};
use tracker_hal::{
    Driver, MonotonicClock, Pacing, Recording, ReplayTransport, StreamDriver, Tap, TrackerConfig,
};

/// Opens the mouse emulator on the cursor events (once: it keeps running).
fn mouse_opener(
    c: MouseConfig,
    cursor_rx: Receiver<CursorEvent>,
    tap: Option<Tap>,
    timing: Arc<Mutex<Option<MouseTiming>>>,
) -> Opener {
    let mut cursor = Some(cursor_rx);
    Box::new(move || {
        let rx = cursor.take().ok_or("the mouse device has stopped")?;
        let link = spawn_device(c.clone(), rx).map_err(|e| e.to_string())?;
        if let Ok(mut t) = timing.lock() {
            *t = Some(link.timing());
        }
        let d = StreamDriver::new(
            link,
            tracker_hal::mouse::MouseDecoder::new(),
            Box::new(MonotonicClock),
        )
        .with_max_wait(MAX_WAIT);
        Ok(match &tap {
            Some(t) => Box::new(d.with_tap(t.clone())) as Source,
            None => Box::new(d) as Source,
        })
    })
}

/// How to (re)open the source.
pub(super) fn opener(
    tracker: TrackerConfig,
    replay: Option<Recording>,
    tap: Option<Tap>,
    cursor_rx: Receiver<CursorEvent>,
    stop: Arc<AtomicBool>,
    mouse_timing: Arc<Mutex<Option<MouseTiming>>>,
) -> Opener {
    fn tapped<T: std::io::Read + std::io::Write, D: tracker_hal::Decoder>(
        d: StreamDriver<T, D>,
        tap: &Option<Tap>,
    ) -> StreamDriver<T, D> {
        let d = d.with_max_wait(MAX_WAIT);
        match tap {
            Some(t) => d.with_tap(t.clone()),
            None => d,
        }
    }
    if let Some(rec) = replay {
        let mut once = Some(rec);
        return Box::new(move || {
            let rec = once.take().ok_or("the recording has been played")?;
            let t = ReplayTransport::from_recording(&rec, Pacing::RealTime)
                .with_read_timeout(READ_TIMEOUT)
                .with_stop(stop.clone());
            let clock = t.clock();
            Ok(Box::new(tapped(
                StreamDriver::new(t, tracker.decoder(), Box::new(clock)),
                &tap,
            )) as Source)
        });
    }
    match tracker.driver.clone() {
        Driver::Mouse(c) => mouse_opener(c, cursor_rx, tap, mouse_timing),
        // The viewer feeds the attention model's point in as the cursor.
        Driver::Attention(a) => mouse_opener(a.stream(), cursor_rx, tap, mouse_timing),
        Driver::Iscan(c) => Box::new(move || {
            let name = c
                .port
                .clone()
                .ok_or("the ISCAN tracker file has no `port`")?;
            let port = tracker_hal::serial::open(&name, c.baud, READ_TIMEOUT)
                .map_err(|e| e.to_string())?;
            Ok(Box::new(tapped(
                StreamDriver::new(port, tracker.decoder(), Box::new(MonotonicClock)),
                &tap,
            )) as Source)
        }),
        // Each open resolves the stream again: after a lost stream (its
        // outlet ended or went silent for `silence_ms`) the tracker thread
        // reopens, finding a restarted outlet by the same query.
        #[cfg(feature = "lsl")]
        Driver::Lsl(c) => Box::new(move || {
            let t = tracker_hal::lsl::inlet::LslTransport::open(&c).map_err(|e| e.to_string())?;
            Ok(Box::new(tapped(
                StreamDriver::new(t, tracker.decoder(), Box::new(MonotonicClock)),
                &tap,
            )) as Source)
        }),
        #[cfg(not(feature = "lsl"))]
        Driver::Lsl(_) => Box::new(|| {
            Err("this gazecast was built without the `lsl` feature: it replays LSL recordings but cannot read a live LSL stream".into())
        }),
        Driver::TobiiHid(c) => Box::new(move || {
            let t = tracker_hal::hid::driver::hidapi_transport::HidApiTransport::open(&c)
                .map_err(|e| e.to_string())?;
            let d =
                tracker_hal::hid::driver::HidDriver::new(t, c.clone(), Box::new(MonotonicClock));
            Ok(Box::new(match &tap {
                Some(t) => d.with_tap(t.clone()),
                None => d,
            }) as Source)
        }),
    }
}
