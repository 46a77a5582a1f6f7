//! Murphy 2007 Fig. 4.2: the highest spatial frequency perceptible at
//! every pixel, cycles per degree — the Geisler–Perry cut-off (eq. 4.3) at
//! the pixel's eccentricity and the model's contrast, which dictates the
//! intermediate mesh's sampling there.

use crate::registry::{DebugMap, MapInput, MapValues};

/// The `cutoff` debug map's registration.
pub static MAP: DebugMap = DebugMap {
    name: "cutoff",
    help: "per-pixel CSF cut-off frequency, cycles/degree (Murphy 2007 Fig. 4.2)",
    make,
};

fn make(input: &MapInput<'_>) -> Result<MapValues, String> {
    let (csf, contrast) = (input.model.csf, input.model.contrast);
    MapValues::per_pixel(input, "cycles/deg", move |sampler, p| {
        let e = sampler.spacing_at(p).eccentricity_deg;
        csf.cutoff_frequency_cpd(contrast, e) as f32
    })
}
