//! What the tracker returns for a frame: the features it weighs, each
//! object's result and the frame's ranking.

/// The five bottom-up features (Lee §3.1.1).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Feature {
    /// `B_l`: HLS lightness.
    Luminance,
    /// `B_h`: HLS hue (a chroma-weighted hue vector).
    Hue,
    /// `B_d`: normalised depth, eq. 3.1.
    Depth,
    /// `B_s`: object size, eq. 3.2.
    Size,
    /// `B_m`: object motion, eq. 3.3.
    Motion,
}

impl Feature {
    /// All five, in the order of [`SaliencyMaps::weights`](crate::SaliencyMaps::weights).
    pub const ALL: [Feature; 5] = [
        Feature::Luminance,
        Feature::Hue,
        Feature::Depth,
        Feature::Size,
        Feature::Motion,
    ];

    pub(super) fn index(self) -> usize {
        self as usize
    }
}

/// One object's result for a frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ObjectAttention {
    /// The object's id.
    pub id: u32,
    /// Smoothed attention (Kalman-filtered `S_o`), [0, 1]. The ranking's key.
    pub attention: f32,
    /// `S_o` of this frame before smoothing (eq. 3.8), [0, 1].
    pub raw_attention: f32,
    /// `Ŝ_o`, eq. 3.7: importance times mean pixel saliency, [0, 1].
    pub object_saliency: f32,
    /// `T_s`, eq. 3.9, [0, 0.5] (computed even when switched off).
    pub spatial_context: f32,
    /// `T_t`, eq. 3.10, [0, 0.5].
    pub temporal_context: f32,
    /// Pixels of the object in the frame.
    pub pixel_count: u64,
    /// Mean eye distance of its pixels with a finite depth, mm (`x` of
    /// eq. 3.9; `depth_far_mm` if none has one).
    pub distance_mm: f32,
    /// Centroid of its pixels, frame pixels (x right, y down, pixel centres
    /// at +0.5).
    pub screen_centre_px: [f32; 2],
    /// Saliency peak on the object, frame pixels: the centroid of the
    /// object's pixels inside the saliency map cell with the highest `S_p`
    /// (ties: the lowest cell index). The centroid when the map is flat.
    pub peak_px: [f32; 2],
}

/// One frame's result.
#[derive(Clone, Debug, PartialEq)]
pub struct Attention {
    /// Visible listed objects with importance > 0, highest smoothed
    /// attention first; equal attention: lower id first.
    pub ranking: Vec<ObjectAttention>,
    /// The first of `ranking` if its attention reaches the configured
    /// threshold; `None` otherwise (e.g. an empty frame).
    pub attended: Option<u32>,
    /// The attended object's saliency peak, frame pixels: a gaze point.
    pub gaze_px: Option<[f32; 2]>,
    /// False when no bottom-up feature carried any contrast (or all were
    /// switched off); pixel saliency was then 1 everywhere.
    pub bottom_up_informative: bool,
    /// Pixels with the background id.
    pub background_pixels: u64,
    /// Pixels with an id missing from the object list (treated as background).
    pub unlisted_pixels: u64,
}

impl Attention {
    /// The ranking's ids, best first (for [`crate::eval::top_k_hit`]).
    pub fn ranking_ids(&self) -> Vec<u32> {
        self.ranking.iter().map(|o| o.id).collect()
    }

    /// The entry of object `id`, if ranked.
    pub fn get(&self, id: u32) -> Option<&ObjectAttention> {
        self.ranking.iter().find(|o| o.id == id)
    }
}
