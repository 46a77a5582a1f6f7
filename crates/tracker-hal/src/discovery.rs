//! Finding trackers: USB devices of known eye-tracker vendors (`rusb`) and
//! HID interfaces with an Eye Tracker collection (`hidapi`, usage page 0x12).
//! Machines without USB (containers, CI) get an error message, not a panic,
//! and so does a build without the `hid-usb` feature (on by default).

/// USB vendors whose devices are eye trackers.
pub const KNOWN_VENDORS: &[(u16, &str)] = &[(0x2104, "Tobii")];

/// What a build without the `hid-usb` feature says instead of a list.
#[cfg(not(feature = "hid-usb"))]
const NO_HID_USB: &str = "built without the `hid-usb` feature of tracker-hal";

/// USB devices of [`KNOWN_VENDORS`], one line each.
#[cfg(not(feature = "hid-usb"))]
pub fn usb_trackers() -> Result<Vec<String>, String> {
    Err(format!("USB unavailable: {NO_HID_USB}"))
}

/// HID interfaces with usage page 0x12 (what the `TobiiHid` driver opens).
#[cfg(not(feature = "hid-usb"))]
pub fn hid_trackers() -> Result<Vec<String>, String> {
    Err(format!("HID unavailable: {NO_HID_USB}"))
}

/// USB devices of [`KNOWN_VENDORS`], one line each.
#[cfg(feature = "hid-usb")]
pub fn usb_trackers() -> Result<Vec<String>, String> {
    use rusb::UsbContext;
    // `rusb::Context::new()`, not the global context, which panics where
    // there is no USB.
    let context = rusb::Context::new().map_err(|e| format!("USB unavailable: {e}"))?;
    let devices = context
        .devices()
        .map_err(|e| format!("cannot list USB devices: {e}"))?;
    let mut out = Vec::new();
    for d in devices.iter() {
        let Ok(desc) = d.device_descriptor() else {
            continue;
        };
        if let Some((_, vendor)) = KNOWN_VENDORS.iter().find(|(id, _)| *id == desc.vendor_id()) {
            out.push(format!(
                "{vendor} {:04x}:{:04x} on bus {} address {}",
                desc.vendor_id(),
                desc.product_id(),
                d.bus_number(),
                d.address()
            ));
        }
    }
    Ok(out)
}

/// HID interfaces with usage page 0x12 (what the `TobiiHid` driver opens).
#[cfg(feature = "hid-usb")]
pub fn hid_trackers() -> Result<Vec<String>, String> {
    let api = hidapi::HidApi::new().map_err(|e| format!("HID unavailable: {e}"))?;
    Ok(api
        .device_list()
        .filter(|d| d.usage_page() == crate::hid::PAGE)
        .map(|d| {
            format!(
                "{:04x}:{:04x} {} {} ({})",
                d.vendor_id(),
                d.product_id(),
                d.manufacturer_string().unwrap_or("?"),
                d.product_string().unwrap_or("?"),
                d.path().to_string_lossy()
            )
        })
        .collect())
}
