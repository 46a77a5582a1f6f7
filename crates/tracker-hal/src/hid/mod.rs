//! Eye trackers on the HID "Eye and Head Trackers" usage page (0x12, HID
//! usage tables review HUTRR74), the interface Tobii co-defined with
//! Microsoft, Intel and EyeTech and that Windows' eye control reads Tobii
//! trackers through.
//!
//! - [`descriptor`]: the report descriptor parser; fields are located by
//!   usage ([`TrackerLayout`]), never by offset.
//! - [`log`]: the `hid-log` text format (one report per line) and
//!   [`HidLogDecoder`], the byte-stream decoder of that text. The live driver
//!   ([`driver::HidDriver`]) turns every report it reads into a log line and
//!   decodes it with the same decoder, so live, recorded and replayed
//!   sessions share one decode path, and a `.gzrec` of a HID session holds
//!   hid-log text.
//! - [`sim`]: a simulated device producing descriptor, feature and input
//!   reports (blinks as gaps, one eye lost, a reconnect).
//! - [`driver`]: the transport trait, its `hidapi` implementation, a replay
//!   implementation, and the host flow (get features 0x11–0x13, set 0x14,
//!   read 0x10).
//!
//! Units: gaze point and eye positions in µm (gaze: from the display's
//! upper-left corner; eye positions: the tracker's 3-D frame), sensor
//! timestamp in µs of the device clock. A value outside its field's logical
//! range (±2,000,000 in the reference descriptor) is invalid.
//!
//! Not covered: Tobii Pro trackers (the Tobii Pro SDK's own protocol) and
//! the vendor-specific USB bulk protocol of consumer trackers such as the
//! Tobii ET5 on Linux. Those are not this interface.

pub mod descriptor;
pub mod driver;
pub mod log;
pub mod sim;

use serde::{Deserialize, Serialize};

use descriptor::{Field, ReportDescriptor, ReportKind};
pub use log::HidLogDecoder;

/// Usage page "Eye and Head Trackers".
pub const PAGE: u16 = 0x12;

/// Usages of page 0x12 (HUTRR74).
pub mod usage {
    /// Eye Tracker: the application collection of a tracker.
    pub const EYE_TRACKER: u16 = 0x01;
    /// Tracking Data: the input report of samples.
    pub const TRACKING_DATA: u16 = 0x10;
    /// Capabilities: the feature report of what the device can do.
    pub const CAPABILITIES: u16 = 0x11;
    /// Configuration: the feature report of the device's setup.
    pub const CONFIGURATION: u16 = 0x12;
    /// Status: the report of the device's state.
    pub const STATUS: u16 = 0x13;
    /// Control: the feature report that starts and stops streaming.
    pub const CONTROL: u16 = 0x14;
    /// Sensor Timestamp: a sample's device time, µs.
    pub const SENSOR_TIMESTAMP: u16 = 0x20;
    /// Position X (of a gaze point or a position).
    pub const POSITION_X: u16 = 0x21;
    /// Position Y.
    pub const POSITION_Y: u16 = 0x22;
    /// Position Z.
    pub const POSITION_Z: u16 = 0x23;
    /// Gaze Point: where the gaze meets the screen, µm.
    pub const GAZE_POINT: u16 = 0x24;
    /// Left Eye Position, µm in the tracker's frame.
    pub const LEFT_EYE_POSITION: u16 = 0x25;
    /// Right Eye Position, µm in the tracker's frame.
    pub const RIGHT_EYE_POSITION: u16 = 0x26;
    /// Head Position, µm in the tracker's frame.
    pub const HEAD_POSITION: u16 = 0x27;
    /// Head Direction.
    pub const HEAD_DIRECTION: u16 = 0x28;
    /// Rotation X (of the head direction).
    pub const ROTATION_X: u16 = 0x29;
    /// Rotation Y.
    pub const ROTATION_Y: u16 = 0x2A;
    /// Rotation Z.
    pub const ROTATION_Z: u16 = 0x2B;
    /// Tracker Quality.
    pub const TRACKER_QUALITY: u16 = 0x100;
    /// Minimum Tracking Distance, µm.
    pub const MIN_TRACKING_DISTANCE: u16 = 0x101;
    /// Optimum Tracking Distance, µm.
    pub const OPTIMUM_TRACKING_DISTANCE: u16 = 0x102;
    /// Maximum Tracking Distance, µm.
    pub const MAX_TRACKING_DISTANCE: u16 = 0x103;
    /// Maximum Screen Plane Width, µm.
    pub const MAX_SCREEN_PLANE_WIDTH: u16 = 0x104;
    /// Maximum Screen Plane Height, µm.
    pub const MAX_SCREEN_PLANE_HEIGHT: u16 = 0x105;
    /// Calibrated Screen Width, µm.
    pub const CALIBRATED_SCREEN_WIDTH: u16 = 0x204;
    /// Calibrated Screen Height, µm.
    pub const CALIBRATED_SCREEN_HEIGHT: u16 = 0x205;
    /// Sampling Frequency, Hz.
    pub const SAMPLING_FREQUENCY: u16 = 0x300;
    /// Configuration Status (see [`ConfigurationStatus`](super::ConfigurationStatus)).
    pub const CONFIGURATION_STATUS: u16 = 0x301;
    /// Device Mode Request (the bits of [`mode`](super::mode)).
    pub const DEVICE_MODE_REQUEST: u16 = 0x400;
}

