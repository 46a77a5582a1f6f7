//! `experiment run` from its options to the end of the sitting: the
//! display and design checked, the tracker (or the simulated participant's
//! pseudo-terminal) set up, the session folder opened or resumed, the
//! event loop run, and everything closed in order.

use std::io::Write;
use std::path::Path;

use experiment::run::design_check::Checked;
use experiment::run::flow::Flow;
use experiment::session::MarkerRow;
use tracker_hal::clock::monotonic_us;
use winit::event_loop::EventLoop;

use super::design_check::check_design;
use super::headless;
use super::options::RunOptions;
use super::participant::{self, Participant};
use super::session_dir::SessionDir;
use super::setup::Setup;
use super::state::{RunClock, Runner, NOMINAL_REFRESH_HZ};
use crate::gaze_feed::GazeSetup;

/// Runs (or resumes) a session to its end or until it is stopped.
pub fn run(opts: &RunOptions, out: &mut dyn Write) -> Result<(), String> {
    let display = crate::config::load_display(&opts.display).map_err(|e| e.to_string())?;
    let geometry = display.geometry().map_err(|e| e.to_string())?;
    let index = match opts.participant_index {
        Some(i) => i,
        None => experiment::index_from_id(&opts.participant).ok_or_else(|| {
            format!(
                "--participant {:?} ends in no number ≥ 1 to take the counterbalancing row from; give --participant-index N",
                opts.participant
            )
        })?,
    };
    // The design on this display, before any folder or window exists.
    let (design, checked) =
        crate::config::load_design_checked(&opts.design, |d| check_design(d, index, &geometry))
            .map_err(|e| e.to_string())?;
    // The design's participant thresholds, relative to its folder.
    let thresholds = match &design.thresholds {
        None => None,
        Some(p) => {
            let path = opts.design.parent().unwrap_or(Path::new(".")).join(p);
            Some(
                crate::args::Thresholds::load(&path)
                    .map_err(|e| format!("{}: field `thresholds`: {e}", opts.design.display()))?,
            )
        }
    };
    let Checked {
        trials,
        layout,
        model,
        cal_plans,
        drift_plan,
    } = checked;
    let mut setup_gaze = GazeSetup::resolve(opts.tracker.as_deref(), None)?;
    // The simulated participant's ISCAN: a pseudo-terminal whose slave the
    // tracker opens in place of the file's port.
    let mut iscan_master = None;
    if opts.headless && (opts.simulate.is_none() || !setup_gaze.is_mouse()) {
        return Err("--headless runs a simulated participant (--simulate-participant SEED) on the mouse tracker (--tracker config/trackers/mouse.ron): without a window there is no one else to look".into());
    }
    if opts.simulate.is_some() && !opts.headless {
        match &mut setup_gaze.tracker.driver {
            tracker_hal::Driver::Mouse(_) => {}
            tracker_hal::Driver::Iscan(c) => {
                use serialport::SerialPort;
                let (master, slave) =
                    serialport::TTYPort::pair().map_err(|e| format!("a pseudo-terminal for the simulated ISCAN: {e}"))?;
                let name = slave
                    .name()
                    .ok_or("the simulated ISCAN's pseudo-terminal has no name")?;
                drop(slave); // the port is opened exclusively, by path
                c.port = Some(name);
                iscan_master = Some((master, c.clone()));
            }
            _ => {
                return Err("--simulate-participant drives a Mouse or an ISCAN tracker file (config/trackers/mouse.ron, iscan-binary.ron)".into())
            }
        }
    }
    let observer = match &opts.participant_model {
        Some(p) => Some(crate::config::load_observer(p).map_err(|e| e.to_string())?),
        None => None,
    };
    let mut dir = SessionDir::open(opts, &design, &display, index, &setup_gaze)?;
    // The session's clock: the host's, or a virtual one from its start.
    let clock = if opts.headless {
        RunClock::Virtual(headless::START_US)
    } else {
        RunClock::Host
    };
    let now = || match clock {
        RunClock::Host => monotonic_us(),
        RunClock::Virtual(t) => t,
    };
    let suffix = format!(
        "{}-{}",
        crate::lsl_out::id_part(&design.name),
        crate::lsl_out::id_part(&opts.participant)
    );
    if let Some(o) = opts.lsl.options("experiment", suffix, true) {
        let (outlets, lines) = crate::lsl_out::Outlets::open(&o)?;
        for l in lines {
            let _ = writeln!(out, "{l}");
        }
        dir.attach_lsl(outlets);
    }
    for line in dir.upgraded().to_vec() {
        let _ = writeln!(out, "{}: {line}", dir.path().display());
        dir.marker(&MarkerRow {
            sitting: dir.sitting(),
            host_us: now(),
            trial: None,
            event: "file-columns-added".into(),
            detail: line,
        });
    }
    let start = dir.next_trial();
    if let Some((trial, sitting)) = dir.aborted_trial().filter(|(t, _)| *t < trials.len()) {
        // The trial the last sitting did not finish runs again now: its
        // rows there are aborted (the analysis and the export leave them out).
        dir.marker(&MarkerRow {
            sitting: dir.sitting(),
            host_us: now(),
            trial: Some(trial),
            event: "aborted-trial".into(),
            detail: format!(
                "trial {} was not finished in sitting {sitting}; it runs again in this sitting, its rows of sitting {sitting} are aborted",
                trial + 1
            ),
        });
    }
    if start >= trials.len() {
        return Err(format!(
            "{}: every trial ({}) is done; nothing to resume",
            dir.path().display(),
            trials.len()
        ));
    }
    let setup = Setup {
        layout,
        design,
        geometry,
        backend: opts.backend,
        fullscreen: opts.fullscreen,
        monitor: opts.monitor,
        max_trials: opts.max_trials,
        stimulus_pictures: opts.stimulus_pictures,
        screenshots: opts.screenshots.clone(),
        cal_plans,
        drift_plan,
        model,
        gaze_tolerance_deg: opts.gaze_tolerance_deg,
        observer,
        thresholds,
    };
    if let Some(d) = &opts.screenshots {
        std::fs::create_dir_all(d).map_err(|e| format!("--screenshots {}: {e}", d.display()))?;
    }
    let event_loop = if opts.headless {
        None
    } else {
        crate::screen::close_recordings_if_the_x_server_goes();
        Some(EventLoop::new().map_err(|e| format!("cannot open a window ({}); the experiment needs a display (run under Xvfb on a machine without one, or --headless with a simulated participant)", crate::screen::plain_error(&e)))?)
    };
    crate::interrupt::catch_interrupts();
    let record = dir.recording_path();
    let setup_gaze = setup_gaze.with_screen(setup.geometry.size_px());
    let record = Some((record.as_path(), display.name.as_str()));
    let start_us = now();
    let (feed, mut virtual_tracker) = if opts.headless {
        let (feed, device, tx) = setup_gaze.virtual_mouse(start_us, record)?;
        (feed, Some((device, tx)))
    } else {
        (setup_gaze.spawn(None, record)?, None)
    };
    let size_px = (setup.geometry.width_px, setup.geometry.height_px);
    let participant = match (opts.simulate, iscan_master) {
        (Some(seed), _) if opts.headless => Some(Participant::inline(
            setup.geometry,
            seed,
            setup.observer.clone(),
        )),
        (Some(seed), Some((port, config))) => Some(Participant::spawn(
            participant::Eye::Iscan {
                port,
                config,
                screen_px: size_px,
            },
            setup.geometry,
            seed,
            setup.observer.clone(),
        )),
        (Some(seed), None) => feed.cursor_tx.clone().map(|tx| {
            Participant::spawn(
                participant::Eye::Mouse(tx),
                setup.geometry,
                seed,
                setup.observer.clone(),
            )
        }),
        _ => None,
    };
    let resumed = start > 0;
    let flow = Flow::new(
        trials,
        start,
        setup.design.response.confirm_click,
        resumed && setup.design.calibration.at_start,
    );
    let _ = writeln!(
        out,
        "gazecast experiment: {} for {} (row {}), trial {} of {}, session folder {}{}",
        setup.design.name,
        opts.participant,
        index,
        start + 1,
        flow.trials().len(),
        dir.path().display(),
        if participant.is_some() {
            " — SIMULATED participant (synthetic data)"
        } else {
            ""
        }
    );
    let mut runner = Runner {
        setup: &setup,
        clock,
        out,
        dir,
        feed,
        screen: None,
        gpu: None,
        overlay_trial: None,
        flow,
        phase_since_us: start_us,
        calibration: None,
        attempts: 0,
        checking: None,
        gaze: setup.geometry.centre_px(),
        cursor: setup.geometry.centre_px(),
        trial: None,
        canvas: Vec::new(),
        last_submit_us: None,
        late_after_ms: 1.5 * 1e3 / NOMINAL_REFRESH_HZ,
        participant,
        trials_this_sitting: 0,
        error: None,
        finished: false,
        quitting: false,
        just_calibrated: false,
        shot: Default::default(),
    };
    runner.entered();
    let result = match (event_loop, virtual_tracker.take()) {
        (Some(event_loop), _) => event_loop
            .run_app(&mut runner)
            .map_err(|e| format!("window: {e}")),
        (None, Some((device, tx))) => {
            headless::run(&mut runner, device, &tx);
            Ok(())
        }
        (None, None) => Err("neither a window nor a headless simulation to run".into()),
    };
    // The tracker first: the simulated participant's line closing under a
    // running tracker would be reported as a lost device.
    let recorded = runner.feed.finish();
    runner.participant = None;
    runner.drain();
    for l in runner.feed.report() {
        runner.say(&l);
    }
    if let Ok(Some(line)) = &recorded {
        runner.say(line);
    }
    if let Some(line) = runner.dir.lsl_summary() {
        runner.say(&line);
    }
    let summary = runner.dir.close();
    runner.say(&summary);
    recorded?;
    if let Some(e) = runner.error.take() {
        return Err(e);
    }
    result
}
