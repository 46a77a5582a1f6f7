//! Saccades of the simulated eye: how long (the main sequence) and along
//! which path in time (a smooth profile).

/// Duration of a saccade of `amplitude_deg` degrees, in ms, by the linear
/// main sequence `D = 2.2·A + 21 ms`: the classic fit of saccade duration
/// against amplitude (Carpenter 1988, *Movements of the Eyes*, 2nd ed.,
/// London: Pion), also the model of PsychoPy iohub's MouseGaze. Every
/// simulated saccade in gazecast (the device simulator, the mouse
/// emulator, the demo's scanpath) takes its duration from here.
pub fn main_sequence_duration_ms(amplitude_deg: f64) -> f64 {
    2.2 * amplitude_deg + 21.0
}

/// Fraction of the way a saccade has covered at fraction `s` ∈ [0, 1] of
/// its duration: the raised cosine `½ − ½·cos(π·s)`, which starts and ends
/// at zero velocity with the peak velocity at mid-flight. A smooth
/// stand-in chosen for the simulation, not a fitted velocity profile (real
/// saccades are skewed, reaching their peak velocity before mid-flight).
pub fn saccade_profile(s: f64) -> f64 {
    0.5 - 0.5 * (std::f64::consts::PI * s).cos()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_main_sequence_and_the_profile() {
        assert_eq!(main_sequence_duration_ms(0.0), 21.0);
        assert!((main_sequence_duration_ms(10.0) - 43.0).abs() < 1e-12);
        assert_eq!(saccade_profile(0.0), 0.0);
        assert!((saccade_profile(0.5) - 0.5).abs() < 1e-12);
        assert!((saccade_profile(1.0) - 1.0).abs() < 1e-12);
        // Symmetric: as far from the end at 1 − s as from the start at s.
        for s in [0.1, 0.25, 0.4] {
            assert!((saccade_profile(s) + saccade_profile(1.0 - s) - 1.0).abs() < 1e-12);
        }
    }
}
