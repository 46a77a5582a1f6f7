//! The search display of one trial as a scene: the design's grid of face
//! meshes (`raycast`'s procedural `Face`, four expressions with one
//! topology and one silhouette), sized in degrees of visual angle on the
//! session's display, and the target preview (the target alone at the
//! centre).
//!
//! Geometry: the objects stand [`DEPTH_MM`] behind the screen, facing the
//! viewer. An object `object_deg` wide is `2 (d + depth) tan(object_deg / 2)`
//! mm across (d the eye-to-screen distance); the grid, `grid_deg` wide from
//! the outer edge of one outer object to the other, spaces the cell centres
//! evenly. The shipped search-task scene (17" at 54 cm: 3.5° objects,
//! 17.11 mm scale, 40.82 mm spacing) is this construction.

use std::collections::BTreeMap;

use experiment::design::{Condition, Design};
use experiment::Trial;
use foveation::ScreenGeometry;
use raycast::scene::{Effect, Light, Material, MeshSource, Object};
use raycast::SceneFile;

/// Objects stand this far behind the screen plane (mm).
pub const DEPTH_MM: f64 = 20.0;

/// Icosphere subdivisions of each face mesh (20·4⁵ = 20 480 triangles).
pub const FACE_SUBDIVISIONS: u32 = 5;

/// Smallest object a design may show: this many pixels across on the
/// session's display (a smaller one draws no recognisable face, or no
/// pixel at all).
pub const MIN_OBJECT_PX: f64 = 8.0;

/// Participant `index`'s trials and the layout, the design checked on
/// `geometry` ([`check_on_display`]): what `experiment run` and
/// `experiment plan` do before anything else.
pub fn plan_on_display(
    design: &Design,
    index: usize,
    geometry: &ScreenGeometry,
) -> Result<(Vec<Trial>, Layout), (String, String)> {
    let trials = experiment::plan(design, index)
        .map_err(|e| (e.field().unwrap_or("runs").to_string(), e.to_string()))?;
    let layout = check_on_display(design, &trials, geometry)?;
    Ok((trials, layout))
}

/// The design's stimuli on the display they will be shown on, checked
/// before any session folder or window exists (`experiment run`,
/// `experiment plan`): every object at least [`MIN_OBJECT_PX`] across,
/// every cell's object wholly on the screen, every condition's sampling
/// model buildable (contrast, inset), and the trial scenes buildable
/// (the scene's triangle limit, sizes that underflow: the first trial's
/// search display and preview go through every check of `Scene::build`,
/// without the hierarchy, and every trial's scene has the same meshes,
/// object count and sizes). `Err((field, message))` names
/// the design field to change.
pub fn check_on_display(
    design: &Design,
    trials: &[Trial],
    geometry: &ScreenGeometry,
) -> Result<Layout, (String, String)> {
    let s = &design.stimulus;
    let layout = Layout::new(design, geometry);
    // Pixels to one decimal, degrees as written (tiny or huge: 1e-42).
    let px = |v: f64| {
        if v.is_finite() && v.abs() >= 0.05 && v.abs() < 1e9 {
            format!("{v:.1}")
        } else {
            foveation::fmt_f64(v)
        }
    };
    let deg = foveation::fmt_f64;
    let [w, h] = geometry.size_px();
    let on = format!(
        "on this display ({}×{} px at {} mm)",
        geometry.width_px, geometry.height_px, geometry.eye_distance_mm
    );
    let across_px = 2.0 * layout.radius_px;
    if !(across_px.is_finite() && across_px >= MIN_OBJECT_PX) {
        // The angle that MIN_OBJECT_PX subtends at the screen centre.
        let pitch = geometry.pitch_x_mm.max(geometry.pitch_y_mm);
        let min_deg = 2.0
            * (MIN_OBJECT_PX * pitch / 2.0 / geometry.eye_distance_mm)
                .atan()
                .to_degrees();
        return Err((
            "stimulus.object_deg".into(),
            format!(
                "{}° is {} px across {on}: an object must be at least {MIN_OBJECT_PX} px \
                 ({min_deg:.2}°) across to be seen",
                deg(s.object_deg),
                px(across_px),
            ),
        ));
    }
    let r = layout.radius_px;
    for (k, c) in layout.centres_px.iter().enumerate() {
        let inside = c[0] - r >= 0.0 && c[0] + r <= w && c[1] - r >= 0.0 && c[1] + r <= h;
        if !(c[0].is_finite() && c[1].is_finite() && inside) {
            let (row, col) = (k as u32 / layout.cols, k as u32 % layout.cols);
            let first = layout.centres_px.first().copied().unwrap_or(*c);
            let last = layout.centres_px.last().copied().unwrap_or(*c);
            let (span_x, span_y) = (
                (last[0] - first[0]).abs() + 2.0 * r,
                (last[1] - first[1]).abs() + 2.0 * r,
            );
            let field = if s.grid_deg > s.object_deg {
                "stimulus.grid_deg"
            } else {
                "stimulus.grid"
            };
            return Err((
                field.into(),
                format!(
                    "the {}×{} grid ({}° wide, objects {}°) takes {} × {} px {on}: cell ({row}, \
                     {col}) at ({}, {}) px reaches off the screen; every object must be wholly \
                     on it",
                    s.grid.0,
                    s.grid.1,
                    deg(s.grid_deg),
                    deg(s.object_deg),
                    px(span_x),
                    px(span_y),
                    px(c[0]),
                    px(c[1])
                ),
            ));
        }
    }
    pipeline::sampling_model(*geometry, design.contrast)
        .map_err(|e| ("contrast".to_string(), e.to_string()))?;
    for (i, c) in design.conditions.iter().enumerate() {
        if let Some(d) = c.inset_deg {
            pipeline::sampling_model(*geometry, design.contrast)
                .and_then(|m| m.with_inset_deg(d))
                .map_err(|e| (format!("conditions[{i}].inset_deg"), e.to_string()))?;
        }
    }
    if let Some(t) = trials.first() {
        for file in [
            search_scene(design, t, &layout),
            preview_scene(design, t, &layout),
        ] {
            raycast::Scene::check(&file, std::path::Path::new(".")).map_err(|e| {
                (
                    "stimulus".to_string(),
                    format!("the trials' scene cannot be built {on}: {e}"),
                )
            })?;
        }
    }
    Ok(layout)
}