/// Device mode request bits (feature 0x14).
pub mod mode {
    /// Report gaze points.
    pub const GAZE_POINT: u32 = 1;
    /// Report eye positions.
    pub const EYE_POSITION: u32 = 2;
    /// Report the head position.
    pub const HEAD_POSITION: u32 = 4;
}

/// Configuration status (feature / input 0x13).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum ConfigurationStatus {
    /// Status 0: not known.
    Unknown,
    /// Status 1: ready.
    Ready,
    /// Status 2: being configured.
    Configuring,
    /// Status 3: the screen must be set up first.
    ScreenSetupNeeded,
    /// Status 4: the user must calibrate first.
    UserCalibrationNeeded,
    /// Any other code (clamped to 0–255).
    Other(u8),
}

impl ConfigurationStatus {
    /// The status of a Configuration Status value (codes 0–4, others kept).
    pub fn from_code(c: i64) -> Self {
        match c {
            0 => Self::Unknown,
            1 => Self::Ready,
            2 => Self::Configuring,
            3 => Self::ScreenSetupNeeded,
            4 => Self::UserCalibrationNeeded,
            c => Self::Other(c.clamp(0, 255) as u8),
        }
    }
}

/// One located value: the fields that carry it (a timestamp may be eight
/// one-byte fields), concatenated little-endian in report order.
#[derive(Debug, Clone, PartialEq)]
pub struct Value {
    /// The report the value is in.
    pub report_id: u8,
    fields: Vec<Field>,
}

impl Value {
    /// Total width in bits.
    pub fn bits(&self) -> u32 {
        self.fields.iter().map(|f| f.bit_size).sum()
    }

    /// Reads the value from a report's data; `None` when the report is short
    /// or (single-field values) the value is outside the logical range.
    pub fn read(&self, data: &[u8]) -> Option<i64> {
        if let [f] = self.fields.as_slice() {
            let v = f.read(data)?;
            return f.in_range(v).then_some(v);
        }
        let mut v = 0u64;
        let mut shift = 0;
        for f in &self.fields {
            let part = descriptor::read_bits(data, f.bit_offset, f.bit_size)?;
            if shift < 64 {
                v |= part << shift;
            }
            shift += f.bit_size;
        }
        Some(v as i64)
    }

    /// The declared logical range of a single-field value, when it declares
    /// one ([`Field::declared_range`]).
    pub fn range(&self) -> Option<(i64, i64)> {
        match self.fields.as_slice() {
            [f] => f.declared_range(),
            _ => None,
        }
    }

    /// Whether `v` is a valid value of this field (always, for values of
    /// several fields or without a declared range).
    pub fn in_range(&self, v: i64) -> bool {
        self.range().is_none_or(|(lo, hi)| (lo..=hi).contains(&v))
    }

    /// Writes `v` into a report's data (the simulator, the control report).
    pub fn write(&self, data: &mut [u8], v: i64) {
        let mut rest = v as u64;
        for f in &self.fields {
            descriptor::write_bits(data, f.bit_offset, f.bit_size, rest);
            rest = rest.checked_shr(f.bit_size).unwrap_or(0);
        }
    }
}

