//! Where a frame is rendered: the CPU (rayon) or the GPU core (wgpu), and
//! the one rule that chooses between them.

use raycast::gpu::{self, GpuRenderer};
use raycast::ray::TriangleTest;
use raycast::scene::Accel;
use raycast::Scene;

use crate::renderer::RenderError;

/// The backend asked for (on a command line, in a bench configuration).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum BackendChoice {
    /// rayon on the CPU: every method, structure and intersector.
    Cpu,
    /// wgpu: every method, with the BVH and the watertight test (compute;
    /// the model-based methods' raster in a render pipeline).
    Gpu,
    /// A real GPU where one can render the scene, else the CPU; says which.
    #[default]
    Auto,
}

/// The backend in use.
pub(crate) enum Backend {
    Cpu,
    Gpu(Box<GpuRenderer>),
}

impl Backend {
    /// Chooses the backend for `scene` (its acceleration structure) and the
    /// triangle test, a GPU one on `device` when given; the note says why
    /// `auto` chose what it did.
    pub(crate) fn choose(
        choice: BackendChoice,
        scene: &Scene,
        test: TriangleTest,
        device: Option<&gpu::SharedDevice>,
    ) -> Result<(Backend, Option<String>), RenderError> {
        let gpu_able = scene.accel == Accel::Bvh && test == TriangleTest::Watertight;
        let open = |scene| {
            match device {
                Some(d) => GpuRenderer::on_device(d, scene),
                None => GpuRenderer::new(scene),
            }
            .map(|g| Backend::Gpu(Box::new(g)))
        };
        Ok(match (choice, gpu_able) {
            (BackendChoice::Cpu, _) => (Backend::Cpu, None),
            (BackendChoice::Gpu, false) => {
                return Err(RenderError::Unsupported(
                    "backend gpu: the GPU core has the BVH and the watertight test only; \
                     choose the CPU backend for the grid accelerator or the Möller–Trumbore \
                     test"
                        .into(),
                ))
            }
            (BackendChoice::Gpu, true) => (open(scene)?, None),
            (BackendChoice::Auto, false) => (
                Backend::Cpu,
                Some(
                    "auto: the CPU renders this (the grid and Möller–Trumbore are CPU-only)".into(),
                ),
            ),
            (BackendChoice::Auto, true) => match gpu::probe() {
                Ok((name, true)) => (
                    Backend::Cpu,
                    Some(format!(
                        "auto: the only adapter is a software one ({name}), slower than the CPU \
                         backend; rendering on the CPU (backend gpu forces it)"
                    )),
                ),
                Ok(_) => match open(scene) {
                    Ok(b) => (b, None),
                    Err(e) => (
                        Backend::Cpu,
                        Some(format!("auto: {e}; rendering on the CPU")),
                    ),
                },
                Err(e) => (
                    Backend::Cpu,
                    Some(format!("auto: {e}; rendering on the CPU")),
                ),
            },
        })
    }
}

impl BackendChoice {
    /// Every choice with its name and help, in the order `--help` lists them.
    pub const ALL: [(BackendChoice, &'static str, &'static str); 3] = [
        (
            BackendChoice::Cpu,
            "cpu",
            "rayon on the CPU: every method, structure and intersector",
        ),
        (
            BackendChoice::Gpu,
            "gpu",
            "wgpu: every method, with the BVH and the watertight test (compute; the \
             model-based methods' raster in a render pipeline)",
        ),
        (
            BackendChoice::Auto,
            "auto",
            "A real GPU where one can render the scene, else the CPU; says which",
        ),
    ];
}

impl std::str::FromStr for BackendChoice {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        Self::ALL
            .iter()
            .find(|(_, name, _)| *name == s)
            .map(|(b, ..)| *b)
            .ok_or_else(|| format!("unknown backend {s:?}; known: cpu, gpu, auto"))
    }
}
