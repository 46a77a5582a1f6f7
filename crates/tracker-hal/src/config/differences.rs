//! Where two tracker configurations disagree, field by field: what a
//! replay checks a `--tracker` file against a recording's header with, and
//! what a resumed session checks its tracker against the first sitting's.
//!
//! Nothing here names the fields that are compared: both sides are
//! serialised (serde, as JSON values) and walked generically, so a field
//! added to any driver's settings is compared without a change here. The
//! only field names written out are the two lists of driver settings left
//! out on purpose ([`LIVE_ONLY`], [`CONNECTION_ONLY`]): a policy, checked
//! by a test against the fields the driver types really have.

use serde_json::{Map, Value};

use super::TrackerConfig;

/// Driver settings that say how a live device is reached or emulated, not
/// what recorded bytes mean: a replay does not compare them with the
/// recording's header (the port it was on; the mouse emulation's realism,
/// already in the recorded stream; which USB device, and its read timeout).
pub const LIVE_ONLY: &[&str] = &[
    "port",
    "jitter_rms_deg",
    "saccades",
    "saccade_threshold_deg",
    "latency_ms",
    "seed",
    "vendor_id",
    "product_id",
    "timeout_ms",
];

/// How a device is reached (its port, which USB device, a read timeout):
/// what may change between the sittings of one session.
pub const CONNECTION_ONLY: &[&str] = &["port", "vendor_id", "product_id", "timeout_ms"];

/// Where `given` (a `--tracker` file) disagrees with a recording's `header`
/// tracker, one line a field: `driver.baud: header 115200, --tracker 19200`
/// (fields named as in the tracker file; [`LIVE_ONLY`] settings are not
/// compared). Empty when they agree.
pub fn tracker_differences(header: &TrackerConfig, given: &TrackerConfig) -> Vec<String> {
    tracker_differences_except(header, given, LIVE_ONLY)
}

/// [`tracker_differences`], leaving out the driver settings in `ignore`.
pub fn tracker_differences_except(
    header: &TrackerConfig,
    given: &TrackerConfig,
    ignore: &[&str],
) -> Vec<String> {
    if header.driver_name() != given.driver_name() {
        return vec![format!(
            "driver: header {}, --tracker {}",
            header.driver_name(),
            given.driver_name()
        )];
    }
    let mut out = Vec::new();
    match (serde_json::to_value(header), serde_json::to_value(given)) {
        (Ok(a), Ok(b)) => json_differences("", &a, &b, ignore, &mut out),
        _ if header != given => out.push("the tracker configuration differs".into()),
        _ => {}
    }
    out
}

/// Appends a line for every leaf where `a` and `b` differ under `path`
/// (dotted); `ignore` names fields directly under `driver`.
fn json_differences(path: &str, a: &Value, b: &Value, ignore: &[&str], out: &mut Vec<String>) {
    let join = |k: &str| {
        if path.is_empty() {
            k.to_string()
        } else {
            format!("{path}.{k}")
        }
    };
    match (a, b) {
        (Value::Object(x), Value::Object(y)) => {
            // An enum variant (`Iscan(...)`, `Frame(...)`): the same variant
            // on both sides is compared field by field under the same name.
            if let (Some((kx, vx)), Some((ky, vy))) = (variant(x), variant(y)) {
                if kx == ky {
                    return json_differences(path, vx, vy, ignore, out);
                }
            }
            let mut keys: Vec<&String> = x.keys().chain(y.keys()).collect();
            keys.sort();
            keys.dedup();
            for k in keys {
                if path == "driver" && ignore.contains(&k.as_str()) {
                    continue;
                }
                json_differences(
                    &join(k),
                    x.get(k).unwrap_or(&Value::Null),
                    y.get(k).unwrap_or(&Value::Null),
                    ignore,
                    out,
                );
            }
        }
        _ if a != b => out.push(format!(
            "{}: header {}, --tracker {}",
            if path.is_empty() { "tracker" } else { path },
            show_json(a),
            show_json(b)
        )),
        _ => {}
    }
}

/// The variant and its value when `m` is an enum value: serde writes an
/// externally tagged variant as a one-entry map keyed by its name
/// (`{"Iscan": ...}`), and variant names are capitalised where field names
/// are snake case.
fn variant(m: &Map<String, Value>) -> Option<(&String, &Value)> {
    if m.len() != 1 {
        return None;
    }
    m.iter()
        .next()
        .filter(|(k, _)| k.starts_with(|c: char| c.is_ascii_uppercase()))
}

/// A value as the tracker file spells it, near enough: unit variants bare,
/// `None` for a missing option.
fn show_json(v: &Value) -> String {
    match v {
        Value::Null => "None".into(),
        Value::String(s) => s.clone(),
        other => other.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The shipped tracker files, one per driver at least.
    fn shipped() -> Vec<TrackerConfig> {
        let dir = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../config/trackers");
        let mut out = Vec::new();
        for e in std::fs::read_dir(&dir).expect("config/trackers") {
            let path = e.expect("entry").path();
            if path.extension().is_some_and(|x| x == "ron") {
                let text = std::fs::read_to_string(&path).expect("read");
                out.push(ron::from_str(&text).unwrap_or_else(|e| panic!("{path:?}: {e}")));
            }
        }
        out
    }

    /// The names of every driver's settings, as serde writes them.
    fn driver_fields(trackers: &[TrackerConfig]) -> Vec<String> {
        let mut names = Vec::new();
        for t in trackers {
            let v = serde_json::to_value(&t.driver).expect("serialise");
            if let Some((_, Value::Object(fields))) = v.as_object().and_then(variant) {
                names.extend(fields.keys().cloned());
            }
        }
        names
    }

    /// The two policy lists name fields the drivers have: a renamed field
    /// would otherwise be compared again without anyone noticing.
    #[test]
    fn the_ignored_settings_are_driver_fields() {
        let trackers = shipped();
        let names: Vec<&str> = trackers.iter().map(TrackerConfig::driver_name).collect();
        for d in ["iscan", "mouse", "tobii-hid", "attention", "lsl"] {
            assert!(names.contains(&d), "no shipped {d} tracker file");
        }
        let fields = driver_fields(&trackers);
        for name in LIVE_ONLY.iter().chain(CONNECTION_ONLY) {
            assert!(
                fields.iter().any(|f| f == name),
                "{name} is no driver setting"
            );
        }
        for name in CONNECTION_ONLY {
            assert!(LIVE_ONLY.contains(name), "{name}");
        }
    }

    #[test]
    fn every_field_is_compared_and_named_by_its_path() {
        let iscan = shipped()
            .into_iter()
            .find(|t| matches!(&t.driver, crate::config::Driver::Iscan(_)))
            .expect("an ISCAN file");
        assert!(tracker_differences(&iscan, &iscan).is_empty());
        let mut other = iscan.clone();
        if let crate::config::Driver::Iscan(c) = &mut other.driver {
            c.baud += 1;
            c.port = Some("/dev/elsewhere".into());
        }
        let d = tracker_differences(&iscan, &other);
        assert_eq!(d.len(), 1, "{d:?}");
        assert!(d[0].starts_with("driver.baud: header "), "{d:?}");
        let d = tracker_differences_except(&iscan, &other, &[]);
        assert_eq!(d.len(), 2, "{d:?}");
        assert!(
            d.iter().any(|l| l.starts_with("driver.port: header ")),
            "{d:?}"
        );
    }
}
