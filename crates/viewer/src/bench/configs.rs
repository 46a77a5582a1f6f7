//! The accuracy sweep's configurations and gaze positions.

use foveation::{Layout, ScreenGeometry};
use pipeline::{BackendChoice, Method, Options};
use rand::{Rng, SeedableRng};
use raycast::render::Triggers;
use raycast::Scene;

use crate::args::AccelArg;

/// Which refinement triggers run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Refinement {
    /// No refinement.
    None,
    /// Silhouette refinement (with its margin).
    Silhouette,
    /// Silhouette and crease refinement.
    SilhouetteCrease,
}

impl Refinement {
    /// The name in reports (`none`, `silhouette`, `silhouette+crease`).
    pub fn name(self) -> &'static str {
        match self {
            Refinement::None => "none",
            Refinement::Silhouette => "silhouette",
            Refinement::SilhouetteCrease => "silhouette+crease",
        }
    }

    fn triggers(self, scene: &Scene) -> Triggers {
        let silhouette = self != Refinement::None;
        Triggers {
            silhouette,
            margin: silhouette,
            crease_deg: (self == Refinement::SilhouetteCrease).then_some(
                scene
                    .sampling
                    .crease_deg()
                    .unwrap_or(raycast::scene::DEFAULT_CREASE_DEG),
            ),
            depth_jump: None,
        }
    }
}

/// One point of the sweep. `method` `Full` is full-resolution ray casting
/// (the reference; contrast, spacing and refinement do not apply); `Image`
/// is image-based foveation (contrast and spacing apply; every pixel is
/// cast, so layout and refinement do not); `Hybrid` takes every knob.
/// `layout` is `Some` exactly for the hybrid method.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Config {
    /// The rendering method.
    pub method: Method,
    /// The ray mask's layout (hybrid only).
    pub layout: Option<Layout>,
    /// Michelson contrast of the CSF cut-off.
    pub contrast: f64,
    /// Largest ray spacing allowed, pixels.
    pub max_spacing_px: f64,
    /// Which refinement triggers run (hybrid only).
    pub refinement: Refinement,
    /// The acceleration structure.
    pub accel: AccelArg,
    /// `Simplify` under a triangle budget (Luebke & Hallen §5.3,
    /// `bench accuracy --budget`); `None` for every other configuration.
    pub budget: Option<usize>,
}

impl Config {
    /// The configuration's name in reports and plots.
    pub fn name(&self) -> String {
        let accel = self.accel.name();
        match self.layout {
            None if matches!(self.method, Method::Module(_)) => {
                format!("{} C={} {accel}", self.method.name(), self.contrast)
            }
            None if self.method.is_model_based() => match self.budget {
                Some(b) => format!("{} budget={b}", self.method.name()),
                None => self.method.name().to_string(),
            },
            None if self.method == Method::Image => format!(
                "image C={} n={} {accel}",
                self.contrast, self.max_spacing_px
            ),
            None => format!("full {accel}"),
            Some(l) => format!(
                "{} C={} n={} {} {accel}",
                l.name(),
                self.contrast,
                self.max_spacing_px,
                self.refinement.name()
            ),
        }
    }

    /// The configuration `gazecast render` uses by default.
    pub fn is_default(&self) -> bool {
        self.layout == Some(Layout::Nyquist)
            && self.contrast == 1.0
            && self.max_spacing_px == foveation::sampling::SEED_MAX_SPACING_PX
            && self.refinement == Refinement::SilhouetteCrease
            && self.accel == AccelArg::Bvh
    }
}

/// The values of each knob the sweep takes.
type Axes = (
    &'static [Layout],
    &'static [f64],
    &'static [f64],
    &'static [Refinement],
    &'static [AccelArg],
);

