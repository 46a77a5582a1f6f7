//! One error type for every operation of every gaze source (the
//! `embedded-hal` `ErrorType` idea): generic code handles one kind enum.

/// What went wrong, independent of the device.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum ErrorKind {
    /// The device or transport went away (unplugged, closed, I/O error).
    Disconnected,
    /// No data arrived within the transport's timeout. The source is still
    /// usable: call again.
    TimedOut,
    /// Data could not be understood. Decoders normally resynchronise and
    /// count instead; this kind is for data that cannot be skipped (a
    /// recording's header, a corrupt chunk).
    InvalidData,
    /// The operation is not supported by this device or configuration.
    Unsupported,
    /// A configuration value is unusable.
    Config,
    /// Any other I/O failure (files, pipes).
    Io,
}

/// An error with its kind and a message a person can act on.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{message}")]
pub struct Error {
    /// What went wrong, for the caller's decision (retry, reopen, give up).
    pub kind: ErrorKind,
    /// What happened, for a person.
    pub message: String,
}

impl Error {
    /// An error of `kind` saying `message`.
    pub fn new(kind: ErrorKind, message: impl Into<String>) -> Self {
        Self {
            kind,
            message: message.into(),
        }
    }

    /// Classifies an I/O error from a transport.
    pub fn from_io(context: &str, e: &std::io::Error) -> Self {
        use std::io::ErrorKind as K;
        let kind = match e.kind() {
            K::TimedOut | K::WouldBlock => ErrorKind::TimedOut,
            K::BrokenPipe
            | K::ConnectionReset
            | K::ConnectionAborted
            | K::NotConnected
            | K::UnexpectedEof => ErrorKind::Disconnected,
            K::NotFound | K::PermissionDenied => ErrorKind::Disconnected,
            _ => ErrorKind::Io,
        };
        Self::new(kind, format!("{context}: {e}"))
    }
}

/// The crate's result type: [`Error`] by default.
pub type Result<T, E = Error> = std::result::Result<T, E>;
