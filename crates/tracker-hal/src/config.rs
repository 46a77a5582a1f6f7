//! A tracker configuration file (`config/trackers/*.ron`); how two of them
//! differ is [`differences`].

pub mod differences;

use serde::{Deserialize, Serialize};

use crate::hid::{HidConfig, HidLogDecoder};
use crate::iscan::{IscanConfig, IscanDecoder};
use crate::lsl::{LslConfig, LslDecoder};
use crate::mapping::Mapping;
use crate::mouse::{MouseConfig, MouseDecoder};
use crate::source::Decoder;

/// Which driver, with its settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Driver {
    /// ISCAN DQW over a serial port.
    Iscan(IscanConfig),
    /// The mouse (or a recorded mouse stream) as a stand-in tracker.
    Mouse(MouseConfig),
    /// A tracker on the HID eye-tracker usage page (Tobii and others).
    TobiiHid(HidConfig),
    /// No eye tracker: the viewer predicts the attended object from each
    /// rendered frame (Lee 2009 ch. 3) and reports its saliency peak as
    /// the point of regard, through the mouse emulator's stream (so its
    /// samples are timestamped, recorded and replayed like any others).
    Attention(AttentionSourceConfig),
    /// A Lab Streaming Layer gaze stream ([`crate::lsl`]).
    Lsl(Box<LslConfig>),
}

/// Smallest and largest saliency map side of the attention source (Lee's
/// 64² to 512²).
pub const ATTENTION_MAP_SIZES: std::ops::RangeInclusive<u32> = 64..=512;

/// The attention source's settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AttentionSourceConfig {
    /// Samples per second of the stream (the prediction changes once per
    /// rendered frame; the stream repeats it in between).
    #[serde(default = "default_attention_rate")]
    pub rate_hz: f64,
    /// Saliency map side, px (64 to 512).
    #[serde(default = "default_attention_map")]
    pub map_size: u32,
}

fn default_attention_rate() -> f64 {
    120.0
}
fn default_attention_map() -> u32 {
    64
}

impl Default for AttentionSourceConfig {
    fn default() -> Self {
        Self {
            rate_hz: default_attention_rate(),
            map_size: default_attention_map(),
        }
    }
}

impl AttentionSourceConfig {
    /// Checks every value; the error names the field.
    pub fn validate(&self) -> Result<(), (&'static str, String)> {
        if !ATTENTION_MAP_SIZES.contains(&self.map_size) {
            return Err((
                "map_size",
                format!(
                    "{} must be {} to {} pixels",
                    self.map_size,
                    ATTENTION_MAP_SIZES.start(),
                    ATTENTION_MAP_SIZES.end()
                ),
            ));
        }
        self.stream().validate()
    }

    /// The mouse emulator that carries the predictions: no jitter, no
    /// saccades, no added latency.
    pub fn stream(&self) -> MouseConfig {
        MouseConfig {
            rate_hz: self.rate_hz,
            ..MouseConfig::default()
        }
    }
}

/// A tracker: its driver and how its coordinates map to the screen.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename = "Tracker", deny_unknown_fields)]
pub struct TrackerConfig {
    /// Which driver, with its settings.
    pub driver: Driver,
    /// How the driver's coordinates map to screen pixels.
    #[serde(default)]
    pub mapping: Mapping,
}

impl TrackerConfig {
    /// Checks every value; the error names the field (dotted path).
    pub fn validate(&self) -> Result<(), (String, String)> {
        let scoped = |prefix: &str, (f, m): (&str, String)| (format!("{prefix}.{f}"), m);
        match &self.driver {
            Driver::Iscan(c) => c.validate().map_err(|e| scoped("driver", e))?,
            Driver::Mouse(c) => c.validate().map_err(|e| scoped("driver", e))?,
            Driver::TobiiHid(c) => c.validate().map_err(|e| scoped("driver", e))?,
            Driver::Attention(c) => c.validate().map_err(|e| scoped("driver", e))?,
            Driver::Lsl(c) => c.validate().map_err(|(f, m)| (format!("driver.{f}"), m))?,
        }
        self.mapping
            .check_range(self.range())
            .map_err(|(f, m)| (f.to_string(), m))
    }

