//! The HID host flow over a transport: read the report descriptor, get the
//! Capabilities, Configuration and Status features, set Control to start,
//! read Tracking Data input reports, set Control to 0 to stop.
//!
//! Every report read becomes a hid-log line decoded by [`HidLogDecoder`]
//! (and sent to the recorder's tap), so a live session and its replay go
//! through the same code.

use std::collections::VecDeque;

use super::log::{format_line, parse_line, Line};
use super::{HidConfig, HidLogDecoder, TrackerLayout};
use crate::clock::Clock;
use crate::error::{Error, ErrorKind, Result};
use crate::recording::Tap;
use crate::sample::{DecodeStats, GazeSample};
use crate::source::{Decoder, GazeSource};
use crate::timing::{ClockMapper, ClockState};

/// A HID device, as the driver needs it.
pub trait HidTransport: Send {
    /// The report descriptor.
    fn descriptor(&mut self) -> Result<Vec<u8>>;
    /// Reads feature report `report_id` (returned with the ID first).
    fn get_feature(&mut self, report_id: u8) -> Result<Vec<u8>>;
    /// Sends a feature report (ID first).
    fn set_feature(&mut self, report: &[u8]) -> Result<()>;
    /// Reads one input report (ID first) into `buf`, waiting at most
    /// `timeout_ms`. `Ok(0)`: nothing arrived; `Ok(None)`-like end of a
    /// replay is `Err` of kind `Disconnected` with an "end of log" message
    /// from [`HidLogTransport`].
    fn read(&mut self, buf: &mut [u8], timeout_ms: u32) -> Result<usize>;
}

/// The driver: a [`GazeSource`] over a [`HidTransport`].
pub struct HidDriver<T> {
    transport: T,
    config: HidConfig,
    decoder: HidLogDecoder,
    clock: Box<dyn Clock>,
    tap: Option<Tap>,
    pending: VecDeque<GazeSample>,
    connected: bool,
    ended: bool,
    mapper: ClockMapper,
}

impl<T: HidTransport> HidDriver<T> {
    /// A driver reading `transport` with `config`, stamping arrivals with `clock`.
    pub fn new(transport: T, config: HidConfig, clock: Box<dyn Clock>) -> Self {
        Self {
            transport,
            config,
            decoder: HidLogDecoder::new(),
            clock,
            tap: None,
            pending: VecDeque::new(),
            connected: false,
            ended: false,
            mapper: ClockMapper::new(),
        }
    }

    /// Also record every report (as hid-log text) to a recorder.
    pub fn with_tap(mut self, tap: Tap) -> Self {
        self.tap = Some(tap);
        self
    }

    /// The decoder (its layout, device info and counts).
    pub fn decoder(&self) -> &HidLogDecoder {
        &self.decoder
    }

    /// The transport, for tests and replays that drive it.
    pub fn transport_mut(&mut self) -> &mut T {
        &mut self.transport
    }

    fn feed(&mut self, line: &Line) {
        let text = format_line(line);
        let t = self.clock.now_us();
        if let Some(tap) = &self.tap {
            tap.device_to_host(t, text.as_bytes());
        }
        let before = self.pending.len();
        self.decoder.push(text.as_bytes(), t, &mut self.pending);
        let pending = self.pending.make_contiguous();
        self.mapper.map_read(&mut pending[before..]);
    }

    /// Reads the descriptor and the features (a fresh device, or after a
    /// reconnect).
    fn connect(&mut self) -> Result<()> {
        let d = self.transport.descriptor()?;
        TrackerLayout::from_descriptor(&d)
            .map_err(|e| Error::new(ErrorKind::Unsupported, format!("not an eye tracker: {e}")))?;
        self.feed(&Line::Descriptor(d));
        let ids = self
            .decoder
            .layout()
            .map(|l| l.feature_ids())
            .unwrap_or_default();
        for id in ids {
            match self.transport.get_feature(id) {
                Ok(r) => self.feed(&Line::Feature(r)),
                // A device may refuse a feature it does not support.
                Err(e) if e.kind == ErrorKind::Unsupported => {}
                Err(e) => return Err(e),
            }
        }
        self.connected = true;
        Ok(())
    }

