//! Lee's attention model (2009 ch. 3, `crates/attention`) run on rendered
//! frames: which object the viewer attends, frame after frame, from the
//! G-buffer's colour, eye distance and object ids alone. Depth of field's
//! `focus: Attention` focuses on it; the viewer's attention gaze source
//! reports its saliency peak as the point of regard.
//!
//! Decisions where the seed is silent or the scene says nothing: the first
//! `attention::frame::MAX_OBJECTS` objects are listed (later ids count as
//! background), each object's task importance is the scene file's
//! `importance` (default 1), objects and camera move as the scene's
//! paths say (`raycast::motion`; a static scene's stand still): each
//! object's motion (Lee eq. 3.3) is the velocity of its bounding box's
//! fastest corner relative to the viewer, and the camera's (eq. 3.9) the
//! viewer's velocity in the display's frame, whose view direction is −z;
//! both at the time the scene was posed for the frame
//! (`raycast::Scene::pose`). The Kalman filter's time step is the frames'
//! time difference (0 without a clock). The tracker's own constants and
//! threshold are `attention::AttentionConfig`'s defaults.
//!
//! Two paths run the model: [`FrameAttention::update`] on a frame read back
//! to the CPU (the reference; the CPU backend's path), and, inside the GPU
//! backend's depth-of-field pass, its per-pixel part on the GPU frame's own
//! buffers before any read-back (`crate::gpu_attention` states the split
//! and the tolerance). Both finish the frame in the same CPU tracker, so
//! the contexts, filter and ranking are one piece of code. The GPU state is
//! made by the first GPU frame only.

use raycast::gpu::{wgpu, GpuError, GpuFrame};
use raycast::{Frame, Scene};

use crate::gpu::{GpuSaliency, PrepareError, SaliencyInput};

/// The model and what it needs between frames.
pub struct FrameAttention {
    tracker: attention::AttentionTracker,
    objects: Vec<attention::ObjectInfo>,
    features: attention::Features,
    last_time_s: Option<f64>,
    attended: Option<u32>,
    /// The per-pixel part on the GPU: made by the first frame measured
    /// there, `None` on the CPU path.
    gpu: Option<Box<GpuSaliency>>,
}

impl std::fmt::Debug for FrameAttention {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FrameAttention")
            .field("map_size", &self.tracker.map_size())
            .field("attended", &self.attended)
            .finish_non_exhaustive()
    }
}

impl FrameAttention {
    /// A model with saliency maps of `map_size`² (64 to 512).
    pub fn new(map_size: u32) -> Result<Self, String> {
        Self::with_features(map_size, attention::Features::ALL)
    }

    /// A model with only `features` switched on (Lee's Table 3.2 groups:
    /// [`attention::Features::lee_groups`]).
    pub fn with_features(map_size: u32, features: attention::Features) -> Result<Self, String> {
        let mut config = attention::AttentionConfig::with_map_size(map_size);
        config.features = features;
        Ok(Self {
            tracker: attention::AttentionTracker::new(config).map_err(|e| e.to_string())?,
            objects: Vec::new(),
            features,
            last_time_s: None,
            attended: None,
            gpu: None,
        })
    }

    /// Whether the GPU passes' shader and buffers exist (made by the first
    /// frame measured on the GPU; never on the CPU path).
    pub fn has_gpu_buffers(&self) -> bool {
        self.gpu.as_ref().is_some_and(|g| g.has_buffers())
    }

    /// The object attended in the last frame, if any.
    pub fn attended(&self) -> Option<u32> {
        self.attended
    }

    /// The features this model runs.
    pub fn features(&self) -> attention::Features {
        self.features
    }

    /// Runs the model on `frame` (whose surface buffers must be filled)
    /// of `scene` as posed for it (its objects' task importances
    /// `Scene::object_importance` and, when it moves, the velocities of
    /// `Scene::pose`), at `time_s`. `None` when the frame cannot be read
    /// (no surface buffers, a size the model refuses); the result's
    /// `attended` is `None` when no object reaches the threshold.
    pub fn update(
        &mut self,
        frame: &Frame,
        scene: &Scene,
        time_s: Option<f64>,
    ) -> Option<attention::Attention> {
        let (camera, dt) = self.frame_inputs(scene, time_s);
        let view = attention::FrameView {
            width: frame.width_px,
            height: frame.height_px,
            rgb: &frame.rgb,
            depth_mm: &frame.depth_mm,
            object: &frame.object,
        };
        let result = self.tracker.update(&view, &self.objects, camera, dt).ok();
        self.attended = result.as_ref().and_then(|r| r.attended);
        result
    }

