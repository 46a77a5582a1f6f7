//! Real serial ports through the `serialport` crate.

use std::time::Duration;

use crate::error::{Error, Result};

/// Opens `path` at `baud`, 8N1, with a read timeout (a read that waits longer
/// returns [`ErrorKind::TimedOut`](crate::ErrorKind::TimedOut) from the driver).
pub fn open(path: &str, baud: u32, timeout: Duration) -> Result<Box<dyn serialport::SerialPort>> {
    serialport::new(path, baud)
        .data_bits(serialport::DataBits::Eight)
        .parity(serialport::Parity::None)
        .stop_bits(serialport::StopBits::One)
        .flow_control(serialport::FlowControl::None)
        .timeout(timeout)
        .open()
        .map_err(|e| {
            let kind = match e.kind() {
                serialport::ErrorKind::NoDevice => crate::ErrorKind::Disconnected,
                serialport::ErrorKind::InvalidInput => crate::ErrorKind::Config,
                _ => crate::ErrorKind::Io,
            };
            Error::new(
                kind,
                format!("cannot open serial port {path} at {baud} baud: {e}"),
            )
        })
}

/// The serial ports this machine has, one line each (name and type). An
/// empty list is not an error.
pub fn list_ports() -> Result<Vec<String>> {
    let ports = serialport::available_ports().map_err(|e| {
        Error::new(
            crate::ErrorKind::Io,
            format!("cannot list serial ports: {e}"),
        )
    })?;
    Ok(ports
        .into_iter()
        .map(|p| {
            let kind = match p.port_type {
                serialport::SerialPortType::UsbPort(u) => format!(
                    "USB {:04x}:{:04x} {} {}",
                    u.vid,
                    u.pid,
                    u.manufacturer.unwrap_or_default(),
                    u.product.unwrap_or_default()
                ),
                serialport::SerialPortType::PciPort => "PCI".into(),
                serialport::SerialPortType::BluetoothPort => "Bluetooth".into(),
                serialport::SerialPortType::Unknown => "unknown".into(),
            };
            format!("{}\t{}", p.port_name, kind.trim())
        })
        .collect())
}
