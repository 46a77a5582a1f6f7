//! The file a renderer reads a participant's thresholds from:
//! `thresholds-<ID>.ron`, written by `gazecast thresholds measure` and read
//! by `--thresholds FILE` (`render`, `view`, `demo`, `bench`) and by an
//! experiment design's `thresholds` field.
//!
//! *Decision*: one self-contained RON file, not the session folder: the
//! measured table (frequency × eccentricity, one row per eccentricity) and
//! the fitted Geisler–Perry parameters (CT0, α, e2) with the participant's
//! id and whether the answers were synthetic. A renderer needs nothing
//! else from the session, and a lab can copy one file next to a design.
//!
//! ```ron
//! (
//!     participant: "P01",
//!     synthetic: true,
//!     geisler_perry: (ct0: 0.0156, alpha: 0.106, e2_deg: 2.3),
//!     frequencies_cpd: [1.0, 2.0, 4.0, 8.0, 16.0],
//!     eccentricities_deg: [0.0, 2.5, 5.0, 10.0],
//!     thresholds: [[...], [...], [...], [...]],
//! )
//! ```

use serde::{Deserialize, Serialize};

use foveation::perceptibility::{ThresholdTable, ThresholdTableData};
use foveation::GeislerPerry;

use crate::ParamError;

/// A participant's thresholds as stored in `thresholds-<ID>.ron`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ParticipantThresholds {
    /// The participant's id.
    pub participant: String,
    /// True when the answers came from a simulated observer, not a person;
    /// everything rendered with these thresholds then says so.
    pub synthetic: bool,
    /// The fitted Geisler–Perry parameters (the CSF of the ray-cast
    /// methods' sampling model).
    pub geisler_perry: GeislerPerry,
    /// The measured table's frequencies, cycles/degree (strictly increasing).
    pub frequencies_cpd: Vec<f64>,
    /// Its eccentricities, degrees (strictly increasing).
    pub eccentricities_deg: Vec<f64>,
    /// One row per eccentricity, one threshold contrast per frequency.
    pub thresholds: Vec<Vec<f64>>,
}

impl ParticipantThresholds {
    /// From a fit and its measured table.
    pub fn new(
        participant: &str,
        synthetic: bool,
        geisler_perry: GeislerPerry,
        table: ThresholdTable,
    ) -> Self {
        let d = ThresholdTableData::from(table);
        Self {
            participant: participant.to_string(),
            synthetic,
            geisler_perry,
            frequencies_cpd: d.frequencies_cpd,
            eccentricities_deg: d.eccentricities_deg,
            thresholds: d.thresholds,
        }
    }

    /// Checks the parameters and the table. The error's `field` is the
    /// file's (`geisler_perry.ct0`, `thresholds`, ...).
    pub fn validate(&self) -> Result<(), ParamError> {
        self.geisler_perry.validate().map_err(|mut e| {
            e.field = match e.field {
                "ct0" => "geisler_perry.ct0",
                "alpha" => "geisler_perry.alpha",
                "e2_deg" => "geisler_perry.e2_deg",
                _ => "geisler_perry",
            };
            e
        })?;
        self.measured_table().map(|_| ())
    }

    /// The measured table alone (clamped to its grid's edges when looked
    /// up outside it).
    pub fn measured_table(&self) -> Result<ThresholdTable, ParamError> {
        ThresholdTable::new(
            self.frequencies_cpd.clone(),
            self.eccentricities_deg.clone(),
            self.thresholds.clone(),
        )
    }

    /// The table the model-based methods use: the measured table inside
    /// its grid, the fitted model outside it
    /// ([`ThresholdTable::extended_by`]).
    pub fn renderer_table(&self) -> Result<ThresholdTable, ParamError> {
        Ok(self.measured_table()?.extended_by(&self.geisler_perry))
    }

    /// One line for `explain`: the participant, whether synthetic, and the
    /// fitted parameters.
    pub fn summary(&self) -> String {
        let m = &self.geisler_perry;
        format!(
            "participant {}{}: Geisler–Perry CT0 {:.4}, α {:.4}, e2 {:.3}°; measured table {}–{} cpd × {}–{}°",
            self.participant,
            if self.synthetic {
                " (SYNTHETIC: a simulated observer, not a person)"
            } else {
                ""
            },
            m.ct0,
            m.alpha,
            m.e2_deg,
            self.frequencies_cpd.first().copied().unwrap_or(f64::NAN),
            self.frequencies_cpd.last().copied().unwrap_or(f64::NAN),
            self.eccentricities_deg.first().copied().unwrap_or(f64::NAN),
            self.eccentricities_deg.last().copied().unwrap_or(f64::NAN),
        )
    }
}