    /// [`FrameAttention::update`] on a frame still on the GPU, before its
    /// read-back: the per-pixel part runs on its colour, depth and object-id
    /// buffers (encoded after `encoder`'s passes, then one wait for the
    /// per-object statistics), the CPU tracker finishes it. Returns a fresh
    /// encoder for the rest of the frame. `Ok((None, …))` when the model
    /// refuses the frame (a size it does not take).
    pub(crate) fn update_on_gpu(
        &mut self,
        frame: &GpuFrame<'_>,
        encoder: wgpu::CommandEncoder,
        scene: &Scene,
        time_s: Option<f64>,
    ) -> Result<(Option<attention::Attention>, wgpu::CommandEncoder), GpuError> {
        let (camera, dt) = self.frame_inputs(scene, time_s);
        let config = *self.tracker.config();
        let gpu = self
            .gpu
            .get_or_insert_with(|| Box::new(GpuSaliency::new(config)));
        let input = SaliencyInput {
            device: frame.device(),
            queue: frame.queue(),
            traffic: frame.traffic(),
            pixels: frame.pixels(),
            depth: frame.depth(),
            ids: frame.object_ids(),
            width: frame.width(),
            height: frame.height(),
            max_binding: frame.max_binding_bytes(),
        };
        match gpu.prepare(&input, &self.objects) {
            Ok(()) => {}
            Err(PrepareError::Attention(_)) => {
                self.attended = None;
                return Ok((None, encoder));
            }
            Err(PrepareError::Gpu(e)) => return Err(e),
        }
        let (measure, next) = gpu.measure(&input, encoder)?;
        let result = self
            .tracker
            .update_measured(&measure, &self.objects, camera, dt)
            .ok();
        self.attended = result.as_ref().and_then(|r| r.attended);
        Ok((result, next))
    }

    /// The attended object's mean eye distance on a GPU frame, mm, or
    /// `None` ([`FrameAttention::depth_mm`]'s GPU twin).
    pub(crate) fn depth_mm_on_gpu(
        &mut self,
        frame: &GpuFrame<'_>,
        encoder: wgpu::CommandEncoder,
        scene: &Scene,
        time_s: Option<f64>,
    ) -> Result<(Option<f64>, wgpu::CommandEncoder), GpuError> {
        let (result, next) = self.update_on_gpu(frame, encoder, scene, time_s)?;
        Ok((result.as_ref().and_then(attended_depth_mm), next))
    }

    /// The object list (rebuilt when the scene's importances or velocities
    /// changed), the camera's motion and the time step for this frame.
    fn frame_inputs(
        &mut self,
        scene: &Scene,
        time_s: Option<f64>,
    ) -> (attention::CameraMotion, f64) {
        let importance = &scene.object_importance;
        let listed = &importance[..importance.len().min(attention::frame::MAX_OBJECTS)];
        let pose = scene.pose();
        let velocity = |id: usize| {
            pose.and_then(|p| p.object_velocity_mm_per_s.get(id))
                .copied()
                .unwrap_or([0.0; 3])
        };
        let same = self.objects.len() == listed.len()
            && self
                .objects
                .iter()
                .zip(listed)
                .enumerate()
                .all(|(id, (o, &i))| {
                    o.importance.to_bits() == i.to_bits()
                        && o.motion_mm_per_s.map(f32::to_bits) == velocity(id).map(f32::to_bits)
                });
        if !same {
            self.objects.clear();
            self.objects.extend(
                listed
                    .iter()
                    .enumerate()
                    .map(|(id, &i)| attention::ObjectInfo {
                        id: id as u32,
                        importance: i,
                        motion_mm_per_s: velocity(id),
                    }),
            );
        }
        let camera = pose.map_or(attention::CameraMotion::STATIC, |p| {
            attention::CameraMotion::new([0.0, 0.0, -1.0], p.camera_velocity_mm_per_s)
        });
        let dt = match (self.last_time_s, time_s) {
            (Some(a), Some(b)) if b.is_finite() && b >= a => b - a,
            _ => 0.0,
        };
        if let Some(t) = time_s.filter(|t| t.is_finite()) {
            self.last_time_s = Some(t);
        }
        (camera, dt)
    }

    /// The attended object's mean eye distance in `frame`, mm, or `None`.
    pub fn depth_mm(&mut self, frame: &Frame, scene: &Scene, time_s: Option<f64>) -> Option<f64> {
        attended_depth_mm(&self.update(frame, scene, time_s)?)
    }

