//! The rows of the session's TSV files (trials, samples, events,
//! markers, frames, clock updates) and their [`TsvRow`] schema: file,
//! columns, and the columns added after the first version.

use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};

use super::layout::{CLOCK_TSV, EVENTS_TSV, FRAMES_TSV, MARKERS_TSV, SAMPLES_TSV, TRIALS_TSV};
use super::na;

/// One completed search trial (`trials.tsv`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TrialRow {
    /// Participant id (as in `session.json`).
    pub participant: String,
    /// The sitting the trial was completed in (its times are on that
    /// sitting's host clock).
    pub sitting: u32,
    /// Run (repetition), from 0.
    pub run: usize,
    /// Position in the session, from 0 (`plan::Trial::index`).
    pub trial: usize,
    /// Position within the run, from 0.
    pub trial_in_run: usize,
    /// Condition name (`Design::conditions[..].name`).
    pub condition: String,
    /// Rendering method (`"full"` or `"hybrid"`).
    pub method: String,
    /// Inset diameter in degrees (`n/a` for the full method).
    #[serde(with = "na")]
    pub inset_deg: Option<f64>,
    /// Whether silhouette edges were kept.
    pub silhouette_edges: bool,
    /// Target mesh index.
    pub target_mesh: u32,
    /// Target cell row in the search grid.
    pub target_row: u32,
    /// Target cell column in the search grid.
    pub target_col: u32,
    /// Host clock when the search display appeared (µs): when the present
    /// call of its first frame returned.
    pub search_onset_us: u64,
    /// Host clock of the response key (µs).
    pub response_us: u64,
    /// Search time, `(response_us − search_onset_us) / 1e6` (s).
    pub rt_s: f64,
    /// Clicked grid row, when the participant confirmed by clicking.
    #[serde(with = "na")]
    pub clicked_row: Option<u32>,
    /// Clicked grid column.
    #[serde(with = "na")]
    pub clicked_col: Option<u32>,
    /// Whether the click hit the target (`n/a` without a click).
    #[serde(with = "na")]
    pub correct: Option<bool>,
    /// Frames rendered during the search.
    pub frames: u64,
    /// Of those, frames that missed their deadline.
    pub frames_late: u64,
    /// Mean rays cast per frame.
    pub mean_rays: f64,
    /// The participant was simulated.
    pub synthetic: bool,
    /// What drew the search display: the renderer's provenance line
    /// (`pipeline::Renderer::provenance`, e.g. `image on cpu;
    /// passes: none`) of the trial's search frames; should it have changed
    /// during the search, each plan in the order they ran, joined by
    /// ` | `. `n/a` in a file written before the column existed.
    #[serde(default, with = "na")]
    pub plan: Option<String>,
    /// The reference's cell row (`plan::Trial::reference_cell`: the cell
    /// that also holds the target mesh, the seed's centre); `n/a` without
    /// a reference and in a file written before the column existed.
    #[serde(default, with = "na")]
    pub reference_row: Option<u32>,
    /// The reference's cell column.
    #[serde(default, with = "na")]
    pub reference_col: Option<u32>,
    /// Mean triangles drawn per search frame, for the methods that draw
    /// triangles (`simplify`, `lod`, `ulod`); `n/a` for the ray-cast
    /// methods (their cost is `mean_rays`) and in older files.
    #[serde(default, with = "na")]
    pub mean_triangles: Option<f64>,
    /// Mean render time per search frame (ms): the method, its passes and
    /// the full-resolution reference; `n/a` in older files.
    #[serde(default, with = "na")]
    pub mean_render_ms: Option<f64>,
    /// 95th percentile (nearest rank) of the search frames' render times
    /// (ms); `n/a` in older files.
    #[serde(default, with = "na")]
    pub p95_render_ms: Option<f64>,
    /// A practice trial (`Design::practice`: before the first run, never
    /// analysed); `false` in a file written before the column existed
    /// (`n/a` in the rows a resume upgraded).
    #[serde(default, with = "na::flag")]
    pub practice: bool,
}