/// The grid on one display: where each cell is, in the world and on the
/// screen.
#[derive(Debug, Clone, PartialEq)]
pub struct Layout {
    pub rows: u32,
    pub cols: u32,
    /// Mesh scale (mm): the face mesh fits the unit sphere, so this is the
    /// object's radius.
    pub scale_mm: f64,
    /// Centre-to-centre spacing of cells (mm, in the objects' plane).
    pub spacing_mm: f64,
    /// Cell centres on the screen (px), row-major.
    pub centres_px: Vec<[f64; 2]>,
    /// An object's radius on the screen (px), for hit-testing clicks.
    pub radius_px: f64,
}

impl Layout {
    /// The design's grid on `geometry`.
    pub fn new(design: &Design, geometry: &ScreenGeometry) -> Self {
        let s = &design.stimulus;
        let (rows, cols) = s.grid;
        let plane = geometry.eye_distance_mm + DEPTH_MM;
        let width = |deg: f64| 2.0 * plane * (deg.to_radians() / 2.0).tan();
        let object = width(s.object_deg);
        let grid = width(s.grid_deg);
        let n = rows.max(cols);
        let spacing_mm = if n > 1 {
            ((grid - object) / f64::from(n - 1)).max(object)
        } else {
            object
        };
        let cam = raycast::Camera::new(geometry);
        let eye = [
            f64::from(cam.eye.x),
            f64::from(cam.eye.y),
            f64::from(cam.eye.z),
        ];
        let [w, h] = geometry.size_px();
        let to_screen = |x: f64, y: f64| {
            // Along the line from the eye to (x, y, −depth) to z = 0.
            let t = eye[2] / (eye[2] + DEPTH_MM);
            let sx = eye[0] + t * (x - eye[0]);
            let sy = eye[1] + t * (y - eye[1]);
            [
                sx / geometry.pitch_x_mm + w / 2.0,
                h / 2.0 - sy / geometry.pitch_y_mm,
            ]
        };
        let mut centres_px = Vec::with_capacity((rows * cols) as usize);
        for r in 0..rows {
            for c in 0..cols {
                let (x, y) = cell_mm(r, c, rows, cols, spacing_mm);
                centres_px.push(to_screen(x, y));
            }
        }
        let scale_mm = object / 2.0;
        let radius_px = scale_mm * geometry.eye_distance_mm
            / plane
            / geometry.pitch_x_mm.max(geometry.pitch_y_mm);
        Self {
            rows,
            cols,
            scale_mm,
            spacing_mm,
            centres_px,
            radius_px,
        }
    }

