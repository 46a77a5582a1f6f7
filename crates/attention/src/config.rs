//! Parameters of the tracker, with the values chosen for the seed's gaps
//! (see the crate docs for why).

use crate::error::AttentionError;

/// Smallest saliency map side (Lee §3.4 tests 64² to 512²).
pub const MIN_MAP_SIZE: u32 = 64;
/// Largest saliency map side.
pub const MAX_MAP_SIZE: u32 = 512;
/// Longest temporal-context window accepted, frames.
pub const MAX_TEMPORAL_WINDOW: u32 = 10_000;

/// `c_s` that makes the largest spatial context exactly 0.5:
/// `max_u u·e^{-u²} = 1/√(2e)` at `u = 1/√2`, so `c_s = 0.5·√(2e)` ≈ 1.1658.
pub const SPATIAL_SCALE_FOR_HALF: f32 = 1.165_821_3;

/// Which parts of the model run. Lee's ablation groups (Table 3.2) are
/// B = {luminance, hue}, E = {depth, size, motion}, T = {spatial, temporal};
/// [`Features::lee_groups`] builds those. A switched-off feature costs no
/// work and contributes nothing.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Features {
    /// `B_l` (group B).
    pub luminance: bool,
    /// `B_h` (group B).
    pub hue: bool,
    /// `B_d`, eq. 3.1 (group E).
    pub depth: bool,
    /// `B_s`, eq. 3.2 (group E).
    pub size: bool,
    /// `B_m`, eq. 3.3 (group E).
    pub motion: bool,
    /// `T_s`, eq. 3.9 (group T).
    pub spatial_context: bool,
    /// `T_t`, eq. 3.10 (group T).
    pub temporal_context: bool,
}

impl Features {
    /// Everything on (Lee's "all components").
    pub const ALL: Self = Self::lee_groups(true, true, true);
    /// Everything off: every visible object's attention is its importance
    /// (ties broken by id). Lee's "baseline" instead picks a random pixel;
    /// a caller simulates that itself.
    pub const NONE: Self = Self::lee_groups(false, false, false);

    /// Lee's Table 3.2 groups: `b` = image features, `e` = 3-D/object
    /// features, `t` = top-down contexts.
    pub const fn lee_groups(b: bool, e: bool, t: bool) -> Self {
        Self {
            luminance: b,
            hue: b,
            depth: e,
            size: e,
            motion: e,
            spatial_context: t,
            temporal_context: t,
        }
    }

    /// The five bottom-up switches in `Feature::ALL` order: luminance,
    /// hue, depth, size, motion.
    pub const fn as_array(&self) -> [bool; 5] {
        [self.luminance, self.hue, self.depth, self.size, self.motion]
    }

    /// Any bottom-up feature on.
    pub fn any_bottom_up(&self) -> bool {
        self.as_array().contains(&true)
    }

    /// Any top-down context on.
    pub fn any_context(&self) -> bool {
        self.spatial_context || self.temporal_context
    }
}

impl Default for Features {
    fn default() -> Self {
        Self::ALL
    }
}

/// Spatial context constants (Lee eq. 3.9).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpatialContextParams {
    /// `L`, the distance of greatest emphasis, mm; `c_x = L / 0.707`.
    pub max_emphasis_distance_mm: f32,
    /// `c_y` of the screen-centre term `e^{-c_y y²}`, with `y` the distance
    /// from the screen centre over half the screen diagonal.
    pub screen_centre_falloff: f32,
    /// `c_s`; at most [`SPATIAL_SCALE_FOR_HALF`] so that `T_s <= 0.5`.
    pub scale: f32,
}

impl Default for SpatialContextParams {
    fn default() -> Self {
        Self {
            max_emphasis_distance_mm: 3_000.0,
            screen_centre_falloff: 3.0,
            scale: SPATIAL_SCALE_FOR_HALF,
        }
    }
}

/// Noise of the per-object constant-velocity Kalman filter (Lee §3.2.1,
/// §3.3, after Welch & Bishop \[98\]). State: attention and its rate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KalmanParams {
    /// Spectral density of the white-noise rate change, attention²/s³.
    pub process_noise: f64,
    /// Variance of one attention measurement, attention².
    pub measurement_noise: f64,
}

impl Default for KalmanParams {
    fn default() -> Self {
        Self {
            process_noise: 1.0,
            measurement_noise: 0.05 * 0.05,
        }
    }
}