/// Where everything of an eye tracker is, found by usage in its descriptor.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackerLayout {
    /// The parsed descriptor.
    pub descriptor: ReportDescriptor,
    /// ID of the Tracking Data input report.
    pub tracking_report_id: u8,
    /// Sensor Timestamp.
    pub timestamp: Option<Value>,
    /// Gaze Point X and Y.
    pub gaze: Option<[Value; 2]>,
    /// Left Eye Position X, Y and Z.
    pub left_eye: Option<[Value; 3]>,
    /// Right Eye Position X, Y and Z.
    pub right_eye: Option<[Value; 3]>,
    /// Head Position X, Y and Z.
    pub head: Option<[Value; 3]>,
    /// Capability values, by usage, as a feature report.
    pub capabilities: Vec<(u16, Value)>,
    /// Configuration values, by usage, as a feature report.
    pub configuration: Vec<(u16, Value)>,
    /// Status values as a feature report.
    pub status: Vec<(u16, Value)>,
    /// Status values as an input report (sent when the status changes).
    pub status_input: Vec<(u16, Value)>,
    /// Device Mode Request, as a feature report.
    pub mode_request: Option<Value>,
}

/// Why a descriptor is not an eye tracker's.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum LayoutError {
    /// The descriptor does not parse.
    #[error("report descriptor: {0}")]
    Descriptor(#[from] descriptor::DescriptorError),
    /// No Eye Tracker collection (usage page 0x12, usage 0x01).
    #[error("no Eye Tracker collection (usage page 0x12, usage 0x01)")]
    NotAnEyeTracker,
    /// No Tracking Data input report with a Gaze Point X and Y.
    #[error("no Tracking Data input report with a Gaze Point X and Y")]
    NoGaze,
}

/// The fields of `usage` on page 0x12 in a report of `kind` (optionally of
/// `report_id`), inside the collection named `collection`.
///
/// Where no field is in such a collection, a field whose only named
/// collection on page 0x12 is the Eye Tracker application itself (its
/// logical collections carry no usage, as in Microsoft's virtual eye-gaze
/// device) is taken instead: the usages looked up this way are unique in an
/// eye tracker, and the Windows HID API finds a usage anywhere in its
/// top-level collection. Fields in collections named otherwise are never
/// taken, so descriptors with named collections locate exactly as before.
/// Position X/Y/Z are not unique (gaze, eyes, head): they are only found in
/// their named Gaze Point, Eye or Head Position collection.
fn locate(
    fields: &[Field],
    kind: ReportKind,
    collection: u16,
    usage: u16,
    report_id: Option<u8>,
) -> Option<Value> {
    let candidate = |f: &&Field| {
        f.kind == kind
            && f.variable
            && f.usage_page == PAGE
            && f.usage == usage
            && report_id.is_none_or(|r| f.report_id == r)
    };
    let named = |f: &&Field| f.innermost(PAGE) == Some(collection);
    let unnamed = |f: &&Field| {
        f.collections.first() == Some(&(PAGE, usage::EYE_TRACKER))
            && f.innermost(PAGE) == Some(usage::EYE_TRACKER)
    };
    let pick = |inside: &dyn Fn(&&Field) -> bool| -> Option<Value> {
        let mut mine = fields.iter().filter(candidate).filter(|f| inside(f));
        let id = mine.next()?.report_id;
        let fields: Vec<Field> = fields
            .iter()
            .filter(candidate)
            .filter(|f| inside(f) && f.report_id == id)
            .cloned()
            .collect();
        Some(Value {
            report_id: id,
            fields,
        })
    };
    let unique = !matches!(
        usage,
        usage::POSITION_X | usage::POSITION_Y | usage::POSITION_Z
    );
    pick(&named).or_else(|| unique.then(|| pick(&unnamed)).flatten())
}