/// One gaze sample (`samples.tsv`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SampleRow {
    /// The sitting (1 = the session's first run, then one per `--resume`).
    pub sitting: u32,
    /// The tracker's timestamp mapped onto the host clock (µs, host
    /// monotonic clock of the sitting): the sample's time.
    pub mapped_us: u64,
    /// The tracker's own timestamp as decoded (µs, tracker clock); `n/a`
    /// for a tracker that sends none (then `mapped_us` is the arrival).
    #[serde(with = "na")]
    pub device_us: Option<u64>,
    /// Host clock when the sample's bytes arrived (µs): delivery, not
    /// capture — it varies with the machine's load.
    pub arrival_us: u64,
    /// How `device_us` stands against the previous sample's: `first`, `ok`,
    /// `repeated`, `backwards`, `ahead` (not believed: its capture would
    /// follow its arrival by over a second; these three have no valid
    /// interval, and `mapped_us` repeats the previous sample's), `reset` (a device clock reset: a new segment),
    /// `no-device-time`.
    pub time_order: String,
    /// The clock segment within the connection (a reset starts a new one).
    pub segment: u32,
    /// Trial index, `n/a` outside trials.
    #[serde(with = "na")]
    pub trial: Option<usize>,
    /// Runner phase (`"search"`, `"target"`, `"calibration"`, …).
    pub phase: String,
    /// Raw tracker x (tracker units), `n/a` if the tracker gave none.
    #[serde(with = "na")]
    pub raw_x: Option<f64>,
    /// Raw tracker y.
    #[serde(with = "na")]
    pub raw_y: Option<f64>,
    /// Gaze x in display pixels; `n/a` for an invalid sample (blink, lost).
    #[serde(with = "na")]
    pub x_px: Option<f64>,
    /// Gaze y in display pixels (origin top-left, y down).
    #[serde(with = "na")]
    pub y_px: Option<f64>,
    /// The left eye's gaze x in display pixels, when the tracker measures
    /// each eye (a binocular or monocular device, not the mouse or the
    /// attention source) and the eye was tracked; `n/a` otherwise and in
    /// a file written before the per-eye columns.
    #[serde(default, with = "na")]
    pub left_x_px: Option<f64>,
    /// The left eye's gaze y in display pixels.
    #[serde(default, with = "na")]
    pub left_y_px: Option<f64>,
    /// The left eye's pupil size as the tracker reports it (the device's
    /// own units), `n/a` where it reports none.
    #[serde(default, with = "na")]
    pub left_pupil: Option<f64>,
    /// The right eye's gaze x in display pixels (as `left_x_px`).
    #[serde(default, with = "na")]
    pub right_x_px: Option<f64>,
    /// The right eye's gaze y in display pixels.
    #[serde(default, with = "na")]
    pub right_y_px: Option<f64>,
    /// The right eye's pupil size (as `left_pupil`).
    #[serde(default, with = "na")]
    pub right_pupil: Option<f64>,
}

impl SampleRow {
    /// Whether the sample has any per-eye data (a position or a pupil of
    /// either eye).
    pub fn has_eye_data(&self) -> bool {
        self.left_x_px.is_some()
            || self.left_pupil.is_some()
            || self.right_x_px.is_some()
            || self.right_pupil.is_some()
    }

    /// Whether the sample has a time of its own (not a repeated, backwards
    /// or ahead device time, whose `mapped_us` is the previous one's).
    pub fn is_timed(&self) -> bool {
        !matches!(self.time_order.as_str(), "repeated" | "backwards" | "ahead")
    }
}

/// One eye-movement event (`events.tsv`), detected on the tracker's clock
/// (I-VT on device-time intervals, then the congruent-fixation merge).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EventRow {
    /// The sitting.
    pub sitting: u32,
    /// Trial index, `n/a` outside trials.
    #[serde(with = "na")]
    pub trial: Option<usize>,
    /// `"fixation"`, `"saccade"`, `"blink"` or `"lost"`.
    pub kind: String,
    /// Start: the first sample's mapped time (µs, host clock).
    pub onset_us: u64,
    /// End: the last sample's mapped time (µs, host clock).
    pub end_us: u64,
    /// Start on the tracker's clock (µs, device time).
    pub onset_device_us: u64,
    /// End on the tracker's clock (µs, device time).
    pub end_device_us: u64,
    /// Fixation: centroid x; saccade: start x (display px).
    pub x_px: f64,
    /// Fixation: centroid y; saccade: start y.
    pub y_px: f64,
    /// Fixation: equal to `x_px`; saccade: end x.
    pub end_x_px: f64,
    /// Fixation: equal to `y_px`; saccade: end y.
    pub end_y_px: f64,
    /// The event belongs to a practice trial (`Design::practice`); `false`
    /// in a file written before the column existed (`n/a` in the rows a
    /// resume upgraded).
    #[serde(default, with = "na::flag")]
    pub practice: bool,
}

/// One runner marker (`markers.tsv`): phase starts, keys, clicks,
/// calibration results.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MarkerRow {
    /// The sitting.
    pub sitting: u32,
    /// Host clock (µs).
    pub host_us: u64,
    /// Trial index, `n/a` outside trials.
    #[serde(with = "na")]
    pub trial: Option<usize>,
    /// What happened (`"phase"`, `"key"`, `"click"`, `"validation"`, …).
    pub event: String,
    /// Free text (no tabs or line breaks).
    pub detail: String,
}