    fn control(&mut self, mode: u32) -> Result<()> {
        let layout = self.decoder.layout();
        let Some((report, sent)) =
            layout.and_then(|l| Some((l.control_report(mode)?, l.mode_value(mode)?)))
        else {
            return Err(Error::new(
                ErrorKind::Unsupported,
                "the device's report descriptor declares no Device Mode Request \
                 (usage page 0x12, usage 0x0400) as a feature, neither in a Control \
                 collection (0x14) nor in an Eye Tracker collection whose logical \
                 collections are unnamed: it cannot be asked to stream",
            ));
        };
        self.transport.set_feature(&report)?;
        if let Some(tap) = &self.tap {
            // The mode actually sent (clamped to the declared range).
            let sent = u32::try_from(sent).unwrap_or(mode);
            tap.host_to_device(
                self.clock.now_us(),
                format_line(&Line::Control(sent)).as_bytes(),
            );
        }
        Ok(())
    }

    /// What the device reported about itself.
    pub fn info(&self) -> super::DeviceInfo {
        self.decoder.info()
    }
}

impl<T: HidTransport> GazeSource for HidDriver<T> {
    fn start(&mut self) -> Result<()> {
        if !self.connected {
            self.connect()?;
        }
        self.control(self.config.mode())
    }

    fn stop(&mut self) -> Result<()> {
        self.control(0)
    }

    fn next_sample(&mut self) -> Result<Option<GazeSample>> {
        let mut buf = [0u8; 4096];
        loop {
            if let Some(s) = self.pending.pop_front() {
                return Ok(Some(s));
            }
            if self.ended {
                return Ok(None);
            }
            match self.transport.read(&mut buf, self.config.timeout_ms) {
                Ok(0) => {
                    return Err(Error::new(
                        ErrorKind::TimedOut,
                        format!(
                            "no report within {} ms (the device sends none while it sees no eyes)",
                            self.config.timeout_ms
                        ),
                    ))
                }
                Ok(n) => {
                    let line = Line::Report {
                        host_time_us: self.clock.now_us(),
                        bytes: buf[..n].to_vec(),
                    };
                    self.feed(&line);
                }
                Err(e) if e.kind == ErrorKind::Disconnected && e.message.contains(END_OF_LOG) => {
                    self.ended = true;
                }
                Err(e) => {
                    if e.kind == ErrorKind::Disconnected {
                        self.connected = false;
                    }
                    return Err(e);
                }
            }
        }
    }

    fn stats(&self) -> DecodeStats {
        self.decoder.stats()
    }

    fn clock(&self) -> Option<ClockState> {
        (self.mapper.state().samples > 0).then(|| self.mapper.state())
    }
}

const END_OF_LOG: &str = "end of the hid-log";

/// A [`HidTransport`] that plays a hid-log back: the descriptor and feature
/// lines answer `descriptor` and `get_feature`, the input reports are read
/// in order (as fast as asked), `set_feature` calls are kept for checking.
#[derive(Debug, Clone, Default)]
pub struct HidLogTransport {
    descriptor: Option<Vec<u8>>,
    features: Vec<Vec<u8>>,
    reports: VecDeque<Vec<u8>>,
    /// Feature reports the host sent, in order.
    pub sent: Vec<Vec<u8>>,
}

impl HidLogTransport {
    /// Parses hid-log text; lines that do not parse are skipped (the decoder,
    /// not the transport, counts damage). Only the first connection is
    /// served: a later descriptor ends the replay as a disconnect would.
    pub fn new(text: &str) -> Self {
        let mut t = Self::default();
        for line in text.lines().filter_map(parse_line) {
            match line {
                Line::Descriptor(d) if t.descriptor.is_none() => t.descriptor = Some(d),
                Line::Descriptor(_) => break,
                Line::Feature(f) => t.features.push(f),
                Line::Report { bytes, .. } => t.reports.push_back(bytes),
                Line::Control(_) | Line::Comment => {}
            }
        }
        t
    }
}

impl HidTransport for HidLogTransport {
    fn descriptor(&mut self) -> Result<Vec<u8>> {
        self.descriptor
            .clone()
            .ok_or_else(|| Error::new(ErrorKind::InvalidData, "the hid-log has no descriptor line"))
    }