    /// The cell under screen point `p` (px): the nearest centre if it is
    /// within half a spacing (a click between objects counts for the
    /// nearest), else `None`.
    pub fn cell_at(&self, p: [f64; 2]) -> Option<(u32, u32)> {
        if !(p[0].is_finite() && p[1].is_finite()) {
            return None;
        }
        let (k, d) = self
            .centres_px
            .iter()
            .enumerate()
            .map(|(k, c)| (k, (c[0] - p[0]).hypot(c[1] - p[1])))
            .min_by(|a, b| a.1.total_cmp(&b.1))?;
        let half_spacing_px = if self.centres_px.len() > 1 {
            self.spacing_px() / 2.0
        } else {
            self.radius_px
        };
        (d <= half_spacing_px.max(self.radius_px))
            .then_some((k as u32 / self.cols, k as u32 % self.cols))
    }

    /// Spacing on the screen (px) between neighbouring centres.
    pub fn spacing_px(&self) -> f64 {
        match self.centres_px.as_slice() {
            [a, b, ..] => (a[0] - b[0]).hypot(a[1] - b[1]),
            _ => 0.0,
        }
    }

    /// The centre (px) of cell (row, col).
    pub fn centre_px(&self, (r, c): (u32, u32)) -> [f64; 2] {
        self.centres_px
            .get((r * self.cols + c) as usize)
            .copied()
            .unwrap_or([0.0, 0.0])
    }
}

/// World position (mm) of cell (r, c): row 0 at the top.
fn cell_mm(r: u32, c: u32, rows: u32, cols: u32, spacing: f64) -> (f64, f64) {
    let x = (f64::from(c) - f64::from(cols - 1) / 2.0) * spacing;
    let y = (f64::from(rows - 1) / 2.0 - f64::from(r)) * spacing;
    (x, y)
}

/// The effects a condition's scene lists: the full-resolution control
/// none (the pipeline then renders every pixel), the hybrid method the
/// CSF mask, with silhouette refinement when edges are kept, and the
/// image method the CSF mask too (it blurs each pixel to the mask's level
/// there; without it the pipeline renders the full-resolution frame, and
/// an image condition was rendered as the control).
pub fn effects_for(condition: &Condition) -> Vec<Effect> {
    match condition.method.as_str() {
        "hybrid" => {
            let mut e = vec![Effect::FoveatedSampling];
            if condition.silhouette_edges {
                e.push(Effect::SilhouetteRefinement);
            }
            e
        }
        "image" => vec![Effect::FoveatedSampling],
        _ => Vec::new(),
    }
}

fn base_scene(name: String, design: &Design, effects: Vec<Effect>) -> SceneFile {
    let meshes: BTreeMap<String, MeshSource> = (0..design.stimulus.meshes)
        .map(|k| {
            (
                mesh_name(k),
                MeshSource::Face {
                    expression: k % 4,
                    subdivisions: FACE_SUBDIVISIONS,
                },
            )
        })
        .collect();
    let mut materials = BTreeMap::new();
    materials.insert(
        "skin".to_string(),
        Material {
            diffuse: (0.78, 0.64, 0.52),
            ..Material::default()
        },
    );
    SceneFile {
        name,
        background: (0.06, 0.06, 0.08),
        meshes,
        materials,
        objects: Vec::new(),
        lights: vec![Light::Headlight { intensity: 1.0 }],
        sampling: None,
        passes: None,
        effects: Some(effects),
        crease_deg: Some(30.0),
        depth_jump: Some(0.05),
        camera: None,
    }
}

fn mesh_name(k: u32) -> String {
    format!("face{k}")
}

fn object(mesh: u32, (x, y): (f64, f64), scale_mm: f64) -> Object {
    Object {
        mesh: mesh_name(mesh),
        material: Some("skin".into()),
        translate_mm: (x as f32, y as f32, -DEPTH_MM as f32),
        rotate_deg: (0.0, 0.0, 0.0),
        scale_mm: scale_mm as f32,
        importance: 1.0,
        motion: None,
    }
}

