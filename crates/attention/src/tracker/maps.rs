//! The saliency maps (Lee §3.1.1, eq. 3.4–3.6): the feature channels of
//! the map cells, their pyramids and contrast maps, and the read-only view
//! of the last frame's maps for debug pictures.

use rayon::prelude::*;

use super::{AttentionTracker, Feature};
use crate::config::AttentionConfig;
use crate::contrast::contrast_weight;
use crate::hls::hue_vector_angle_deg;
use crate::pyramid::Pyramid;

/// Pyramid channels: lightness, hue vector x, hue vector y, depth, size, motion.
pub(super) const CH_L: usize = 0;
pub(super) const CH_HX: usize = 1;
pub(super) const CH_HY: usize = 2;
pub(super) const CH_D: usize = 3;
pub(super) const CH_S: usize = 4;
pub(super) const CH_M: usize = 5;
pub(super) const CHANNELS: usize = 6;

/// Read-only view of the last frame's maps, for debug pictures. Every map
/// is `size × size`, row-major, values in [0, 1] (hue vector components in
/// [−1, 1]). Maps of switched-off features are 0.
pub struct SaliencyMaps<'a> {
    pub(super) tracker: &'a AttentionTracker,
}

impl<'a> SaliencyMaps<'a> {
    /// The map side.
    pub fn size(&self) -> usize {
        self.tracker.map_size()
    }

    /// Level 0 of a scalar feature; `None` for [`Feature::Hue`] (see
    /// [`SaliencyMaps::hue_vector`]).
    pub fn feature(&self, feature: Feature) -> Option<&'a [f32]> {
        let ch = match feature {
            Feature::Luminance => CH_L,
            Feature::Hue => return None,
            Feature::Depth => CH_D,
            Feature::Size => CH_S,
            Feature::Motion => CH_M,
        };
        Some(self.tracker.pyramids[ch].level(0).data)
    }

    /// The chroma-weighted hue vector at level 0, `(C cos h, C sin h)`.
    pub fn hue_vector(&self) -> (&'a [f32], &'a [f32]) {
        (
            self.tracker.pyramids[CH_HX].level(0).data,
            self.tracker.pyramids[CH_HY].level(0).data,
        )
    }

    /// Hue in degrees at level 0 (allocates).
    pub fn hue_angle_deg(&self) -> Vec<f32> {
        let (x, y) = self.hue_vector();
        x.iter()
            .zip(y)
            .map(|(&x, &y)| hue_vector_angle_deg([x, y]))
            .collect()
    }

    /// The pyramid of a scalar feature; `None` for hue.
    pub fn pyramid(&self, feature: Feature) -> Option<&'a Pyramid> {
        let ch = match feature {
            Feature::Luminance => CH_L,
            Feature::Hue => return None,
            Feature::Depth => CH_D,
            Feature::Size => CH_S,
            Feature::Motion => CH_M,
        };
        Some(&self.tracker.pyramids[ch])
    }

    /// The pyramids of the hue vector's two components.
    pub fn hue_pyramids(&self) -> (&'a Pyramid, &'a Pyramid) {
        (&self.tracker.pyramids[CH_HX], &self.tracker.pyramids[CH_HY])
    }

    /// `C_f`, eq. 3.4.
    pub fn contrast(&self, feature: Feature) -> &'a [f32] {
        &self.tracker.contrast[feature.index()]
    }

    /// `w_f`, eq. 3.6, in [`Feature::ALL`] order (0 for off or flat features).
    pub fn weights(&self) -> [f32; 5] {
        self.tracker.weights
    }

    /// `S_p`, [0, 1].
    pub fn pixel_saliency(&self) -> &'a [f32] {
        &self.tracker.saliency
    }
}

impl AttentionTracker {
    /// The pyramids of every enabled channel from the cells (Lee §3.1.1).
    pub(super) fn build_pyramids(&mut self) {
        let m = self.config.map_size;
        let enabled = channel_flags(&self.config);
        let side = m as usize;
        let cells = &self.cells;
        self.pyramids
            .par_iter_mut()
            .enumerate()
            .for_each(|(ch, pyramid)| {
                let base = pyramid.base_mut(side, side);
                if enabled[ch] {
                    for (b, c) in base.iter_mut().zip(cells) {
                        *b = c[ch];
                    }
                } else {
                    base.fill(0.0);
                }
                pyramid.rebuild();
            });
    }

    /// Eq. 3.4 per enabled feature, and the weights of eq. 3.6.
    pub(super) fn contrast_maps(&mut self) {
        let on = self.config.features.as_array();
        for (i, feature) in Feature::ALL.iter().enumerate() {
            let out = &mut self.contrast[i];
            if !on[i] {
                out.fill(0.0);
                self.weights[i] = 0.0;
                continue;
            }
            match feature {
                Feature::Hue => {
                    let (px, py) = (&self.pyramids[CH_HX], &self.pyramids[CH_HY]);
                    self.centre_surround.hue(px, py, out);
                }
                _ => {
                    let ch = match feature {
                        Feature::Luminance => CH_L,
                        Feature::Depth => CH_D,
                        Feature::Size => CH_S,
                        _ => CH_M,
                    };
                    self.centre_surround.scalar(&self.pyramids[ch], out);
                }
            }
            self.weights[i] = contrast_weight(out);
        }
    }
}

pub(super) fn channel_flags(config: &AttentionConfig) -> [bool; CHANNELS] {
    let [luminance, hue, depth, size, motion] = config.features.as_array();
    [luminance, hue, hue, depth, size, motion]
}