impl TrackerLayout {
    /// Parses a descriptor and locates the tracker's values.
    pub fn from_descriptor(bytes: &[u8]) -> Result<Self, LayoutError> {
        let descriptor = ReportDescriptor::parse(bytes)?;
        if !descriptor
            .applications
            .contains(&(PAGE, usage::EYE_TRACKER))
        {
            return Err(LayoutError::NotAnEyeTracker);
        }
        let f = &descriptor.fields;
        use usage::*;
        let xy = |c: u16, id: Option<u8>| -> Option<[Value; 2]> {
            Some([
                locate(f, ReportKind::Input, c, POSITION_X, id)?,
                locate(f, ReportKind::Input, c, POSITION_Y, id)?,
            ])
        };
        let gaze = xy(GAZE_POINT, None).ok_or(LayoutError::NoGaze)?;
        let id = gaze[0].report_id;
        if gaze[1].report_id != id {
            return Err(LayoutError::NoGaze);
        }
        let xyz = |c: u16| -> Option<[Value; 3]> {
            let [x, y] = xy(c, Some(id))?;
            Some([x, y, locate(f, ReportKind::Input, c, POSITION_Z, Some(id))?])
        };
        let list = |kind: ReportKind, c: u16, usages: &[u16]| -> Vec<(u16, Value)> {
            usages
                .iter()
                .filter_map(|&u| locate(f, kind, c, u, None).map(|v| (u, v)))
                .collect()
        };
        let status_usages = [SAMPLING_FREQUENCY, CONFIGURATION_STATUS];
        Ok(Self {
            tracking_report_id: id,
            timestamp: locate(
                f,
                ReportKind::Input,
                TRACKING_DATA,
                SENSOR_TIMESTAMP,
                Some(id),
            ),
            left_eye: xyz(LEFT_EYE_POSITION),
            right_eye: xyz(RIGHT_EYE_POSITION),
            head: xyz(HEAD_POSITION),
            gaze: Some(gaze),
            capabilities: list(
                ReportKind::Feature,
                CAPABILITIES,
                &[
                    TRACKER_QUALITY,
                    MIN_TRACKING_DISTANCE,
                    OPTIMUM_TRACKING_DISTANCE,
                    MAX_TRACKING_DISTANCE,
                    MAX_SCREEN_PLANE_WIDTH,
                    MAX_SCREEN_PLANE_HEIGHT,
                ],
            ),
            configuration: list(
                ReportKind::Feature,
                CONFIGURATION,
                &[CALIBRATED_SCREEN_WIDTH, CALIBRATED_SCREEN_HEIGHT],
            ),
            status: list(ReportKind::Feature, STATUS, &status_usages),
            status_input: list(ReportKind::Input, STATUS, &status_usages),
            mode_request: locate(f, ReportKind::Feature, CONTROL, DEVICE_MODE_REQUEST, None),
            descriptor,
        })
    }

    /// The feature report IDs to read at start (capabilities, configuration,
    /// status), in that order, without repeats.
    pub fn feature_ids(&self) -> Vec<u8> {
        let mut ids = Vec::new();
        for list in [&self.capabilities, &self.configuration, &self.status] {
            if let Some((_, v)) = list.first() {
                if !ids.contains(&v.report_id) {
                    ids.push(v.report_id);
                }
            }
        }
        ids
    }

    /// The Mode Request value sent for `mode`: `mode` itself when the
    /// descriptor's logical range allows it, else the gaze point alone
    /// (dropping eye and head positions) when that fits, else `mode` clamped
    /// to the range (a device declaring 0..1 gets 1 for 3). A stop (0) is
    /// sent as 0 whatever the range: clamping it would start the device.
    /// `None` when the device has no Mode Request.
    pub fn mode_value(&self, request: u32) -> Option<i64> {
        let v = self.mode_request.as_ref()?;
        let want = i64::from(request);
        let gaze_only = i64::from(request & mode::GAZE_POINT);
        Some(match v.range() {
            None => want,
            Some(_) if want == 0 || v.in_range(want) => want,
            Some(_) if v.in_range(gaze_only) => gaze_only,
            Some((lo, hi)) => want.clamp(lo, hi),
        })
    }

    /// The Control feature report asking for `mode` (0 stops streaming),
    /// report ID first, the request clamped by [`mode_value`](Self::mode_value).
    /// `None` when the device has no Control report.
    pub fn control_report(&self, mode: u32) -> Option<Vec<u8>> {
        let v = self.mode_request.as_ref()?;
        let value = self.mode_value(mode)?;
        let len = self.descriptor.report_len(ReportKind::Feature, v.report_id);
        let mut data = vec![0u8; len];
        v.write(&mut data, value);
        let mut out = vec![v.report_id];
        out.extend(data);
        Some(out)
    }

    /// Decodes one Tracking Data report (`data` without the ID byte).
    pub fn tracking(&self, data: &[u8]) -> Option<Tracking> {
        let need = self
            .descriptor
            .report_len(ReportKind::Input, self.tracking_report_id);
        if data.len() < need {
            return None;
        }
        let point = |vs: &[Value]| -> Option<Vec<f64>> {
            vs.iter().map(|v| v.read(data).map(|x| x as f64)).collect()
        };
        let p2 = |vs: &Option<[Value; 2]>| vs.as_ref().and_then(|v| point(v)).map(|p| [p[0], p[1]]);
        let p3 = |vs: &Option<[Value; 3]>| {
            vs.as_ref()
                .and_then(|v| point(v))
                .map(|p| [p[0], p[1], p[2]])
        };
        Some(Tracking {
            timestamp_us: self
                .timestamp
                .as_ref()
                .and_then(|v| v.read(data))
                .map(|t| t as u64),
            gaze_um: p2(&self.gaze),
            left_eye_um: p3(&self.left_eye),
            right_eye_um: p3(&self.right_eye),
            head_um: p3(&self.head),
        })
    }

