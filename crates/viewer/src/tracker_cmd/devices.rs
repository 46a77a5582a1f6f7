//! `gazecast devices`: the serial ports, USB eye trackers and HID
//! eye-tracker interfaces this machine has.

use std::io::Write;

/// Runs `gazecast devices`.
pub fn devices(out: &mut dyn Write) -> Result<(), String> {
    let ports = tracker_hal::serial::list_ports()
        .unwrap_or_else(|e| vec![format!("(serial ports unavailable: {e})")]);
    let w = |out: &mut dyn Write, s: &str| writeln!(out, "{s}").map_err(|e| e.to_string());
    w(out, "serial ports:")?;
    if ports.is_empty() {
        w(out, "  (none found)")?;
    }
    for p in ports {
        w(out, &format!("  {p}"))?;
    }
    for (title, found) in [
        (
            "USB eye trackers (known vendors: Tobii 0x2104):",
            tracker_hal::discovery::usb_trackers(),
        ),
        (
            "HID eye trackers (usage page 0x12):",
            tracker_hal::discovery::hid_trackers(),
        ),
    ] {
        w(out, title)?;
        match found {
            Ok(list) if list.is_empty() => w(out, "  (none found)")?,
            Ok(list) => {
                for d in list {
                    w(out, &format!("  {d}"))?;
                }
            }
            Err(e) => w(out, &format!("  ({e})"))?,
        }
    }
    Ok(())
}
