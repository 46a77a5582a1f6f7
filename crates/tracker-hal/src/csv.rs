//! The sample CSV written by `gazecast replay` and by the simulator's
//! expected outputs.

use crate::sample::GazeSample;

/// The header line, exactly.
pub const CSV_HEADER: &str =
    "seq,device_time_us,host_time_us,left_x,left_y,left_valid,right_x,right_y,right_valid,gaze_x,gaze_y,gaze_valid";

/// One row. `map` converts tracker units to the output units (identity for
/// `--raw`). Missing eyes and gaze have empty coordinates and valid = 0.
pub fn csv_row(s: &GazeSample, map: &dyn Fn([f64; 2]) -> Option<[f64; 2]>) -> String {
    let point = |p: Option<[f64; 2]>| match p.and_then(map) {
        Some([x, y]) => format!("{x},{y},1"),
        None => ",,0".to_string(),
    };
    let device = s.device_time_us.map(|t| t.to_string()).unwrap_or_default();
    format!(
        "{},{},{},{},{},{}",
        s.seq,
        device,
        s.host_time_us,
        point(s.left.position),
        point(s.right.position),
        point(s.gaze())
    )
}
