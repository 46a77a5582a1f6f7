//! The design's check as `experiment run` and `experiment plan` make it:
//! `experiment::run::design_check` with the renderer's own part, the
//! sampling model of the design's contrast and of each condition's
//! contrast and inset.

use experiment::design::Design;
use experiment::run::design_check::{self, Checked};
use foveation::ScreenGeometry;

/// The renderer's check of `design` on `geometry`: the sampling model of
/// the contrast, and of each condition's inset, can be built.
/// `Err((field, message))` names the design field.
pub fn sampling_models(design: &Design, geometry: &ScreenGeometry) -> Result<(), (String, String)> {
    pipeline::sampling_model(*geometry, design.contrast)
        .map_err(|e| ("contrast".to_string(), e.to_string()))?;
    for (i, c) in design.conditions.iter().enumerate() {
        if let Some(k) = c.contrast {
            pipeline::sampling_model(*geometry, k)
                .map_err(|e| (format!("conditions[{i}].contrast"), e.to_string()))?;
        }
        if let Some(d) = c.inset_deg {
            pipeline::sampling_model(*geometry, c.contrast_or(design.contrast))
                .and_then(|m| m.with_inset_deg(d))
                .map_err(|e| (format!("conditions[{i}].inset_deg"), e.to_string()))?;
        }
    }
    Ok(())
}

/// The one check of a design that `experiment plan` and `experiment run`
/// share ([`design_check::check_design`]), with the renderer's part
/// ([`sampling_models`]).
pub fn check_design(
    design: &Design,
    index: usize,
    geometry: &ScreenGeometry,
) -> Result<Checked, (String, String)> {
    design_check::check_design(design, index, geometry, &|d| sampling_models(d, geometry))
}

#[cfg(test)]
mod tests {
    use super::*;
    use experiment::design::DriftCheck;
    use experiment::run::flow::{Flow, Phase};
    use experiment::run::layout::Layout;
    use experiment::run::on_display::{self, MIN_OBJECT_PX};
    use experiment::run::stimulus::search_scene;
    use experiment::Step;
    use proptest::prelude::*;
    use tracker_hal::calibration::{Procedure, Session};