    fn get_feature(&mut self, report_id: u8) -> Result<Vec<u8>> {
        self.features
            .iter()
            .find(|f| f.first() == Some(&report_id))
            .cloned()
            .ok_or_else(|| {
                Error::new(
                    ErrorKind::Unsupported,
                    format!("no feature report {report_id:#04x} in the log"),
                )
            })
    }

    fn set_feature(&mut self, report: &[u8]) -> Result<()> {
        self.sent.push(report.to_vec());
        Ok(())
    }

    fn read(&mut self, buf: &mut [u8], _timeout_ms: u32) -> Result<usize> {
        let Some(r) = self.reports.pop_front() else {
            return Err(Error::new(ErrorKind::Disconnected, END_OF_LOG));
        };
        let n = r.len().min(buf.len());
        buf[..n].copy_from_slice(&r[..n]);
        Ok(n)
    }
}

/// The `hidapi` transport (pure Linux backend: no system hidapi library).
/// Only with the `hid-usb` feature (on by default).
#[cfg(feature = "hid-usb")]
pub mod hidapi_transport {
    use super::*;

    /// An open HID device.
    pub struct HidApiTransport {
        device: hidapi::HidDevice,
    }

    fn err(context: &str, e: hidapi::HidError) -> Error {
        Error::new(ErrorKind::Disconnected, format!("{context}: {e}"))
    }

    impl HidApiTransport {
        /// Opens the first HID interface with an Eye Tracker collection
        /// (usage page 0x12, usage 1), optionally of the given vendor/product.
        pub fn open(config: &HidConfig) -> Result<Self> {
            let api = hidapi::HidApi::new().map_err(|e| err("hidapi", e))?;
            let found = api.device_list().find(|d| {
                d.usage_page() == super::super::PAGE
                    && config.vendor_id.is_none_or(|v| v == d.vendor_id())
                    && config.product_id.is_none_or(|p| p == d.product_id())
            });
            let Some(info) = found else {
                return Err(Error::new(
                    ErrorKind::Disconnected,
                    "no HID device with an Eye Tracker collection (usage page 0x12) is connected",
                ));
            };
            let device = info
                .open_device(&api)
                .map_err(|e| err("opening the tracker", e))?;
            Ok(Self { device })
        }
    }

    impl HidTransport for HidApiTransport {
        fn descriptor(&mut self) -> Result<Vec<u8>> {
            let mut buf = vec![0u8; hidapi::MAX_REPORT_DESCRIPTOR_SIZE];
            let n = self
                .device
                .get_report_descriptor(&mut buf)
                .map_err(|e| err("reading the report descriptor", e))?;
            buf.truncate(n);
            Ok(buf)
        }

        fn get_feature(&mut self, report_id: u8) -> Result<Vec<u8>> {
            let mut buf = vec![0u8; 4096];
            buf[0] = report_id;
            let n = self
                .device
                .get_feature_report(&mut buf)
                .map_err(|e| err("reading a feature report", e))?;
            buf.truncate(n);
            Ok(buf)
        }

        fn set_feature(&mut self, report: &[u8]) -> Result<()> {
            self.device
                .send_feature_report(report)
                .map_err(|e| err("sending a feature report", e))
        }