/// The `event` of the marker a calibration writes when it is fitted and
/// validated: its detail is a [`CalibrationMarker`] as one line of JSON.
pub const CALIBRATION_MARKER: &str = "calibration-fields";

/// What a calibration (fit and validation) leaves for the BIDS export's
/// calibration fields: the detail of a [`CALIBRATION_MARKER`] marker.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CalibrationMarker {
    /// Targets the calibration showed (its plan: 9 for a 3 × 3 grid).
    pub targets: usize,
    /// The targets the fit used, in display pixels (origin top-left).
    pub positions_px: Vec<[f64; 2]>,
    /// Mean accuracy over the validation points with data (degrees of
    /// visual angle).
    pub average_deg: f64,
    /// The worst validation point's accuracy (degrees).
    pub maximal_deg: f64,
}

impl CalibrationMarker {
    /// The marker's detail: one line of JSON (no tab, no line break).
    pub fn to_detail(&self) -> String {
        serde_json::to_string(self).unwrap_or_default()
    }

    /// Reads a marker's detail back; `Err` says why it is not one.
    pub fn from_detail(detail: &str) -> Result<Self, String> {
        let m: Self = serde_json::from_str(detail).map_err(|e| e.to_string())?;
        let finite = m.average_deg.is_finite()
            && m.maximal_deg.is_finite()
            && m.positions_px.iter().flatten().all(|v| v.is_finite());
        if !finite {
            return Err("a value is not finite".into());
        }
        Ok(m)
    }
}

/// One rendered frame (`frames.tsv`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct FrameRow {
    /// The sitting.
    pub sitting: u32,
    /// Host clock when the present call returned (µs).
    pub host_us: u64,
    /// Trial index, `n/a` outside trials.
    #[serde(with = "na")]
    pub trial: Option<usize>,
    /// Runner phase.
    pub phase: String,
    /// Rays cast.
    pub rays: u64,
    /// Render time (ms).
    pub render_ms: f64,
    /// Time since the previous frame (ms), `n/a` for the first.
    #[serde(with = "na")]
    pub interval_ms: Option<f64>,
    /// The frame missed its deadline.
    pub late: bool,
    /// What drew the frame: the provenance line of its renderer
    /// (`pipeline::Renderer::provenance`: method, backend, passes), e.g.
    /// `hybrid on cpu; passes: none`; `n/a` for a screen no renderer drew
    /// (text, calibration targets) and in a file written before the
    /// column existed.
    #[serde(default, with = "na")]
    pub plan: Option<String>,
    /// Bytes the frame's renderer uploaded to the GPU (`write_buffer`,
    /// `write_texture`, buffers made with contents; counted at the `wgpu`
    /// calls, `raycast::gpu::TrafficCounter`); 0 for a search frame shown
    /// again within the gaze tolerance; `n/a` for a frame no GPU renderer
    /// drew (the CPU backend, text and target screens, the preview's copy)
    /// and in a file written before the column existed.
    #[serde(default, with = "na")]
    pub gpu_uploaded_bytes: Option<u64>,
    /// Bytes the frame's renderer read back from the GPU (ranges mapped
    /// for reading); `n/a` as for `gpu_uploaded_bytes`.
    #[serde(default, with = "na")]
    pub gpu_read_back_bytes: Option<u64>,
    /// Compute dispatches the frame's renderer made; `n/a` as above.
    #[serde(default, with = "na")]
    pub gpu_dispatches: Option<u64>,
    /// Draw calls the frame's renderer made (the raster methods); `n/a`
    /// as above.
    #[serde(default, with = "na")]
    pub gpu_draws: Option<u64>,
    /// Queue submissions the frame's renderer made; `n/a` as above.
    #[serde(default, with = "na")]
    pub gpu_submits: Option<u64>,
}

/// One update of the tracker's clock model (`clock.tsv`): how the
/// tracker's clock was mapped onto the host's (tracker-hal `timing`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ClockRow {
    /// The sitting.
    pub sitting: u32,
    /// Samples the model had mapped on this connection.
    pub samples: u64,
    /// The newest sample's device time (µs, tracker clock).
    pub device_us: u64,
    /// Its mapped time (µs, host clock).
    pub mapped_us: u64,
    /// Host µs per tracker µs.
    pub rate: f64,
    /// Tracker-clock drift against the host (ppm; positive: fast).
    pub drift_ppm: f64,
    /// The fitted drift lay beyond the model's bound (a wrong nominal rate).
    pub rate_clamped: bool,
    /// Mapped − device time (µs): the clock offset.
    pub offset_us: f64,
    /// Arrival − mapped time of the newest sample (µs).
    pub delay_us: f64,
    /// Steps back towards an arrival (causality corrections) so far.
    pub corrections: u64,
    /// Samples with a repeated or backwards device time so far.
    pub non_increasing: u64,
    /// Device clock resets so far.
    pub resets: u64,
}

