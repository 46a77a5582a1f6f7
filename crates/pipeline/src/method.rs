//! Rendering methods: what fills the G-buffer.

use raycast::scene::Effect;
use raycast::Scene;

/// How a frame's G-buffer is filled.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum Method {
    /// One ray per pixel (the control condition).
    Full,
    /// Murphy 2007's hybrid: the CSF ray mask, reconstruction from the
    /// intermediate mesh, refinement where the scene's effects ask.
    #[default]
    #[value(alias = "foveated")]
    Hybrid,
    /// Image-based foveation (Geisler & Perry 1998): every pixel cast, then
    /// blurred by a Gaussian pyramid to the level the CSF allows at its
    /// eccentricity.
    #[value(alias = "image-based")]
    Image,
    /// Model-based: Luebke & Hallen 2001's perceptual simplification
    /// (imperceptible mode: every fold the Geisler–Perry table judges
    /// invisible at its eccentricity), rasterised on the CPU.
    #[value(alias = "luebke-hallen")]
    Simplify,
    /// Model-based: Murphy & Duchowski 2001's gaze-contingent level of
    /// detail (Table 1's levels by eccentricity), rasterised on the CPU.
    #[value(alias = "murphy-duchowski")]
    Lod,
    /// Lee 2009 ch. 7: attention-guided level of detail with ULOD's blend
    /// of adjacent levels (`ULOD5`: 1, 1/4, … 1/256 of each object's
    /// triangles by quadric simplification), levels set by Lee's attention
    /// model on the previous frame; no eye tracker needed. CPU raster.
    #[value(alias = "attention-lod")]
    Ulod,
}

impl Method {
    /// The method that will run for `scene` when `self` is asked for: the
    /// foveated methods (hybrid, image-based, model-based) need the scene to list
    /// `FoveatedSampling`; without it the scene is rendered at full
    /// resolution, on every backend. `Ulod` follows attention, not the
    /// gaze, and runs whatever the scene lists.
    pub fn for_scene(self, scene: &Scene) -> Method {
        match self {
            Method::Hybrid | Method::Image | Method::Simplify | Method::Lod
                if !scene.has(Effect::FoveatedSampling) =>
            {
                Method::Full
            }
            m => m,
        }
    }

    /// The name used in reports and `--stats`.
    pub fn name(self) -> &'static str {
        match self {
            Method::Full => "full",
            Method::Hybrid => "foveated",
            Method::Image => "image-based",
            Method::Simplify => "simplify",
            Method::Lod => "lod",
            Method::Ulod => "ulod",
        }
    }

    /// Whether the method simplifies geometry and rasterises it.
    pub fn is_model_based(self) -> bool {
        matches!(self, Method::Simplify | Method::Lod)
    }
}
