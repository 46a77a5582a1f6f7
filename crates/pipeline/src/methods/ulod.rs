//! Lee 2009 ch. 7: attention-guided level of detail with ULOD's blend of
//! adjacent levels, the levels set by Lee's attention model on the
//! previous frame; no eye tracker needed. CPU raster. The model and the
//! levels are [`crate::ulod`]'s.

use raycast::render::Stats;
use raycast::Frame;

use crate::plan::Side;
use crate::registry::{FrameMethod, MethodContext, MethodFrame, MethodModule, MethodSetup};
use crate::ulod::Ulod;
use crate::RenderError;

/// The levels (`ULOD5`, Lee's largest set) and the attention map's size.
pub const ULOD_LEVELS: usize = 5;
/// Side of the square attention map the model computes, pixels.
pub const ULOD_MAP_SIZE: u32 = 64;

/// The `ulod` method's registration.
pub static METHOD: MethodModule = MethodModule {
    name: "ulod",
    aliases: &["attention-lod"],
    help: "Lee 2009 ch. 7: attention-guided level of detail with ULOD's blend of adjacent levels \
           (`ULOD5`: 1, 1/4, … 1/256 of each object's triangles by quadric simplification), \
           levels set by Lee's attention model on the previous frame; no eye tracker \
           needed. CPU raster",
    foveated: false,
    gpu: false,
    gpu_post: false,
    static_scene: true,
    make,
};

fn make(setup: &MethodSetup<'_>) -> Result<Box<dyn FrameMethod>, RenderError> {
    let levels =
        crate::ulod::scene_levels(setup.scene, ULOD_LEVELS).map_err(RenderError::Unsupported)?;
    Ok(Box::new(UlodMethod {
        ulod: Ulod::new(levels, ULOD_LEVELS, ULOD_MAP_SIZE).map_err(RenderError::Unsupported)?,
        attention_ms: 0.0,
    }))
}

/// The method's state: the levels and the attention model, and the
/// model's time on the last frame (ms; it set this frame's levels).
pub struct UlodMethod {
    /// The levels of every object and the attention model.
    pub ulod: Ulod,
    /// The attention model's time on the last frame, ms.
    pub attention_ms: f64,
}

impl FrameMethod for UlodMethod {
    fn render(&mut self, input: MethodFrame<'_>, frame: &mut Frame) -> Result<Stats, RenderError> {
        let started = std::time::Instant::now();
        let t = input.time_s.is_finite().then_some(input.time_s);
        self.ulod
            .draw(input.scene, input.camera, self.attention_ms, frame);
        // The next frame's levels come from this frame, read now, before
        // any pass draws on it (Lee's previous frame).
        self.attention_ms = self.ulod.observe(input.scene, frame, t);
        Ok(Stats {
            time_ms: started.elapsed().as_secs_f64() * 1e3,
            ..Stats::default()
        })
    }

    fn detail(&self, _: &MethodContext<'_>) -> String {
        format!(
            "per frame: Lee's attention model ({ULOD_MAP_SIZE}² maps) on the previous frame sets each object's level L = {}(1 − S_o/max S_o) (Lee eq. 7.3); level ⌊L⌋ drawn opaque and ⌊L⌋+1 blended over it with opacity L − ⌊L⌋ (ULOD), levels of 4^−l of the triangles by quadric simplification; CPU z-buffer",
            ULOD_LEVELS - 1
        )
    }

    fn owns(&self, _: Side) -> String {
        format!("{ULOD_LEVELS} levels per object and {ULOD_MAP_SIZE}² attention maps")
    }

    fn as_any(&self) -> &dyn std::any::Any {
        self
    }
}
