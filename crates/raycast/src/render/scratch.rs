//! What a hybrid frame keeps across frames (the mask, vertex hits, flags,
//! pixel owners) and the stage times of the last frame.

use super::*;

/// Wall time of each stage of one CPU frame (ms), in the order they run.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize)]
pub struct StageTimes {
    /// Building the ray mask for the gaze.
    pub mask: f64,
    /// Casting a ray through every mesh vertex.
    pub vertex_rays: f64,
    /// Classifying cells homogeneous or heterogeneous.
    pub classify: f64,
    /// Widening the refined cells by the silhouette margin.
    pub margin: f64,
    /// Giving every pixel its owner (fovea or one cell).
    pub ownership: f64,
    /// Casting or interpolating every pixel, and shading it.
    pub pixels: f64,
    /// Of `pixels`: time spent casting and shading the fovea and refined
    /// pixels, summed over the threads (CPU ms, not wall time).
    pub pixel_casts_cpu: f64,
}

impl StageTimes {
    /// The stages by name, in the order they run.
    pub fn named(&self) -> [(&'static str, f64); 7] {
        [
            ("mask", self.mask),
            ("vertex rays", self.vertex_rays),
            ("classify", self.classify),
            ("margin", self.margin),
            ("ownership", self.ownership),
            ("pixels", self.pixels),
            ("pixel casts (cpu)", self.pixel_casts_cpu),
        ]
    }
}

/// What a foveated frame needs besides the frame itself (the mask, the
/// vertex hits, the refined flags, the pixel owners), kept across frames so
/// that a renderer allocates nothing per frame once it has had one frame of
/// this size; and the stage times of the last frame.
#[derive(Debug, Default)]
pub struct Scratch {
    pub(super) mask: Option<RayMask>,
    pub(super) vertex_hits: Vec<Option<Hit>>,
    pub(super) refined: Vec<bool>,
    pub(super) touched: Vec<bool>,
    pub(super) owner: Vec<AtomicU32>,
    pub(super) stages: StageTimes,
}

impl Scratch {
    /// Wall time of each stage of the last frame rendered with it.
    pub fn stages(&self) -> &StageTimes {
        &self.stages
    }
}

/// Milliseconds since `t`, and resets `t` to now.
pub(super) fn lap(t: &mut Instant) -> f64 {
    let now = Instant::now();
    let ms = (now - *t).as_secs_f64() * 1e3;
    *t = now;
    ms
}
