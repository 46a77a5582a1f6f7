//! What running a session decides, apart from any window, renderer or
//! tracker device: the order of screens, the stimuli, the design's checks
//! on the display, the simulated participant's behaviour and what a
//! finished trial records. The `gazecast` binary's runner shows the
//! screens, renders the stimuli and writes the files.
//!
//! - [`flow`]: the order of screens in a session;
//! - [`layout`]: the search grid on the display;
//! - [`stimulus`]: a trial's search display and target preview as scenes;
//! - [`on_display`]: the stimuli checked on the display;
//! - [`design_check`]: the one check `experiment plan` and `experiment run`
//!   share, and the calibration plans it derives;
//! - [`acceptance`]: whether a calibration, validation or drift check is
//!   good enough;
//! - [`participant`]: the simulated participant's behaviour;
//! - [`observer`]: the search model whose observer sees what is rendered;
//! - [`trial_result`]: a finished trial's eye-movement events and click.

pub mod acceptance;
pub mod design_check;
pub mod flow;
pub mod layout;
pub mod observer;
pub mod on_display;
pub mod participant;
pub mod stimulus;
pub mod trial_result;

/// The seed's design and display, for this module's tests.
#[cfg(test)]
pub(crate) mod test_support {
    use crate::Design;
    use screen_geometry::ScreenGeometry;

    /// `config/experiments/murphy2007-search.ron`.
    pub fn murphy() -> Design {
        Design::load(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../config/experiments/murphy2007-search.ron"
        ))
        .expect("design")
    }

    /// The seed's 17-inch display at 1280×1024.
    pub fn seed_display() -> ScreenGeometry {
        screen_geometry::Display::seed_17in(1280, 1024)
            .geometry()
            .expect("geometry")
    }
}
