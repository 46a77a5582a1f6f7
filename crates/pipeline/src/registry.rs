//! Method modules and debug maps, registered by one line each.
//!
//! A new rendering method is a file in [`crate::methods`] that implements
//! [`FrameMethod`] and declares its `METHOD: MethodModule` (name, aliases,
//! help, whether it follows the gaze and whether it has a GPU path), plus
//! its name in that module's `register!` line. From there the method is a
//! [`Method`](crate::Method) everywhere: the command line's `--method`, an
//! experiment condition's `method:`, `explain`, the frame plan and every
//! frame's provenance. A new debug map (a per-pixel quantity drawn as a
//! picture, `render --map`) is a file in [`crate::maps`] declaring its
//! `MAP: DebugMap`, and its name in that module's `register!` line.

use std::fmt;

use foveation::SamplingModel;
use raycast::gpu::{GpuPost, GpuRenderer};
use raycast::ray::TriangleTest;
use raycast::render::{Scratch, Stats};
use raycast::{Camera, Frame, Scene};

use crate::effects::Pass;
use crate::plan::{Channels, Side};
use crate::{Options, RenderError};

/// What a method module's frame gets.
pub struct MethodFrame<'a> {
    /// The scene as posed for this frame.
    pub scene: &'a Scene,
    /// The camera the frame is rendered from.
    pub camera: &'a Camera,
    /// The sampling model this frame is rendered under (the CSF at the
    /// display's geometry and the measured eye distance).
    pub model: &'a SamplingModel,
    /// The ray/triangle intersection test to use.
    pub test: TriangleTest,
    /// The point of regard, screen pixels.
    pub gaze_px: [f64; 2],
    /// The frame's time, s.
    pub time_s: f64,
    /// The binocular gaze point's eye distance for this frame (mm), when
    /// the tracker gave one.
    pub vergence_mm: Option<f64>,
    /// Fill the surface buffers (depth, id, normal): a later pass reads them.
    pub surface: bool,
    /// The ray caster's CPU buffers (mask, vertex hits, owners, stage
    /// times), the renderer's for its life: nothing is allocated in them
    /// until a method uses them.
    pub scratch: &'a mut Scratch,
    /// The GPU core, when the method renders on the GPU backend.
    pub gpu: Option<&'a mut GpuRenderer>,
    /// The GPU passes to encode between the cast and the read-back, for a
    /// method that declares [`MethodModule::gpu_post`] (none otherwise).
    pub post: Option<&'a mut dyn GpuPost>,
}

/// What `explain` and the frame plan tell a method about where it runs.
pub struct MethodContext<'a> {
    /// The sampling model the frame is rendered under.
    pub model: &'a SamplingModel,
    /// Where the method runs: CPU or GPU.
    pub side: Side,
    /// Whether the renderer keeps cast samples across frames
    /// ([`crate::Options::reuse`]).
    pub reuse: bool,
}

/// A method module's state: made once per renderer, then one frame at a time.
pub trait FrameMethod: Send {
    /// Fills `frame` (sized to the camera) for this frame.
    fn render(&mut self, input: MethodFrame<'_>, frame: &mut Frame) -> Result<Stats, RenderError>;
    /// What it does per frame, for `explain` (may span lines).
    fn detail(&self, on: &MethodContext<'_>) -> String;
    /// The buffers it owns, in words.
    fn owns(&self, side: Side) -> String;
    /// The G-buffer channels it writes besides the surface buffers (which
    /// it fills when [`MethodFrame::surface`] asks).
    fn writes(&self) -> Channels {
        Channels::COLOUR | Channels::HIT
    }
    /// The method's own passes, which run first after it (image-based
    /// foveation's blur); taken once, when the renderer is made.
    fn own_passes(&mut self) -> Vec<Box<dyn Pass>> {
        Vec::new()
    }
    /// The state itself, for callers that inspect a known method.
    fn as_any(&self) -> &dyn std::any::Any;
    /// The model-based methods' state, to give it a participant's
    /// thresholds ([`crate::Renderer::set_thresholds`]); `None` for the
    /// other methods.
    fn model_based_mut(&mut self) -> Option<&mut crate::model_based::ModelBased> {
        None
    }
}

/// What a method module is made from.
pub struct MethodSetup<'a> {
    /// The scene as loaded (not yet posed for a frame).
    pub scene: &'a Scene,
    /// The camera the frames are rendered from.
    pub camera: &'a Camera,
    /// The sampling model (the CSF at the display's geometry).
    pub model: &'a SamplingModel,
    /// What the command line (or design) chose: layout, triangle test,
    /// refinement triggers, the model-based options.
    pub options: &'a Options,
}

/// A rendering method: the built-in ones ([`crate::methods`]) and the
/// registered modules alike.
pub struct MethodModule {
    /// Its one name: on the command line, in designs, in reports and
    /// `--stats`, in every frame's provenance.
    pub name: &'static str,
    /// Other names accepted for it.
    pub aliases: &'static [&'static str],
    /// One line of help.
    pub help: &'static str,
    /// Whether it follows the gaze: unless the scene samples `Foveated`
    /// the scene is rendered at full resolution instead, like every
    /// foveated method.
    pub foveated: bool,
    /// Whether it renders on the GPU backend (its frame gets
    /// [`MethodFrame::gpu`]); without, `backend gpu` is refused and `auto`
    /// renders it on the CPU.
    pub gpu: bool,
    /// Whether its GPU frame takes the GPU passes between its cast and its
    /// read-back ([`MethodFrame::post`]); without, every pass runs on the
    /// CPU after it.
    pub gpu_post: bool,
    /// Whether it builds its state from the scene once (levels of detail),
    /// so that a moving scene is refused.
    pub static_scene: bool,
    /// Makes its state for a renderer.
    pub make: fn(&MethodSetup<'_>) -> Result<Box<dyn FrameMethod>, RenderError>,
}

impl PartialEq for MethodModule {
    fn eq(&self, other: &Self) -> bool {
        self.name == other.name
    }
}

impl Eq for MethodModule {}

impl fmt::Debug for MethodModule {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("MethodModule")
            .field("name", &self.name)
            .finish_non_exhaustive()
    }
}