/// A row type of one of the session's TSV files.
pub trait TsvRow: Serialize + DeserializeOwned {
    /// The file name in the session folder.
    const FILE: &'static str;
    /// The header: the serde field names, in order.
    const COLUMNS: &'static [&'static str];
    /// How many of the last [`TsvRow::COLUMNS`] were added after the
    /// file's first version (each `Option` with a serde default). A file
    /// written before has a header that stops short of them: [`read_tsv`](super::read_tsv)
    /// reads its rows with those fields `None`, and [`TsvLog::append_to`](super::TsvLog::append_to)
    /// adds them (`n/a`) to its rows before appending.
    const LATER_COLUMNS: usize = 0;

    /// The header line without its `\n`.
    fn header_line() -> String {
        Self::COLUMNS.join("\t")
    }

    /// How many columns a file with this header line has: all of
    /// [`TsvRow::COLUMNS`] for the current header, fewer for the header of
    /// a file written before the [`TsvRow::LATER_COLUMNS`]; `None` for any
    /// other header.
    fn header_columns(found: &str) -> Option<usize> {
        let all = Self::COLUMNS.len();
        let oldest = all - Self::LATER_COLUMNS.min(all);
        (oldest..=all)
            .rev()
            .find(|&n| n > 0 && found == Self::COLUMNS[..n].join("\t"))
    }
}

impl TsvRow for TrialRow {
    const FILE: &'static str = TRIALS_TSV;
    const COLUMNS: &'static [&'static str] = &[
        "participant",
        "sitting",
        "run",
        "trial",
        "trial_in_run",
        "condition",
        "method",
        "inset_deg",
        "silhouette_edges",
        "target_mesh",
        "target_row",
        "target_col",
        "search_onset_us",
        "response_us",
        "rt_s",
        "clicked_row",
        "clicked_col",
        "correct",
        "frames",
        "frames_late",
        "mean_rays",
        "synthetic",
        "plan",
        "reference_row",
        "reference_col",
        "mean_triangles",
        "mean_render_ms",
        "p95_render_ms",
        "practice",
    ];
    const LATER_COLUMNS: usize = 7;
}

impl TsvRow for SampleRow {
    const FILE: &'static str = SAMPLES_TSV;
    const COLUMNS: &'static [&'static str] = &[
        "sitting",
        "mapped_us",
        "device_us",
        "arrival_us",
        "time_order",
        "segment",
        "trial",
        "phase",
        "raw_x",
        "raw_y",
        "x_px",
        "y_px",
        "left_x_px",
        "left_y_px",
        "left_pupil",
        "right_x_px",
        "right_y_px",
        "right_pupil",
    ];
    const LATER_COLUMNS: usize = 6;
}

impl TsvRow for EventRow {
    const FILE: &'static str = EVENTS_TSV;
    const COLUMNS: &'static [&'static str] = &[
        "sitting",
        "trial",
        "kind",
        "onset_us",
        "end_us",
        "onset_device_us",
        "end_device_us",
        "x_px",
        "y_px",
        "end_x_px",
        "end_y_px",
        "practice",
    ];
    const LATER_COLUMNS: usize = 1;
}

impl TsvRow for ClockRow {
    const FILE: &'static str = CLOCK_TSV;
    const COLUMNS: &'static [&'static str] = &[
        "sitting",
        "samples",
        "device_us",
        "mapped_us",
        "rate",
        "drift_ppm",
        "rate_clamped",
        "offset_us",
        "delay_us",
        "corrections",
        "non_increasing",
        "resets",
    ];
}

impl TsvRow for MarkerRow {
    const FILE: &'static str = MARKERS_TSV;
    const COLUMNS: &'static [&'static str] = &["sitting", "host_us", "trial", "event", "detail"];
}

impl TsvRow for FrameRow {
    const FILE: &'static str = FRAMES_TSV;
    const COLUMNS: &'static [&'static str] = &[
        "sitting",
        "host_us",
        "trial",
        "phase",
        "rays",
        "render_ms",
        "interval_ms",
        "late",
        "plan",
        "gpu_uploaded_bytes",
        "gpu_read_back_bytes",
        "gpu_dispatches",
        "gpu_draws",
        "gpu_submits",
    ];
    const LATER_COLUMNS: usize = 6;
}
