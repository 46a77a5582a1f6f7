//! The sample CSV written by `gazecast replay` and by the simulator's
//! expected outputs. Each row has the sample's three times
//! ([`crate::timing`]): `device_time_us` (the tracker's clock, as
//! decoded), `host_time_us` (host arrival), `mapped_time_us` (the device
//! time on the host clock) and `time_order` ([`crate::timing::TimeOrder::name`]).

use crate::sample::GazeSample;

/// The header line, exactly.
pub const CSV_HEADER: &str =
    "seq,device_time_us,host_time_us,mapped_time_us,time_order,left_x,left_y,left_valid,right_x,right_y,right_valid,gaze_x,gaze_y,gaze_valid";

/// One row. `map` converts tracker units to the output units (identity for
/// `--raw`). Missing eyes and gaze have empty coordinates and valid = 0.
pub fn csv_row(s: &GazeSample, map: &dyn Fn([f64; 2]) -> Option<[f64; 2]>) -> String {
    let point = |p: Option<[f64; 2]>| match p.and_then(map) {
        Some([x, y]) => format!("{x},{y},1"),
        None => ",,0".to_string(),
    };
    let device = s.device_time_us.map(|t| t.to_string()).unwrap_or_default();
    format!(
        "{},{},{},{},{},{},{},{}",
        s.seq,
        device,
        s.host_time_us,
        s.mapped_time_us,
        s.time_order.name(),
        point(s.left.position),
        point(s.right.position),
        point(s.gaze())
    )
}

/// Most rows [`parse_gaze`] reads: 10 million samples (a day at 120 Hz).
pub const MAX_ROWS: usize = 10_000_000;

/// One row of a sample CSV as an analysis reads it: its time and the
/// combined gaze (screen px), `None` where the row says it is invalid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GazeRow {
    /// The mapped device time (host clock, µs; `mapped_time_us`), or the
    /// arrival time (`host_time_us`) in a CSV without mapped times.
    pub time_us: u64,
    /// The combined gaze, screen px; `None` where the row says it is invalid.
    pub gaze: Option<[f64; 2]>,
}

/// A sample CSV read back: its rows and its comment lines (lines that start
/// with `#`, before or between rows, without the `#`), which say where the
/// data came from (a synthesised session says so there).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct GazeCsv {
    /// The comment lines, without their `#`.
    pub notes: Vec<String>,
    /// The rows, in file order.
    pub rows: Vec<GazeRow>,
}

/// Why a sample CSV cannot be read: the line (1-based) and the column.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("line {line}: {field}: {message}")]
pub struct CsvError {
    /// 1-based line number.
    pub line: usize,
    /// The column (header name) the error is about.
    pub field: String,
    /// What is wrong.
    pub message: String,
}

