//! What a hybrid frame keeps across frames (the mask, vertex hits, flags,
//! pixel owners, and with reuse on the cache of cast samples) and the stage
//! times of the last frame.

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
///
/// [`Scratch::default`] keeps buffers only. [`Scratch::with_reuse`] also
/// keeps the samples it casts for the next frames (temporal reuse during
/// fixations, see the [`render`](mod@crate::render) module): the frames are the same,
/// byte for byte, with or without it.
#[derive(Debug, Default)]
pub struct Scratch {
    pub(super) mask: Option<RayMask>,
    /// What `mask` was built from; `None` while it is being rebuilt.
    pub(super) source: Option<MaskSource>,
    /// Counts the masks built into `mask`, with a number of this scratch's
    /// own: a consumer of the mask (the GPU core's upload) can tell one it
    /// already has ([`Scratch::mask_for`]).
    pub(super) generation: (u64, u64),
    pub(super) vertex_hits: Vec<Option<Hit>>,
    pub(super) refined: Vec<bool>,
    pub(super) touched: Vec<bool>,
    pub(super) owner: Vec<AtomicU32>,
    pub(super) stages: StageTimes,
    /// The cache of cast samples; `None` with reuse off.
    pub(super) reuse: Option<Box<Reuse>>,
}

/// What a kept mask was built from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct MaskSource {
    model: SamplingModel,
    layout: Layout,
    gaze_px: [f64; 2],
}

impl MaskSource {
    /// Whether the mask built from `self` serves a frame for `other`: the
    /// same model and layout, and the same gaze (when `same_gaze` counts)
    /// or one within the model's gaze tolerance of the mask's POR.
    fn holds(&self, mask: &RayMask, other: &MaskSource, same_gaze: bool) -> bool {
        self.model == other.model
            && self.layout == other.layout
            && (same_gaze && self.gaze_px.map(f64::to_bits) == other.gaze_px.map(f64::to_bits) || {
                let g = &self.model.geometry;
                let [w, h] = g.size_px();
                let gaze = foveation::mask::stand_in_por(other.gaze_px, w, h);
                self.model.within_tolerance(mask.por_px, gaze)
            })
    }
}

/// Distinguishes scratches in [`Scratch::mask_for`]'s generations.
static SCRATCHES: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);

impl Scratch {
    /// Makes [`Scratch::mask`] the ray mask for a frame at `gaze_px`: the
    /// kept one when, with a gaze tolerance
    /// ([`SamplingModel::gaze_tolerance_deg`]), the gaze is within it of the
    /// kept mask's POR, or, with reuse on, the gaze is the one it was built
    /// for (same model and layout in both cases); else rebuilt in place for
    /// this gaze. (Without reuse or a tolerance every frame builds its mask,
    /// so that a repeated gaze times a whole frame.) Returns whether it was kept, and its generation (a
    /// pair that differs for every mask this or any other scratch built).
    /// On error (a non-finite gaze) the kept mask stays as it was.
    pub fn mask_for(
        &mut self,
        model: &SamplingModel,
        layout: Layout,
        gaze_px: [f64; 2],
    ) -> Result<(bool, (u64, u64)), foveation::ParamError> {
        let wanted = MaskSource {
            model: *model,
            layout,
            gaze_px,
        };
        let kept = match (&self.mask, &self.source) {
            (Some(m), Some(s)) => s.holds(m, &wanted, self.reuse.is_some()),
            _ => false,
        };
        if !kept {
            match &mut self.mask {
                Some(m) => mask::rebuild(m, model, layout, gaze_px)?,
                None => self.mask = Some(mask::build(model, layout, gaze_px)?),
            }
            self.source = Some(wanted);
            if self.generation.0 == 0 {
                self.generation.0 = SCRATCHES.fetch_add(1, Ordering::Relaxed);
            }
            self.generation.1 += 1;
        }
        Ok((kept, self.generation))
    }

    /// The ray mask of the last foveated frame (or [`Scratch::mask_for`]).
    pub fn mask(&self) -> Option<&RayMask> {
        self.mask.as_ref()
    }

    /// A scratch with temporal reuse on: foveated frames take the hits of
    /// pixel centres cast by earlier frames from a per-pixel cache, and
    /// keep a whole frame's vertex rays, classification and owners while
    /// the mask stays bit-identical. The cache (28 bytes a pixel) is
    /// allocated by the first foveated frame.
    pub fn with_reuse() -> Self {
        let mut s = Self::default();
        s.set_reuse(true);
        s
    }

    /// Turns temporal reuse on (keeping any cache) or off (dropping it).
    pub fn set_reuse(&mut self, on: bool) {
        match (on, self.reuse.is_some()) {
            (true, false) => self.reuse = Some(Box::default()),
            (false, true) => self.reuse = None,
            _ => {}
        }
    }

    /// Whether temporal reuse is on.
    pub fn reuse(&self) -> bool {
        self.reuse.is_some()
    }

    /// Forgets every kept sample and frame (the cache stays allocated). Not
    /// needed for correctness when the scene, camera or settings change —
    /// those are detected — only for a scene whose geometry was edited in
    /// place without a new [`Scene::revision`].
    pub fn invalidate(&mut self) {
        if let Some(r) = self.reuse.as_deref_mut() {
            r.invalidate();
        }
    }

    /// Wall time of each stage of the last frame rendered with it.
    pub fn stages(&self) -> &StageTimes {
        &self.stages
    }

    /// What temporal reuse did in the last frame (zero with reuse off).
    pub fn reuse_stats(&self) -> ReuseStats {
        self.reuse
            .as_deref()
            .map_or_else(ReuseStats::default, |r| r.stats)
    }
}

/// Milliseconds since `t`, and resets `t` to now.
pub(super) fn lap(t: &mut Instant) -> f64 {
    let now = Instant::now();
    let ms = (now - *t).as_secs_f64() * 1e3;
    *t = now;
    ms
}
