//! Murphy 2007 Fig. 4.1: the eccentricity of every pixel from the point of
//! regard, degrees, through the display's geometry (the eye at its
//! distance and position; [`foveation::ScreenGeometry`]).

use crate::registry::{DebugMap, MapInput, MapValues};

/// The `eccentricity` debug map's registration.
pub static MAP: DebugMap = DebugMap {
    name: "eccentricity",
    help: "per-pixel eccentricity from the gaze, degrees (Murphy 2007 Fig. 4.1)",
    make,
};

fn make(input: &MapInput<'_>) -> Result<MapValues, String> {
    MapValues::per_pixel(input, "deg", |sampler, p| {
        sampler.spacing_at(p).eccentricity_deg as f32
    })
}