    /// The attended object's saliency peak in `frame` (screen px): a point
    /// of regard; `None` when nothing is attended.
    pub fn gaze_px(
        &mut self,
        frame: &Frame,
        scene: &Scene,
        time_s: Option<f64>,
    ) -> Option<[f64; 2]> {
        gaze_of(&self.update(frame, scene, time_s)?)
    }
}

/// The attended object's saliency peak (screen px), when finite.
fn gaze_of(result: &attention::Attention) -> Option<[f64; 2]> {
    let p = result.gaze_px?;
    let p = [f64::from(p[0]), f64::from(p[1])];
    (p[0].is_finite() && p[1].is_finite()).then_some(p)
}

/// Lee's attention model as the gaze source, a pass at the end of the
/// plan: it runs the model on every finished frame, and its saliency peak
/// ([`AttentionGaze::gaze_px`]) is the point of regard the viewer feeds to
/// the next frames (`Renderer::set_attention_gaze`). On the GPU backend it
/// measures the GPU frame before any read-back (one wait for the
/// per-object statistics: `crate::gpu_attention` states the split and the
/// tolerance), so the frame itself can stay on the GPU.
pub struct AttentionGaze {
    model: FrameAttention,
    gaze: Option<[f64; 2]>,
}

impl AttentionGaze {
    /// The gaze source for attention model `model`; no gaze until its first frame.
    pub fn new(model: FrameAttention) -> Self {
        Self { model, gaze: None }
    }

    /// The last frame's attended saliency peak (screen px); `None` when
    /// nothing was attended (or before the first frame).
    pub fn gaze_px(&self) -> Option<[f64; 2]> {
        self.gaze
    }

    /// The model, for its state (the attended object, its GPU buffers).
    pub fn model(&self) -> &FrameAttention {
        &self.model
    }
}

impl crate::effects::Pass for AttentionGaze {
    fn name(&self) -> &'static str {
        "attention gaze source (Lee ch. 3)"
    }

    fn run(&mut self, frame: &mut Frame, input: &crate::effects::PassInput<'_>) {
        self.gaze = self
            .model
            .update(frame, input.scene, input.time_s)
            .as_ref()
            .and_then(gaze_of);
    }

    fn as_any(&self) -> &dyn std::any::Any {
        self
    }

    fn reads(&self) -> crate::plan::Channels {
        use crate::plan::Channels;
        Channels::COLOUR | Channels::DEPTH | Channels::ID
    }

    fn writes(&self) -> crate::plan::Channels {
        crate::plan::Channels::NONE
    }

    fn owns(&self) -> String {
        let m = self.model.tracker.map_size();
        format!("the saliency maps ({m}²) and the per-object statistics")
    }

    fn into_gpu(
        self: Box<Self>,
    ) -> Result<Box<dyn crate::effects::GpuPass>, Box<dyn crate::effects::Pass>> {
        Ok(Box::new(GpuAttentionGaze { pass: *self }))
    }
}

/// [`AttentionGaze`] on the GPU frame.
struct GpuAttentionGaze {
    pass: AttentionGaze,
}

impl crate::effects::GpuPass for GpuAttentionGaze {
    fn reference(&self) -> &dyn crate::effects::Pass {
        &self.pass
    }

    fn encode(
        &mut self,
        frame: &GpuFrame<'_>,
        encoder: wgpu::CommandEncoder,
        input: &crate::effects::PassInput<'_>,
    ) -> Result<wgpu::CommandEncoder, GpuError> {
        let (result, next) =
            self.pass
                .model
                .update_on_gpu(frame, encoder, input.scene, input.time_s)?;
        self.pass.gaze = result.as_ref().and_then(gaze_of);
        Ok(next)
    }

    fn has_buffers(&self) -> bool {
        self.pass.model.has_gpu_buffers()
    }

    fn has_attention_buffers(&self) -> bool {
        self.pass.model.has_gpu_buffers()
    }

    fn detail(&self) -> String {
        "attention gaze source (Lee ch. 3): the model's per-pixel part on the frame's colour, \
         depth and ids on the GPU, the per-object statistics read back (one wait), contexts, \
         Kalman filter and ranking on the CPU; its saliency peak is the next frames' gaze"
            .into()
    }
}

/// The attended object's mean eye distance, mm, when finite and positive.
fn attended_depth_mm(result: &attention::Attention) -> Option<f64> {
    let d = f64::from(result.get(result.attended?)?.distance_mm);
    (d.is_finite() && d > 0.0).then_some(d)
}