/// Everything [`crate::AttentionTracker::new`] needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AttentionConfig {
    /// Saliency map side, `MIN_MAP_SIZE..=MAX_MAP_SIZE`; the map is square
    /// whatever the frame's aspect (as Lee's textures).
    pub map_size: u32,
    /// Which features and contexts run.
    pub features: Features,
    /// `z_near` of eq. 3.1, mm.
    pub depth_near_mm: f32,
    /// `z_far` of eq. 3.1, mm; background pixels take `B_d = 1`.
    pub depth_far_mm: f32,
    /// Spatial context constants.
    pub spatial: SpatialContextParams,
    /// `λ` of eq. 3.10, in frames.
    pub temporal_window_frames: u32,
    /// Kalman noise.
    pub kalman: KalmanParams,
    /// Smallest smoothed attention that makes an object "attended", in (0, 1].
    pub attention_threshold: f32,
}

impl Default for AttentionConfig {
    fn default() -> Self {
        Self {
            map_size: 64,
            features: Features::ALL,
            depth_near_mm: 100.0,
            depth_far_mm: 100_000.0,
            spatial: SpatialContextParams::default(),
            temporal_window_frames: 60,
            kalman: KalmanParams::default(),
            attention_threshold: 0.01,
        }
    }
}

impl AttentionConfig {
    /// The default configuration at another map size.
    pub fn with_map_size(map_size: u32) -> Self {
        Self {
            map_size,
            ..Self::default()
        }
    }

    /// Checks every field; the tracker does this in `new`.
    pub fn validate(&self) -> Result<(), AttentionError> {
        if !(MIN_MAP_SIZE..=MAX_MAP_SIZE).contains(&self.map_size) {
            return Err(AttentionError::MapSizeOutOfRange {
                size: self.map_size,
                min: MIN_MAP_SIZE,
                max: MAX_MAP_SIZE,
            });
        }
        let invalid = |field: &'static str, reason: &str| {
            Err(AttentionError::InvalidConfig {
                field,
                reason: reason.to_owned(),
            })
        };
        let near = self.depth_near_mm;
        let far = self.depth_far_mm;
        if !(near.is_finite() && near >= 0.0) {
            return invalid("depth_near_mm", "use a finite distance >= 0 mm");
        }
        if !(far.is_finite() && far > near) {
            return invalid(
                "depth_far_mm",
                "use a finite distance greater than depth_near_mm",
            );
        }
        let s = &self.spatial;
        if !(s.max_emphasis_distance_mm.is_finite() && s.max_emphasis_distance_mm > 0.0) {
            return invalid(
                "spatial.max_emphasis_distance_mm",
                "use a finite distance > 0 mm",
            );
        }
        if !(s.screen_centre_falloff.is_finite() && s.screen_centre_falloff >= 0.0) {
            return invalid("spatial.screen_centre_falloff", "use a finite value >= 0");
        }
        if !(s.scale.is_finite() && s.scale > 0.0 && s.scale <= SPATIAL_SCALE_FOR_HALF) {
            return invalid(
                "spatial.scale",
                "use a value in (0, 1.1658]; larger lets T_s exceed 0.5 (Lee eq. 3.9)",
            );
        }
        if !(1..=MAX_TEMPORAL_WINDOW).contains(&self.temporal_window_frames) {
            return invalid("temporal_window_frames", "use 1 to 10000 frames");
        }
        let k = &self.kalman;
        if !(k.process_noise.is_finite() && k.process_noise >= 0.0) {
            return invalid("kalman.process_noise", "use a finite value >= 0");
        }
        if !(k.measurement_noise.is_finite() && k.measurement_noise > 0.0) {
            return invalid("kalman.measurement_noise", "use a finite value > 0");
        }
        let t = self.attention_threshold;
        if !(t.is_finite() && t > 0.0 && t <= 1.0) {
            return invalid("attention_threshold", "use a value in (0, 1]");
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tracker::Feature;

    #[test]
    fn the_feature_array_is_in_feature_order() {
        for (i, feature) in Feature::ALL.iter().enumerate() {
            let mut f = Features::NONE;
            match feature {
                Feature::Luminance => f.luminance = true,
                Feature::Hue => f.hue = true,
                Feature::Depth => f.depth = true,
                Feature::Size => f.size = true,
                Feature::Motion => f.motion = true,
            }
            let on = f.as_array();
            assert!(
                on[i] && on.iter().filter(|&&b| b).count() == 1,
                "{feature:?}"
            );
            assert!(f.any_bottom_up());
        }
        assert_eq!(Features::ALL.as_array(), [true; 5]);
        assert!(!Features::lee_groups(false, false, true).any_bottom_up());
    }
}