/// The trial's search display: every cell's mesh from the plan.
pub fn search_scene(design: &Design, trial: &Trial, layout: &Layout) -> SceneFile {
    let condition = &design.conditions[trial.condition];
    let mut f = base_scene(
        format!(
            "{} trial {} ({})",
            design.name,
            trial.index + 1,
            condition.name
        ),
        design,
        effects_for(condition),
    );
    for r in 0..layout.rows {
        for c in 0..layout.cols {
            let mesh = trial
                .cells
                .get((r * layout.cols + c) as usize)
                .copied()
                .unwrap_or(0);
            let at = cell_mm(r, c, layout.rows, layout.cols, layout.spacing_mm);
            f.objects.push(object(mesh, at, layout.scale_mm));
        }
    }
    f
}

/// The target preview: the target mesh alone at the screen's centre, at
/// full resolution.
pub fn preview_scene(design: &Design, trial: &Trial, layout: &Layout) -> SceneFile {
    let mut f = base_scene(
        format!("{} trial {} target", design.name, trial.index + 1),
        design,
        Vec::new(),
    );
    f.objects
        .push(object(trial.target_mesh, (0.0, 0.0), layout.scale_mm));
    f
}

#[cfg(test)]
mod tests {
    use super::*;

    fn murphy() -> Design {
        Design::load(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/../../config/experiments/murphy2007-search.ron"
        ))
        .expect("design")
    }

    fn seed_display() -> ScreenGeometry {
        foveation::Display {
            name: "17in".into(),
            resolution_px: (1280, 1024),
            size_mm: (337.9, 270.3),
            eye_distance_mm: 540.0,
            eye_point_px: None,
        }
        .geometry()
        .expect("geometry")
    }

    /// The construction gives the shipped search-task scene's numbers
    /// (3.5° objects, 20° grid at 54 cm).
    #[test]
    fn the_seed_grid_matches_the_search_task_scene() {
        let l = Layout::new(&murphy(), &seed_display());
        assert!((l.scale_mm - 17.11).abs() < 0.01, "{}", l.scale_mm);
        assert!((l.spacing_mm - 40.82).abs() < 0.01, "{}", l.spacing_mm);
        assert_eq!(l.centres_px.len(), 25);
        // The centre cell is the screen's centre.
        let c = l.centre_px((2, 2));
        assert!((c[0] - 640.0).abs() < 1e-9 && (c[1] - 512.0).abs() < 1e-9);
        // Row 0 is above (smaller y), column 0 to the left.
        assert!(l.centre_px((0, 0))[1] < c[1] && l.centre_px((0, 0))[0] < c[0]);
    }

    #[test]
    fn clicks_find_the_nearest_cell_and_not_far_away() {
        let l = Layout::new(&murphy(), &seed_display());
        for (k, c) in l.centres_px.iter().enumerate() {
            let cell = (k as u32 / 5, k as u32 % 5);
            assert_eq!(l.cell_at(*c), Some(cell));
            assert_eq!(l.cell_at([c[0] + 0.4 * l.spacing_px(), c[1]]), Some(cell));
        }
        assert_eq!(l.cell_at([5.0, 5.0]), None);
        assert_eq!(l.cell_at([f64::NAN, 5.0]), None);
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

    #[test]
    fn scenes_place_the_plan_and_list_only_the_condition_effects() {
        let d = murphy();
        let l = Layout::new(&d, &seed_display());
        let trials = experiment::plan(&d, 0).expect("plan");
        for t in &trials[..11] {
            let s = search_scene(&d, t, &l);
            assert_eq!(s.objects.len(), 25);
            let at = (t.target_cell.0 * 5 + t.target_cell.1) as usize;
            assert_eq!(s.objects[at].mesh, mesh_name(t.target_mesh));
            let c = &d.conditions[t.condition];
            let e = effects_for(c);
            assert_eq!(s.effects.as_ref(), Some(&e));
            assert_eq!(
                e.contains(&Effect::FoveatedSampling),
                c.method == "hybrid" || c.method == "image"
            );
            assert_eq!(
                e.contains(&Effect::SilhouetteRefinement),
                c.silhouette_edges
            );
            let p = preview_scene(&d, t, &l);
            assert_eq!(p.objects.len(), 1);
            assert!(p.effects.as_ref().is_some_and(|e| e.is_empty()));
            assert_eq!(p.objects[0].mesh, mesh_name(t.target_mesh));
        }
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
        // More than the scene's triangle limit: 32×32 faces.
        let (field, msg) = refusal(
            &with(|d| {
                d.stimulus.grid = (32, 32);
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
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(48))]

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
}