/// Reads the CSV [`csv_row`] writes (the header [`CSV_HEADER`] first; the
/// columns are found by name, so extra columns are allowed). The time is
/// `mapped_time_us` where the header has it, else `host_time_us`; times
/// must not go backwards; a valid gaze must be finite. At most
/// [`MAX_ROWS`] rows.
pub fn parse_gaze(text: &str) -> Result<GazeCsv, CsvError> {
    let err = |line: usize, field: &str, message: String| CsvError {
        line,
        field: field.to_string(),
        message,
    };
    let mut out = GazeCsv::default();
    let mut columns: Option<[usize; 4]> = None;
    let mut time_field = "host_time_us";
    let mut width = 0;
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let raw = raw.trim_end_matches('\r');
        if let Some(note) = raw.strip_prefix('#') {
            out.notes.push(note.trim().to_string());
            continue;
        }
        if raw.trim().is_empty() {
            continue;
        }
        let cells: Vec<&str> = raw.split(',').map(str::trim).collect();
        let Some([t, x, y, v]) = columns else {
            let find = |name: &str| {
                cells.iter().position(|c| *c == name).ok_or_else(|| {
                    err(
                        line,
                        name,
                        format!("the header has no `{name}` column (expected {CSV_HEADER})"),
                    )
                })
            };
            let time = match cells.iter().position(|c| *c == "mapped_time_us") {
                Some(k) => {
                    time_field = "mapped_time_us";
                    k
                }
                None => find("host_time_us")?,
            };
            columns = Some([time, find("gaze_x")?, find("gaze_y")?, find("gaze_valid")?]);
            width = cells.len();
            continue;
        };
        if cells.len() != width {
            return Err(err(
                line,
                "row",
                format!("{} columns where the header has {width}", cells.len()),
            ));
        }
        if out.rows.len() >= MAX_ROWS {
            return Err(err(line, "row", format!("more than {MAX_ROWS} rows")));
        }
        let time_us: u64 = cells[t].parse().map_err(|_| {
            err(
                line,
                time_field,
                format!("`{}` is not a whole number of µs", cells[t]),
            )
        })?;
        if let Some(last) = out.rows.last() {
            if time_us < last.time_us {
                return Err(err(
                    line,
                    time_field,
                    format!("{time_us} goes back from {}", last.time_us),
                ));
            }
        }
        let valid = match cells[v] {
            "1" => true,
            "0" => false,
            other => return Err(err(line, "gaze_valid", format!("`{other}` must be 0 or 1"))),
        };
        let gaze = if valid {
            let num = |k: usize, name: &str| -> Result<f64, CsvError> {
                let s = cells[k];
                s.parse::<f64>()
                    .ok()
                    .filter(|f| f.is_finite())
                    .ok_or_else(|| err(line, name, format!("`{s}` is not a finite number")))
            };
            Some([num(x, "gaze_x")?, num(y, "gaze_y")?])
        } else {
            None
        };
        out.rows.push(GazeRow { time_us, gaze });
    }
    if columns.is_none() {
        return Err(err(
            text.lines().count().max(1),
            "header",
            format!("no header line (expected {CSV_HEADER})"),
        ));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_back_what_it_writes_and_names_bad_lines() {
        let text = format!(
            "# synthetic\n{CSV_HEADER}\n0,,100,90,first,,,0,,,0,10.5,20,1\n1,,200,190,ok,,,0,,,0,,,0\n"
        );
        let csv = parse_gaze(&text).expect("parses");
        assert_eq!(csv.notes, vec!["synthetic".to_string()]);
        assert_eq!(
            csv.rows,
            vec![
                GazeRow {
                    time_us: 90,
                    gaze: Some([10.5, 20.0])
                },
                GazeRow {
                    time_us: 190,
                    gaze: None
                }
            ]
        );
        let back =
            format!("{CSV_HEADER}\n0,,100,100,ok,,,0,,,0,1,2,1\n1,,50,50,ok,,,0,,,0,1,2,1\n");
        let e = parse_gaze(&back).unwrap_err();
        assert_eq!((e.line, e.field.as_str()), (3, "mapped_time_us"));
        // A CSV of an earlier version (no mapped times): arrival times.
        let old = "seq,device_time_us,host_time_us,gaze_x,gaze_y,gaze_valid\n0,,100,1,2,1\n";
        assert_eq!(parse_gaze(old).expect("old").rows[0].time_us, 100);
        let nan = format!("{CSV_HEADER}\n0,,100,100,ok,,,0,,,0,NaN,2,1\n");
        assert_eq!(parse_gaze(&nan).unwrap_err().field, "gaze_x");
        let short = format!("{CSV_HEADER}\n0,,100,1,2,1\n");
        assert_eq!(parse_gaze(&short).unwrap_err().line, 2);
        assert_eq!(parse_gaze("").unwrap_err().field, "header");
        assert_eq!(parse_gaze("a,b\n").unwrap_err().field, "host_time_us");
        let flag = format!("{CSV_HEADER}\n0,,100,100,ok,,,0,,,0,1,2,yes\n");
        assert_eq!(parse_gaze(&flag).unwrap_err().field, "gaze_valid");
    }
}
