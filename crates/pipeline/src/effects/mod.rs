//! Effects: passes over a filled G-buffer, assembled from the scene's
//! `passes` (or the passes of an old-form file's effect list). A pass the
//! scene does not list is never constructed: it allocates nothing and runs
//! nothing.
//!
//! Adding an effect: a variant of `raycast::scene::PostPass` (with its
//! parameters, parsed from the scene file), a module here implementing
//! [`Pass`], and one arm in [`pass_for`]. A pass with a GPU implementation
//! says so in [`Pass::into_gpu`]; the frame plan (`crate::plan`) puts it on
//! the GPU when every pass before it is there too.

pub mod depth_of_field;
pub mod dof_reference;
pub mod dof_splat;
pub mod por_overlay;
pub mod refocus;

use foveation::SamplingModel;
use raycast::gpu::{wgpu, GpuError, GpuFrame};
use raycast::scene::{DofMethod, PostPass};
use raycast::{Camera, Frame, Scene};

use crate::plan::{Channels, Role};

/// What a pass may read besides the frame.
#[derive(Debug, Clone, Copy)]
pub struct PassInput<'a> {
    /// The scene as posed for this frame.
    pub scene: &'a Scene,
    /// The camera the frame was rendered from.
    pub camera: &'a Camera,
    /// The point of regard the frame was rendered for (screen px).
    pub gaze_px: [f64; 2],
    /// The frame's time, s (any fixed origin), for passes with dynamics
    /// (depth of field's refocusing); `None`: no clock, such passes act at
    /// once. `Renderer::render` gives the wall clock, `render_at` the
    /// caller's time.
    pub time_s: Option<f64>,
    /// The eye distance of the binocular 3-D gaze point for this frame, mm
    /// (Murphy & Duchowski eqs. 1–3), when the tracker's sample had both
    /// eyes valid and converging; `None` otherwise. Read by depth of
    /// field's `focus: Vergence`.
    pub vergence_mm: Option<f64>,
}

/// One pass over a rendered frame.
pub trait Pass: Send {
    /// The name `--explain` prints.
    fn name(&self) -> &'static str;
    /// Reads and writes the frame in place.
    fn run(&mut self, frame: &mut Frame, input: &PassInput<'_>);

    /// The pass itself, for callers that inspect a known pass (debug maps).
    fn as_any(&self) -> &dyn std::any::Any;

    /// The G-buffer channels the pass reads.
    fn reads(&self) -> Channels {
        Channels::COLOUR
    }

    /// The G-buffer channels the pass writes.
    fn writes(&self) -> Channels {
        Channels::COLOUR
    }

    /// Whether the pass reads the frame's surface buffers (depth, object
    /// id, normal); the method fills them only when some pass does.
    fn needs_surface(&self) -> bool {
        self.reads().intersects(Channels::SURFACE)
    }

    /// The buffers the pass allocates (with its first frame), in words.
    fn owns(&self) -> String {
        "nothing".into()
    }

    /// What the pass is in the frame plan: an effect, or part of the method.
    fn role(&self) -> Role {
        Role::Effect
    }

    /// The sampling model this frame is rendered under (before every
    /// frame); a pass that follows the CSF reads it here.
    fn prepare(&mut self, _model: &SamplingModel) {}

    /// The pass moved into its GPU implementation, when it has one for its
    /// settings; the pass itself back otherwise (it then runs on the CPU,
    /// after the read-back).
    fn into_gpu(self: Box<Self>) -> Result<Box<dyn GpuPass>, Box<dyn Pass>>;
}

/// A pass's GPU implementation: the same filter encoded on a GPU frame's
/// buffers between its cast and its read-back. The CPU pass it implements
/// ([`GpuPass::reference`]) is the reference it equals within its stated
/// tolerance, and holds the parameters and the state (focus, refocusing).
pub trait GpuPass: Send {
    /// The CPU pass this implements.
    fn reference(&self) -> &dyn Pass;

    /// The sampling model this frame is rendered under.
    fn prepare(&mut self, _model: &SamplingModel) {}

    /// Encodes the pass on `frame` into `encoder` (which it may submit,
    /// going on in a new one) and returns the encoder the next pass or the
    /// read-back is appended to.
    fn encode(
        &mut self,
        frame: &GpuFrame<'_>,
        encoder: wgpu::CommandEncoder,
        input: &PassInput<'_>,
    ) -> Result<wgpu::CommandEncoder, GpuError>;

    /// Whether its GPU buffers exist (made by its first frame).
    fn has_buffers(&self) -> bool;

    /// What it does on the GPU, for `explain`.
    fn detail(&self) -> String {
        self.reference().name().to_string()
    }

    /// The GPU buffers it allocates, in words.
    fn owns(&self) -> String {
        self.reference().owns()
    }

    /// The focal depth of the last frame it blurred (mm), for a
    /// depth-of-field pass.
    fn focal_depth_mm(&self) -> Option<f64> {
        None
    }

    /// Whether it holds the attention model's GPU buffers.
    fn has_attention_buffers(&self) -> bool {
        false
    }
}

/// The pass a post pass of the scene file runs after the method.
pub fn pass_for(effect: &PostPass) -> Option<Box<dyn Pass>> {
    match effect {
        PostPass::PorOverlay { half_px } => Some(Box::new(por_overlay::PorOverlay {
            half_px: i64::from(*half_px),
        })),
        PostPass::DepthOfField { method, .. } => match method {
            DofMethod::Mipmap => depth_of_field::DepthOfField::from_effect(effect)
                .map(|p| Box::new(p) as Box<dyn Pass>),
            DofMethod::Splat => dof_splat::DepthOfFieldSplat::from_effect(effect)
                .map(|p| Box::new(p) as Box<dyn Pass>),
        },
    }
}

/// The passes for `scene`, in the order its file lists them, plus the POR
/// overlay when `por_overlay` asks for it and the scene does not.
pub fn passes_for(scene: &Scene, por_overlay: bool) -> Vec<Box<dyn Pass>> {
    let mut passes: Vec<Box<dyn Pass>> = scene.passes().iter().filter_map(pass_for).collect();
    if por_overlay && !scene.has_pass(&PostPass::POR_OVERLAY) {
        passes.push(Box::new(por_overlay::PorOverlay::default()));
    }
    passes
}