    /// The tracker's range, the rectangle `[0, w] × [0, h]` of tracker
    /// units its samples fall in, as the file declares it: an ISCAN's
    /// `frame` (per eye), a HID tracker's `screen_um` (gaze is in µm from
    /// the display's upper-left corner). `None` for the mouse: its samples
    /// are screen pixels, of a screen the tracker file does not name.
    /// [`Mapping::check_range`] checks the mapping against it.
    pub fn range(&self) -> Option<(f64, f64)> {
        match &self.driver {
            Driver::Iscan(c) => Some(c.frame),
            Driver::Mouse(_) | Driver::Attention(_) => None,
            Driver::TobiiHid(c) => Some(c.screen_um),
            Driver::Lsl(c) => Some(c.frame()),
        }
    }

    /// A fresh decoder for this driver.
    pub fn decoder(&self) -> Box<dyn Decoder> {
        match &self.driver {
            Driver::Iscan(c) => Box::new(IscanDecoder::new(c.clone())),
            Driver::Mouse(_) | Driver::Attention(_) => Box::new(MouseDecoder::new()),
            Driver::TobiiHid(_) => Box::new(HidLogDecoder::new()),
            Driver::Lsl(c) => Box::new(LslDecoder::new((**c).clone())),
        }
    }

    /// The tracker's coordinate frame, (width, height) in tracker units
    /// (mouse: unbounded, reported as infinite).
    pub fn frame(&self) -> (f64, f64) {
        match &self.driver {
            Driver::Iscan(c) => c.frame,
            Driver::Mouse(_) | Driver::Attention(_) => (f64::INFINITY, f64::INFINITY),
            Driver::TobiiHid(c) => c.screen_um,
            Driver::Lsl(c) => c.frame(),
        }
    }

    /// Whether the device measures two eyes: not the mouse or the
    /// attention source, whose decoder copies one point into both, nor an
    /// LSL stream with one gaze point.
    pub fn measures_two_eyes(&self) -> bool {
        match &self.driver {
            Driver::Mouse(_) | Driver::Attention(_) => false,
            // A stream with one gaze point copies it into both eyes.
            Driver::Lsl(c) => c.binocular(),
            _ => true,
        }
    }

    /// Short name of the driver, for messages.
    pub fn driver_name(&self) -> &'static str {
        match &self.driver {
            Driver::Iscan(_) => "iscan",
            Driver::Mouse(_) => "mouse",
            Driver::TobiiHid(_) => "tobii-hid",
            Driver::Attention(_) => "attention",
            Driver::Lsl(_) => "lsl",
        }
    }
}

impl Decoder for Box<dyn Decoder> {
    fn push(
        &mut self,
        bytes: &[u8],
        arrival_us: u64,
        out: &mut std::collections::VecDeque<crate::GazeSample>,
    ) {
        (**self).push(bytes, arrival_us, out)
    }
    fn finish(&mut self) {
        (**self).finish()
    }
    fn stats(&self) -> crate::DecodeStats {
        (**self).stats()
    }
    fn start_command(&self) -> Vec<u8> {
        (**self).start_command()
    }
    fn stop_command(&self) -> Vec<u8> {
        (**self).stop_command()
    }
    fn frame_hint(&self) -> Option<(f64, f64)> {
        (**self).frame_hint()
    }
    // Forwarded like every other method: the default (`Device`) made a
    // boxed ISCAN decoder, whose device times are its record counter,
    // claim the tracker's own timestamps in the session and the log.
    fn device_clock(&self) -> crate::DeviceClock {
        (**self).device_clock()
    }
}