    /// The values a feature or input report carries, by usage.
    pub fn values(list: &[(u16, Value)], report_id: u8, data: &[u8]) -> Vec<(u16, i64)> {
        list.iter()
            .filter(|(_, v)| v.report_id == report_id)
            .filter_map(|(u, v)| v.read(data).map(|x| (*u, x)))
            .collect()
    }
}

/// One Tracking Data report, decoded. `None` = absent or invalid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tracking {
    /// Sensor Timestamp, µs (device clock).
    pub timestamp_us: Option<u64>,
    /// Gaze point on the calibrated screen, µm.
    pub gaze_um: Option<[f64; 2]>,
    /// Left eye position, µm (tracker frame).
    pub left_eye_um: Option<[f64; 3]>,
    /// Right eye position, µm (tracker frame).
    pub right_eye_um: Option<[f64; 3]>,
    /// Head position, µm (tracker frame).
    pub head_um: Option<[f64; 3]>,
}

/// What the device told us in its feature reports.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct DeviceInfo {
    /// Calibrated screen size (µm), feature 0x12.
    pub screen_um: Option<(f64, f64)>,
    /// Sampling frequency, Hz.
    pub sampling_hz: Option<f64>,
    /// Configuration status.
    pub status: Option<ConfigurationStatus>,
    /// Tracker quality, as the device reports it.
    pub tracker_quality: Option<i64>,
    /// Minimum, optimum, maximum tracking distance (µm).
    pub tracking_distance_um: Option<(f64, f64, f64)>,
}

impl DeviceInfo {
    /// Applies the values of a feature or status report.
    pub fn apply(&mut self, values: &[(u16, i64)]) {
        use usage::*;
        let get = |u: u16| values.iter().find(|(k, _)| *k == u).map(|(_, v)| *v);
        if let (Some(w), Some(h)) = (get(CALIBRATED_SCREEN_WIDTH), get(CALIBRATED_SCREEN_HEIGHT)) {
            if w > 0 && h > 0 {
                self.screen_um = Some((w as f64, h as f64));
            }
        }
        if let Some(f) = get(SAMPLING_FREQUENCY).filter(|f| *f > 0) {
            self.sampling_hz = Some(f as f64);
        }
        if let Some(s) = get(CONFIGURATION_STATUS) {
            self.status = Some(ConfigurationStatus::from_code(s));
        }
        if let Some(q) = get(TRACKER_QUALITY) {
            self.tracker_quality = Some(q);
        }
        if let (Some(a), Some(b), Some(c)) = (
            get(MIN_TRACKING_DISTANCE),
            get(OPTIMUM_TRACKING_DISTANCE),
            get(MAX_TRACKING_DISTANCE),
        ) {
            self.tracking_distance_um = Some((a as f64, b as f64, c as f64));
        }
    }
}

/// The `TobiiHid` driver's settings (a tracker file's `driver: TobiiHid((…))`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HidConfig {
    /// USB vendor ID to open (default: any device with an Eye Tracker
    /// collection; Tobii is 0x2104).
    #[serde(default)]
    pub vendor_id: Option<u16>,
    /// USB product ID to open (default: any).
    #[serde(default)]
    pub product_id: Option<u16>,
    /// Calibrated screen size (µm) used until the device reports its own
    /// (feature 0x12), and for replays of logs without it.
    pub screen_um: (f64, f64),
    /// Ask for eye positions as well as the gaze point.
    #[serde(default = "yes")]
    pub eye_positions: bool,
    /// Read timeout (ms): `next_sample` returns `TimedOut` after it.
    #[serde(default = "default_timeout")]
    pub timeout_ms: u32,
}

fn yes() -> bool {
    true
}
fn default_timeout() -> u32 {
    100
}

impl HidConfig {
    /// Checks the settings; the error names the field and says why.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        let (w, h) = self.screen_um;
        if !(w.is_finite() && h.is_finite() && w > 0.0 && h > 0.0) {
            return Err(("screen_um", format!("({w}, {h}) must be positive µm")));
        }
        if self.timeout_ms == 0 || self.timeout_ms > 60_000 {
            return Err((
                "timeout_ms",
                format!("{} must be in 1..=60000", self.timeout_ms),
            ));
        }
        Ok(())
    }

    /// The mode request bits this configuration asks for.
    pub fn mode(&self) -> u32 {
        mode::GAZE_POINT
            | if self.eye_positions {
                mode::EYE_POSITION
            } else {
                0
            }
    }
}