    fn murphy() -> Design {
        Design::load(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../config/experiments/murphy2007-search.ron"
        ))
        .expect("design")
    }

    fn seed_display() -> ScreenGeometry {
        foveation::Display::seed_17in(1280, 1024)
            .geometry()
            .expect("geometry")
    }

    fn runs_display() -> ScreenGeometry {
        crate::config::load_display(std::path::Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../config/displays/tobii-et1750-17in.ron"
        )))
        .expect("display")
        .geometry()
        .expect("geometry")
    }

    /// The trials on the display with the renderer's check.
    fn plan_on_display(
        d: &Design,
        index: usize,
        g: &ScreenGeometry,
    ) -> Result<(Vec<experiment::Trial>, Layout), (String, String)> {
        on_display::plan_on_display(d, index, g, &|d| sampling_models(d, g))
    }

    fn check_on_display(
        d: &Design,
        trials: &[experiment::Trial],
        g: &ScreenGeometry,
    ) -> Result<Layout, (String, String)> {
        on_display::check_on_display(d, trials, g, &|d| sampling_models(d, g))
    }

    /// Every method a condition may name renders as that method: the
    /// search scene lists what the method needs, and the renderer built
    /// for it runs it (an image condition used to run as the
    /// full-resolution control, silently: its scene had no foveated
    /// sampling). An unknown name is an error, not the control.
    #[test]
    fn each_condition_method_renders_as_named() {
        use pipeline::{BackendChoice, Method, Options, Renderer};
        let mut d = murphy();
        let geometry = seed_display();
        let l = Layout::new(&d, &geometry);
        let trial = experiment::plan(&d, 0).expect("plan")[1].clone();
        for name in experiment::design::METHODS {
            let c = &mut d.conditions[trial.condition];
            c.method = name.to_string();
            c.inset_deg = (*name == "hybrid").then_some(5.0);
            c.silhouette_edges = false;
            let file = search_scene(&d, &trial, &l);
            let scene = raycast::Scene::build(&file, std::path::Path::new(".")).expect("scene");
            let method = super::super::trial::condition_method(name).expect("known");
            let model = pipeline::sampling_model(geometry, 1.0).expect("model");
            let options = Options {
                method,
                backend: BackendChoice::Cpu,
                ..Options::default()
            };
            let r = Renderer::new(&scene, raycast::Camera::new(&geometry), model, &options)
                .expect("renderer");
            assert_eq!(r.method(), method, "{name}");
            let expect = match *name {
                "full" => Method::Full,
                "hybrid" => Method::Hybrid,
                _ => Method::Image,
            };
            assert_eq!(r.method(), expect, "{name}");
        }
        let e = super::super::trial::condition_method("imag").expect_err("unknown");
        assert!(e.contains("imag") && e.contains("image"), "{e}");
    }

    fn display(res: (u32, u32), size_mm: (f64, f64), eye_mm: f64) -> ScreenGeometry {
        foveation::Display {
            name: "any".into(),
            resolution_px: res,
            size_mm,
            eye_distance_mm: eye_mm,
            eye_point_px: None,
        }
        .geometry()
        .expect("geometry")
    }

    fn with(edit: impl Fn(&mut Design)) -> Design {
        let mut d = murphy();
        edit(&mut d);
        d.validate().expect("a valid design");
        d
    }

    fn refusal(d: &Design, g: &ScreenGeometry) -> (String, String) {
        match plan_on_display(d, 0, g) {
            Err(e) => e,
            Ok(_) => panic!("accepted: {:?}", d.stimulus),
        }
    }

    #[test]
    fn the_seed_design_fits_its_display_and_what_cannot_be_seen_or_built_is_refused() {
        let g = seed_display();
        plan_on_display(&murphy(), 0, &g).expect("the seed design on the seed display");
        // A grid wider than the screen: only the centre was on screen.
        let (field, msg) = refusal(&with(|d| d.stimulus.grid_deg = 60.0), &g);
        assert_eq!(field, "stimulus.grid_deg", "{msg}");
        assert!(
            msg.contains("off the screen") && msg.contains("1280×1024"),
            "{msg}"
        );
        // Objects of 1e-42°: no pixel drawn.
        let (field, msg) = refusal(&with(|d| d.stimulus.object_deg = 1e-42), &g);
        assert_eq!(field, "stimulus.object_deg", "{msg}");
        assert!(msg.contains("1e-42") && msg.contains("8 px"), "{msg}");
        // 0.1° is about 3.6 px here.
        assert_eq!(
            refusal(&with(|d| d.stimulus.object_deg = 0.1), &g).0,
            "stimulus.object_deg"
        );
        // More than the scene's triangle limit: 31×33 faces (odd, so the
        // seed's reference has a centre).
        let (field, msg) = refusal(
            &with(|d| {
                d.stimulus.grid = (31, 33);
                d.stimulus.object_deg = 0.5;
            }),
            &g,
        );
        assert_eq!(field, "stimulus", "{msg}");
        assert!(msg.contains("20000000 triangles"), "{msg}");
        // The design allows an inset of 180°, the sampling model does not.
        let (field, _) = refusal(&with(|d| d.conditions[10].inset_deg = Some(180.0)), &g);
        assert_eq!(field, "conditions[10].inset_deg");
        // The seed design on a screen of under 6° (10 cm at 1 m): its 20°
        // grid does not fit.
        let small = display((320, 240), (100.0, 75.0), 1000.0);
        assert_eq!(refusal(&murphy(), &small).0, "stimulus.grid_deg");
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(fixtures::proptest_cases(48)))]

        /// Accepted exactly when every object of the search scene that is
        /// rendered — its sphere's left, right, top and bottom points,
        /// projected through the eye onto the screen — lies on the screen
        /// and spans at least MIN_OBJECT_PX.
        #[test]
        fn a_design_is_accepted_iff_every_object_is_on_screen_and_visible(
            rows in 1u32..6,
            cols in 1u32..6,
            object_deg in prop_oneof_object(),
            grid_extra in 0.0f64..40.0,
            res in (200u32..2600, 200u32..1700),
            eye_mm in 300.0f64..1200.0,
        ) {
            let g = display(res, (f64::from(res.0) * 0.26, f64::from(res.1) * 0.26), eye_mm);
            let mut d = murphy();
            d.stimulus.grid = (rows, cols);
            // The seed's reference needs a centre cell (odd sides) and a
            // second cell; other grids are checked without one.
            if rows % 2 == 0 || cols % 2 == 0 || rows * cols < 2 {
                d.stimulus.reference = None;
            }
            d.stimulus.object_deg = object_deg;
            d.stimulus.grid_deg = (object_deg + grid_extra).min(169.0);
            proptest::prop_assume!(d.validate().is_ok());
            let trials = experiment::plan(&d, 0).expect("plan");
            let layout = Layout::new(&d, &g);
            let file = search_scene(&d, &trials[0], &layout);
            // Independent projection: eye at the camera, screen at z = 0.
            let cam = raycast::Camera::new(&g);
            let eye = [f64::from(cam.eye.x), f64::from(cam.eye.y), f64::from(cam.eye.z)];
            let [w, h] = g.size_px();
            let project = |x: f64, y: f64, z: f64| {
                let t = eye[2] / (eye[2] - z);
                [
                    (eye[0] + t * (x - eye[0])) / g.pitch_x_mm + w / 2.0,
                    h / 2.0 - (eye[1] + t * (y - eye[1])) / g.pitch_y_mm,
                ]
            };
            let mut ok = true;
            for o in &file.objects {
                let (x, y, z) = (f64::from(o.translate_mm.0), f64::from(o.translate_mm.1), f64::from(o.translate_mm.2));
                let r = f64::from(o.scale_mm);
                let (l, rt) = (project(x - r, y, z), project(x + r, y, z));
                let (top, bottom) = (project(x, y + r, z), project(x, y - r, z));
                let tol = 1e-6 * w.max(h);
                ok &= l[0] >= -tol && rt[0] <= w + tol && top[1] >= -tol && bottom[1] <= h + tol;
                ok &= (rt[0] - l[0]).min(bottom[1] - top[1]) >= MIN_OBJECT_PX * (1.0 - 1e-3);
            }
            let got = check_on_display(&d, &trials, &g);
            match &got {
                Ok(_) => proptest::prop_assert!(ok, "accepted, but an object is off the screen or too small"),
                Err((field, msg)) => {
                    proptest::prop_assert!(field.starts_with("stimulus."), "{field}: {msg}");
                    // A borderline object (within a thousandth) may go either way.
                    proptest::prop_assert!(!ok || msg.contains("8 px"), "{field}: {msg}");
                }
            }
        }
    }

    fn prop_oneof_object() -> impl proptest::strategy::Strategy<Value = f64> {
        use proptest::prelude::*;
        prop_oneof![1e-3f64..0.5, 0.5f64..30.0, Just(1e-42)]
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(fixtures::proptest_cases(64)))]

        /// Every design that `experiment plan` accepts, `experiment run`
        /// accepts and can set up. `plan`'s trials-on-the-display check
        /// accepting a design implies the shared check accepts it; and
        /// what the shared check accepts gives run everything it builds
        /// before the window: the calibration session (its fit has the
        /// points it needs, at most 25 of each kind), the drift check's
        /// single target wherever the plan puts a drift check, and a flow
        /// that reaches its end.
        #[test]
        fn every_design_plan_accepts_run_accepts(
            points in prop_oneof![0u32..30, Just(36u32), Just(1_000_000u32)],
            validation in prop_oneof![0u32..30, Just(1_000_000u32)],
            drift in proptest::option::of((0u32..50, prop_oneof![Just(f64::NAN), 0.1f64..5.0])),
            at_start in any::<bool>(),
            midpoint in any::<bool>(),
            runs in 1u32..4,
            index in 0usize..30,
        ) {
            let g = runs_display();
            let mut d = murphy();
            d.calibration.points = points;
            d.calibration.validation_points = validation;
            d.calibration.at_start = at_start;
            d.calibration.validate_at_midpoint = midpoint;
            d.runs = runs;
            d.drift_check = drift.map(|(every_trials, threshold_deg)| DriftCheck {
                every_trials,
                threshold_deg,
            });
            let shared = check_design(&d, index, &g);
            if plan_on_display(&d, index, &g).is_ok() {
                prop_assert!(shared.is_ok(), "{:?}", shared.err());
            }
            let Ok(c) = shared else {
                return Ok(());
            };
            prop_assert!(d.validate().is_ok());
            prop_assert_eq!(c.cal_plans.0.targets_px.len(), points as usize);
            prop_assert_eq!(c.cal_plans.1.targets_px.len(), validation as usize);
            prop_assert!(points <= 25 && validation <= 25);
            prop_assert!(c.cal_plans.0.targets_px.len() >= c.model.min_points());
            let _session = Session::new(
                c.model,
                c.cal_plans.0.clone(),
                c.cal_plans.1.clone(),
                g,
                d.calibration.accuracy_threshold_deg,
                true,
            );
            let drifts = c
                .trials
                .iter()
                .filter(|t| t.before.contains(&Step::DriftCheck))
                .count();
            prop_assert_eq!(drifts > 0, d.drift_check.is_some());
            if let Some(p) = &c.drift_plan {
                prop_assert_eq!(p.targets_px.len(), 1);
                let _ = Procedure::new(p.clone());
            }
            let mut flow = Flow::new(c.trials.clone(), 0, d.response.confirm_click, false);
            let mut steps = 0usize;
            while flow.phase() != Phase::Done {
                if flow.phase() == Phase::DriftCheck {
                    prop_assert!(c.drift_plan.is_some());
                }
                flow.advance();
                steps += 1;
                prop_assert!(steps < 10 * (c.trials.len() + 2) * 4);
            }
        }
    }
}