/// The registered method modules (the built-in methods are
/// [`crate::Method`]'s named variants).
pub static METHODS: &[&MethodModule] = crate::methods::ALL;

/// What a debug map is drawn for.
pub struct MapInput<'a> {
    /// The sampling model (the CSF at the display's geometry and eye distance).
    pub model: &'a SamplingModel,
    /// The point of regard, screen pixels.
    pub gaze_px: [f64; 2],
    /// Screen width, pixels.
    pub width_px: u32,
    /// Screen height, pixels.
    pub height_px: u32,
}

/// A per-pixel quantity, row-major.
#[derive(Debug, Clone, PartialEq)]
pub struct MapValues {
    /// Width, pixels.
    pub width_px: u32,
    /// Height, pixels.
    pub height_px: u32,
    /// The value at each pixel, row-major, in `unit`.
    pub values: Vec<f32>,
    /// The quantity's unit, for the picture's caption.
    pub unit: &'static str,
}

impl MapValues {
    /// The map of `f` at every pixel centre of the input's screen, for its
    /// gaze, rows in parallel. A gaze that is not finite is refused; the
    /// size is checked against [`MAX_MAP_PIXELS`].
    pub fn per_pixel(
        input: &MapInput<'_>,
        unit: &'static str,
        f: impl Fn(&foveation::sampling::PorSampler, [f64; 2]) -> f32 + Sync,
    ) -> Result<MapValues, String> {
        use rayon::prelude::*;
        let g = input.gaze_px;
        if !(g[0].is_finite() && g[1].is_finite()) {
            return Err(format!(
                "the point of regard must be finite, got ({}, {})",
                g[0], g[1]
            ));
        }
        let (w, h) = (input.width_px, input.height_px);
        let n = u64::from(w) * u64::from(h);
        if n > MAX_MAP_PIXELS {
            return Err(format!(
                "{w}×{h}: a map holds at most {MAX_MAP_PIXELS} pixels"
            ));
        }
        let sampler = input.model.from_por(g);
        let mut values = vec![0.0f32; n as usize];
        if w > 0 {
            values
                .par_chunks_mut(w as usize)
                .enumerate()
                .for_each(|(y, row)| {
                    for (x, v) in row.iter_mut().enumerate() {
                        *v = f(&sampler, [x as f64 + 0.5, y as f64 + 0.5]);
                    }
                });
        }
        Ok(MapValues {
            width_px: w,
            height_px: h,
            values,
            unit,
        })
    }
}

/// The most pixels a debug map holds (an 8K display, 33 MP, with room).
pub const MAX_MAP_PIXELS: u64 = 1 << 26;

/// A registered debug map.
pub struct DebugMap {
    /// The name `render --map NAME=FILE.png` takes.
    pub name: &'static str,
    /// One line of help (with its seed figure).
    pub help: &'static str,
    /// Draws the map for an input, or says why it cannot.
    pub make: fn(&MapInput<'_>) -> Result<MapValues, String>,
}

impl fmt::Debug for DebugMap {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("DebugMap")
            .field("name", &self.name)
            .finish_non_exhaustive()
    }
}

/// The registered debug maps.
pub static MAPS: &[&DebugMap] = crate::maps::ALL;

/// The registered map called `name`.
pub fn map(name: &str) -> Option<&'static DebugMap> {
    MAPS.iter().copied().find(|m| m.name == name)
}
