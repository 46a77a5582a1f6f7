//! The sampling model every command renders with.

use foveation::{GeislerPerry, SamplingModel, ScreenGeometry};

/// The Geisler–Perry CSF (Murphy 2007 eq. 4.3) at Michelson contrast
/// `contrast`, ray spacing clamped to the seed's n_max (17 px, §4.2).
pub fn sampling_model(
    geometry: ScreenGeometry,
    contrast: f64,
) -> Result<SamplingModel, foveation::ParamError> {
    SamplingModel::new(
        geometry,
        GeislerPerry::default(),
        contrast,
        foveation::sampling::SEED_MAX_SPACING_PX,
    )
}

/// [`sampling_model`] with another CSF (a participant's fitted
/// Geisler–Perry parameters, `--thresholds FILE`).
pub fn sampling_model_with(
    geometry: ScreenGeometry,
    csf: GeislerPerry,
    contrast: f64,
) -> Result<SamplingModel, foveation::ParamError> {
    SamplingModel::new(
        geometry,
        csf,
        contrast,
        foveation::sampling::SEED_MAX_SPACING_PX,
    )
}