        fn read(&mut self, buf: &mut [u8], timeout_ms: u32) -> Result<usize> {
            self.device
                .read_timeout(buf, i32::try_from(timeout_ms).unwrap_or(i32::MAX))
                .map_err(|e| err("reading from the tracker", e))
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::sim::{simulate_hid, HidLayout};
    use super::*;
    use crate::clock::SharedClock;
    use crate::sim::{gaze_script, Script};

    fn log_text(layout: HidLayout) -> (String, Vec<GazeSample>) {
        let truth = gaze_script(&Script {
            seconds: 2.0,
            rate_hz: 50.0,
            frame: (337_900.0, 270_300.0),
            units_per_degree: 10_470.0,
            seed: 3,
        });
        let s = simulate_hid(layout, &truth, (337_900.0, 270_300.0), 50.0, 3);
        let text: Vec<u8> = s
            .chunks
            .iter()
            .filter(|c| c.kind == crate::recording::ChunkKind::DeviceToHost)
            .flat_map(|c| c.payload.iter().copied())
            .collect();
        (String::from_utf8(text).expect("text"), s.expected)
    }

    #[test]
    fn the_host_flow_reads_features_starts_streams_and_stops() {
        let (text, expected) = log_text(HidLayout::Compact);
        let config = HidConfig {
            vendor_id: None,
            product_id: None,
            screen_um: (1.0, 1.0),
            eye_positions: true,
            timeout_ms: 10,
        };
        let mut d = HidDriver::new(
            HidLogTransport::new(&text),
            config,
            Box::new(SharedClock::default()),
        );
        d.start().expect("starts");
        assert_eq!(d.info().screen_um, Some((337_900.0, 270_300.0)));
        assert_eq!(d.info().sampling_hz, Some(50.0));
        let mut got = Vec::new();
        while let Some(s) = d.next_sample().expect("replays") {
            got.push(s);
        }
        d.stop().expect("stops");
        assert_eq!(d.transport_mut().sent, vec![vec![0x14, 3], vec![0x14, 0]]);
        // The replay transport serves the first connection only.
        assert!(!got.is_empty() && got.len() < expected.len());
        for (g, e) in got.iter().zip(&expected) {
            assert_eq!(
                (g.combined, g.device_time_us, g.eye_position_um),
                (e.combined, e.device_time_us, e.eye_position_um)
            );
        }
    }

    /// Every descriptor shape the simulator emits, through the live driver
    /// flow and through the byte-stream decoder `replay --format hid-log`
    /// uses: the same samples, the device's screen size, the clamped mode.
    #[test]
    fn every_simulated_shape_streams_live_and_replays() {
        for layout in HidLayout::ALL {
            let (text, expected) = log_text(layout);
            let mut d = HidDriver::new(
                HidLogTransport::new(&text),
                HidConfig {
                    vendor_id: None,
                    product_id: None,
                    screen_um: (1.0, 1.0),
                    eye_positions: true,
                    timeout_ms: 10,
                },
                Box::new(SharedClock::default()),
            );
            d.start()
                .unwrap_or_else(|e| panic!("{layout:?}: starts: {e}"));
            assert_eq!(
                d.info().screen_um,
                Some((337_900.0, 270_300.0)),
                "{layout:?}"
            );
            let mut live = Vec::new();
            while let Some(s) = d.next_sample().expect("replays") {
                live.push(s);
            }
            let start = if layout == HidLayout::Unnamed { 1 } else { 3 };
            assert_eq!(
                d.transport_mut().sent,
                vec![vec![0x14, start]],
                "{layout:?}"
            );
            let mut decoder = HidLogDecoder::new();
            let replayed = crate::source::decode_all(&mut decoder, text.as_bytes(), 0);
            assert_eq!(replayed.len(), expected.len(), "{layout:?}");
            assert_eq!(decoder.frame_hint(), Some((337_900.0, 270_300.0)));
            assert_eq!(decoder.stats().resyncs, 0, "{layout:?}");
            assert!(!live.is_empty() && live.len() < expected.len());
            for (k, e) in expected.iter().enumerate() {
                let r = &replayed[k];
                assert_eq!(
                    (r.combined, r.device_time_us, r.eye_position_um),
                    (e.combined, e.device_time_us, e.eye_position_um),
                    "{layout:?} sample {k}"
                );
                if let Some(g) = live.get(k) {
                    assert_eq!(
                        (g.combined, g.device_time_us, g.eye_position_um),
                        (e.combined, e.device_time_us, e.eye_position_um),
                        "{layout:?} live sample {k}"
                    );
                }
            }
        }
    }

    #[test]
    fn a_device_that_is_not_an_eye_tracker_is_refused() {
        let mut t = HidLogTransport::new("# descriptor 05 01 09 02 a1 01 c0\n");
        assert!(t.descriptor().is_ok());
        let mut d = HidDriver::new(
            t,
            HidConfig {
                vendor_id: None,
                product_id: None,
                screen_um: (1.0, 1.0),
                eye_positions: false,
                timeout_ms: 10,
            },
            Box::new(SharedClock::default()),
        );
        let e = d.start().expect_err("a mouse");
        assert_eq!(e.kind, ErrorKind::Unsupported);
    }
}