/// The sweep: full resolution with each structure, then every combination
/// of the hybrid method's knobs, then image-based foveation at each
/// contrast and spacing, then each registered method module and the two
/// model-based methods: 2 + 144 + 24 + M + 2 configurations, or
/// 1 + 8 + 2 + M + 2 in `--quick` (M modules).
pub fn configurations(quick: bool) -> Vec<Config> {
    let (layouts, contrasts, spacings, refinements, accels): Axes = if quick {
        (
            &[Layout::Seed, Layout::Nyquist],
            &[1.0, 0.25],
            &[17.0],
            &[Refinement::None, Refinement::SilhouetteCrease],
            &[AccelArg::Bvh],
        )
    } else {
        (
            &[Layout::Seed, Layout::Nyquist],
            &[1.0, 0.5, 0.25, 0.1],
            &[4.0, 8.0, 17.0],
            &[
                Refinement::None,
                Refinement::Silhouette,
                Refinement::SilhouetteCrease,
            ],
            &[AccelArg::Bvh, AccelArg::Grid],
        )
    };
    let mut out: Vec<Config> = accels
        .iter()
        .map(|&accel| Config {
            method: Method::Full,
            layout: None,
            contrast: 1.0,
            max_spacing_px: 1.0,
            refinement: Refinement::None,
            accel,
            budget: None,
        })
        .collect();
    for &accel in accels {
        for &layout in layouts {
            for &contrast in contrasts {
                for &max_spacing_px in spacings {
                    for &refinement in refinements {
                        out.push(Config {
                            method: Method::Hybrid,
                            layout: Some(layout),
                            contrast,
                            max_spacing_px,
                            refinement,
                            accel,
                            budget: None,
                        });
                    }
                }
            }
        }
    }
    for &accel in accels {
        for &contrast in contrasts {
            for &max_spacing_px in spacings {
                out.push(Config {
                    method: Method::Image,
                    layout: None,
                    contrast,
                    max_spacing_px,
                    refinement: Refinement::None,
                    accel,
                    budget: None,
                });
            }
        }
    }
    // Every registered method module (`pipeline::registry::METHODS`) at
    // contrast 1 and the seed's largest spacing, as `render` runs it: no
    // line here per module. Then the model-based methods (CPU raster; no
    // knob of the sweep applies).
    for method in Method::all().filter(|m| matches!(m, Method::Module(_))) {
        out.push(Config {
            method,
            layout: None,
            contrast: 1.0,
            max_spacing_px: foveation::sampling::SEED_MAX_SPACING_PX,
            refinement: Refinement::None,
            accel: AccelArg::Bvh,
            budget: None,
        });
    }
    for method in [Method::Simplify, Method::Lod] {
        out.push(Config {
            method,
            layout: None,
            contrast: 1.0,
            max_spacing_px: 1.0,
            refinement: Refinement::None,
            accel: AccelArg::Bvh,
            budget: None,
        });
    }
    out
}

/// `Simplify` under each triangle budget (`bench accuracy --budget`), in
/// the order given, each once.
pub fn budget_configurations(budgets: &[usize]) -> Vec<Config> {
    let mut out: Vec<Config> = Vec::new();
    for &b in budgets {
        let c = Config {
            method: Method::Simplify,
            layout: None,
            contrast: 1.0,
            max_spacing_px: 1.0,
            refinement: Refinement::None,
            accel: AccelArg::Bvh,
            budget: Some(b),
        };
        if !out.contains(&c) {
            out.push(c);
        }
    }
    out
}

/// The pipeline options of one configuration (the CPU backend).
pub fn options_for(config: &Config, scene: &Scene) -> Options {
    Options {
        method: config.method,
        backend: BackendChoice::Cpu,
        layout: config.layout.unwrap_or_default(),
        triggers: Some(config.refinement.triggers(scene)),
        model_based: pipeline::model_based::ModelBasedOptions {
            budget: config.budget,
            ignore_gaze: false,
        },
        ..Options::default()
    }
}

/// The centre, the four corner pixels, then seeded uniform positions.
pub fn gaze_positions(geometry: &ScreenGeometry, n: usize, seed: u64) -> Vec<[f64; 2]> {
    let [w, h] = geometry.size_px();
    let mut fixed = vec![
        geometry.centre_px(),
        [0.5, 0.5],
        [w - 0.5, h - 0.5],
        [w - 0.5, 0.5],
        [0.5, h - 0.5],
    ];
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    while fixed.len() < n {
        fixed.push([rng.random_range(0.0..w), rng.random_range(0.0..h)]);
    }
    fixed.truncate(n);
    fixed
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bench::scaling::scaling_display;

    #[test]
    fn the_sweep_has_every_combination_once() {
        let all = configurations(false);
        let modules = pipeline::registry::METHODS.len();
        assert_eq!(all.len(), 2 + 2 * 4 * 3 * 3 * 2 + 2 * 4 * 3 + modules + 2);
        for (i, a) in all.iter().enumerate() {
            assert!(all[i + 1..].iter().all(|b| b != a), "{} twice", a.name());
        }
        assert_eq!(all.iter().filter(|c| c.is_default()).count(), 1);
        let quick = configurations(true);
        assert_eq!(quick.len(), 13 + modules);
        assert!(quick.iter().any(|c| c.name() == "layers C=1 bvh"));
        assert_eq!(
            quick.iter().filter(|c| c.method == Method::Image).count(),
            2
        );
        assert_eq!(quick.iter().filter(|c| c.is_default()).count(), 1);
        assert!(all.iter().chain(&quick).all(|c| c.budget.is_none()));
        let budgets = budget_configurations(&[5000, 1000, 5000]);
        assert_eq!(budgets.len(), 2);
        assert_eq!(budgets[0].name(), "simplify budget=5000");
        assert_eq!(budgets[1].budget, Some(1000));
    }

    #[test]
    fn gazes_start_with_centre_and_corners_and_are_seeded() {
        let g = scaling_display(100, 50).geometry().expect("valid");
        let a = gaze_positions(&g, 8, 3);
        assert_eq!(a[0], [50.0, 25.0]);
        assert_eq!(a[2], [99.5, 49.5]);
        assert_eq!(a, gaze_positions(&g, 8, 3));
        assert_ne!(a[5..], gaze_positions(&g, 8, 4)[5..]);
        assert!(a[5..]
            .iter()
            .all(|p| (0.0..100.0).contains(&p[0]) && (0.0..50.0).contains(&p[1])));
        assert_eq!(gaze_positions(&g, 1, 3).len(), 1);
    }
}
