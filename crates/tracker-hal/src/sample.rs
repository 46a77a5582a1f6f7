//! What a gaze source delivers.

use crate::timing::TimeOrder;

/// One eye in one sample: a position in tracker units, or missing. A
/// missing eye never carries a coordinate (no bogus 0,0).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct EyeSample {
    /// Point of regard in tracker units (ISCAN: 0..512 frame units; mouse:
    /// screen pixels). `None` when the eye was not tracked (blink, lost).
    pub position: Option<[f64; 2]>,
    /// Pupil size in the device's units, when the device reports it.
    pub pupil: Option<f64>,
}

impl EyeSample {
    /// An eye that was not tracked.
    pub const MISSING: EyeSample = EyeSample {
        position: None,
        pupil: None,
    };

    /// Whether the eye was tracked (it has a position).
    pub fn valid(&self) -> bool {
        self.position.is_some()
    }
}

/// One gaze sample.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GazeSample {
    /// Records decoded by this source so far, from 0: strictly increasing.
    pub seq: u64,
    /// The device's own timestamp in µs on the device clock, when it has one
    /// (ISCAN has none; its driver derives one, see `iscan`).
    pub device_time_us: Option<u64>,
    /// Host monotonic time in µs when the record's last byte arrived (the
    /// *arrival* time: what the machine's load changes).
    pub host_time_us: u64,
    /// The device time mapped onto the host monotonic clock (µs) by the
    /// driver's [`ClockMapper`](crate::timing::ClockMapper): the time every
    /// file, event and latency figure uses. A decoder sets it to the
    /// arrival time with [`TimeOrder::Unmapped`]; the driver maps it.
    pub mapped_time_us: u64,
    /// How the device time stands against the previous sample's.
    pub time_order: TimeOrder,
    /// The clock segment (a device clock reset starts a new one): events
    /// never span two.
    pub clock_segment: u32,
    /// The left eye.
    pub left: EyeSample,
    /// The right eye.
    pub right: EyeSample,
    /// The device's own combined (cyclopean) point, for devices that send one.
    pub combined: Option<[f64; 2]>,
    /// Left and right eye positions in the tracker's 3-D frame (µm), from
    /// trackers that report them (HID); `None` when absent or invalid.
    pub eye_position_um: [Option<[f64; 3]>; 2],
}

impl GazeSample {
    /// A decoded sample, not yet mapped onto the host clock.
    pub fn new(
        seq: u64,
        device_time_us: Option<u64>,
        arrival_us: u64,
        left: EyeSample,
        right: EyeSample,
    ) -> Self {
        Self {
            seq,
            device_time_us,
            host_time_us: arrival_us,
            mapped_time_us: arrival_us,
            time_order: TimeOrder::Unmapped,
            clock_segment: 0,
            left,
            right,
            combined: None,
            eye_position_um: [None, None],
        }
    }

    /// The point the renderer uses: the device's combined point where it has
    /// one, else the mean of the valid eyes; `None` when no eye is valid.
    pub fn gaze(&self) -> Option<[f64; 2]> {
        if self.combined.is_some() {
            return self.combined;
        }
        match (self.left.position, self.right.position) {
            (Some(l), Some(r)) => Some([(l[0] + r[0]) / 2.0, (l[1] + r[1]) / 2.0]),
            (Some(p), None) | (None, Some(p)) => Some(p),
            (None, None) => None,
        }
    }
}

/// What a decoder has seen so far.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct DecodeStats {
    /// Bytes received from the transport.
    pub bytes: u64,
    /// Records decoded into samples.
    pub records: u64,
    /// Bytes skipped because they did not form a valid record.
    pub dropped_bytes: u64,
    /// Times the decoder lost and regained record alignment.
    pub resyncs: u64,
    /// Values outside the device's range (reported as a missing eye).
    pub invalid_values: u64,
}

impl std::ops::Add for DecodeStats {
    type Output = DecodeStats;
    /// Two counts together (a connection's, then the next one's),
    /// saturating: a count never wraps to a small number.
    fn add(self, b: DecodeStats) -> DecodeStats {
        DecodeStats {
            bytes: self.bytes.saturating_add(b.bytes),
            records: self.records.saturating_add(b.records),
            dropped_bytes: self.dropped_bytes.saturating_add(b.dropped_bytes),
            resyncs: self.resyncs.saturating_add(b.resyncs),
            invalid_values: self.invalid_values.saturating_add(b.invalid_values),
        }
    }
}
