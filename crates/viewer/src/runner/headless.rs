//! `experiment run --headless`: the session without a window, on a
//! virtual clock. The same runner runs the same screens (flow, calibration
//! and validation, trials), renders the same stimuli with the same
//! renderer and writes the same files; what differs is only who keeps
//! time and who looks:
//!
//! - the clock is virtual ([`RunClock::Virtual`]): it starts at
//!   [`START_US`], the sitting's host anchor (paired with the wall clock
//!   when the sitting began), and moves one refresh period ([`NOMINAL_REFRESH_HZ`])
//!   per frame, however long the frame took to render;
//! - the simulated participant is stepped once per frame at the frame's
//!   virtual time ([`super::participant::Participant::step`]) instead of
//!   on its own thread;
//! - the tracker is the mouse emulator ticked on the same clock
//!   (`tracker_hal::virtual_mouse`): every tick up to the frame's time is
//!   delivered before the frame, with its record bytes in the session's
//!   recording.
//!
//! A session so runs in the time its frames take to render, not in the
//! time a person would take, and its samples and events do not depend on
//! the machine. Every file says so: the session is synthetic (a simulated
//! participant) and its sitting's device clock names the virtual clock.

use crossbeam_channel::Sender;
use tracker_hal::mouse::CursorEvent;
use tracker_hal::supervisor::TrackerMsg;
use tracker_hal::virtual_mouse::VirtualMouse;

use super::state::{RunClock, Runner, NOMINAL_REFRESH_HZ};

/// The longest one screen may last on the virtual clock before the
/// simulation is declared stuck (a participant who never ends a screen
/// would otherwise loop for ever): ten virtual minutes.
pub(super) const STUCK_AFTER_US: u64 = 600_000_000;

/// Where a headless sitting's virtual clock starts (µs): the sitting's
/// host anchor, paired with the wall clock when the sitting began. A fixed
/// start makes two runs of one simulation write the same times.
pub(super) const START_US: u64 = 1_000_000;

/// What `session.json` says of a headless sitting's clock.
pub(super) const VIRTUAL_CLOCK: &str = "virtual clock of a headless simulation (gazecast experiment run --headless): device, arrival and mapped times are the simulation's time, which starts at the sitting's host anchor (1 s) and advances one refresh period per frame";

/// Runs the session's frames on the virtual clock until it ends, is
/// stopped (Ctrl-C, SIGTERM) or fails; errors are left in
/// `runner.error`.
pub(super) fn run(runner: &mut Runner<'_>, mut device: VirtualMouse, tx: &Sender<TrackerMsg>) {
    let period_us = (1e6 / NOMINAL_REFRESH_HZ).round() as u64;
    let mut samples = Vec::new();
    while !runner.quitting {
        if crate::interrupt::interrupted() {
            runner.say("interrupted (Ctrl-C or SIGTERM): ending the session");
            runner.quit();
            break;
        }
        let now = runner.now();
        if now.saturating_sub(runner.phase_since_us) > STUCK_AFTER_US {
            runner.error.get_or_insert(format!(
                "the simulated session stayed on the {} screen for {} virtual minutes: stopped",
                runner.flow.phase().name(),
                STUCK_AFTER_US / 60_000_000
            ));
            break;
        }
        if let Some(p) = &runner.participant {
            for (t_us, position_px) in p.step(now) {
                device.cursor(CursorEvent {
                    t_us,
                    position_px,
                    blink: false,
                });
            }
        }
        device.advance_to(now, &mut samples);
        for m in samples.drain(..) {
            let _ = tx.send(m);
        }
        if let Err(e) = runner.frame() {
            runner.error.get_or_insert(e);
            break;
        }
        if runner.error.is_some() {
            break;
        }
        runner.clock = RunClock::Virtual(now + period_us);
    }
    runner.feed.set_faults(device.faults());
}
