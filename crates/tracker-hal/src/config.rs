//! A tracker configuration file (`config/trackers/*.ron`).

use serde::{Deserialize, Serialize};

use crate::hid::{HidConfig, HidLogDecoder};
use crate::iscan::{IscanConfig, IscanDecoder};
use crate::mapping::Mapping;
use crate::mouse::{MouseConfig, MouseDecoder};
use crate::source::Decoder;

/// Which driver, with its settings.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum Driver {
    Iscan(IscanConfig),
    Mouse(MouseConfig),
    /// A tracker on the HID eye-tracker usage page (Tobii and others).
    TobiiHid(HidConfig),
}

/// A tracker: its driver and how its coordinates map to the screen.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename = "Tracker", deny_unknown_fields)]
pub struct TrackerConfig {
    pub driver: Driver,
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
            Driver::Mouse(_) => None,
            Driver::TobiiHid(c) => Some(c.screen_um),
        }
    }

    /// A fresh decoder for this driver.
    pub fn decoder(&self) -> Box<dyn Decoder> {
        match &self.driver {
            Driver::Iscan(c) => Box::new(IscanDecoder::new(c.clone())),
            Driver::Mouse(_) => Box::new(MouseDecoder::new()),
            Driver::TobiiHid(_) => Box::new(HidLogDecoder::new()),
        }
    }

    /// The tracker's coordinate frame, (width, height) in tracker units
    /// (mouse: unbounded, reported as infinite).
    pub fn frame(&self) -> (f64, f64) {
        match &self.driver {
            Driver::Iscan(c) => c.frame,
            Driver::Mouse(_) => (f64::INFINITY, f64::INFINITY),
            Driver::TobiiHid(c) => c.screen_um,
        }
    }

    /// Short name of the driver, for messages.
    pub fn driver_name(&self) -> &'static str {
        match &self.driver {
            Driver::Iscan(_) => "iscan",
            Driver::Mouse(_) => "mouse",
            Driver::TobiiHid(_) => "tobii-hid",
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
}
