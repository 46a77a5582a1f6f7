//! The gaze of a person searching a display for a target, frame by frame:
//! the built-in scanpath of `gazecast demo` when no tracker drives it.

use rand::{Rng, SeedableRng};
use screen_geometry::ScreenGeometry;

use super::saccade::{main_sequence_duration_ms, saccade_profile};

/// The places a search fixates: `start`, then a number of the objects
/// other than the target drawn from `visits` (each visited once, each the
/// nearest of three random candidates from where the eye is, as searches
/// tend to go), then the target. Shared by the demo's scanpath and the
/// experiment's simulated participant.
pub fn search_stops<R: Rng>(
    start: [f64; 2],
    objects: &[[f64; 2]],
    target: [f64; 2],
    visits: std::ops::RangeInclusive<usize>,
    rng: &mut R,
) -> Vec<[f64; 2]> {
    let mut stops = vec![start];
    let mut left: Vec<[f64; 2]> = objects.iter().copied().filter(|o| *o != target).collect();
    let visits = rng.random_range(visits).min(left.len());
    for _ in 0..visits {
        let here = stops[stops.len() - 1];
        let best = (0..3)
            .map(|_| rng.random_range(0..left.len()))
            .min_by(|&a, &b| {
                let d = |i: usize| (left[i][0] - here[0]).hypot(left[i][1] - here[1]);
                d(a).total_cmp(&d(b))
            })
            .unwrap_or(0);
        stops.push(left.swap_remove(best));
    }
    stops.push(target);
    stops
}

/// Gaze (screen px) per frame at `fps` for a search of `objects` that ends
/// on `target`: a fixation at the centre, then 4–6 of the other objects in
/// a seeded order (the nearest of three random candidates each time, as
/// searches tend to go), then the target (fixated twice as long);
/// fixations of 250–450 ms with uniform jitter of ±0.1° (at the centre's
/// pixels per degree), saccades between them with main-sequence durations
/// ([`main_sequence_duration_ms`], amplitudes at the eye from `geometry`)
/// along [`saccade_profile`]. Deterministic for a seed. The fixation
/// durations and the nearest-of-three choice are plausible stand-ins for a
/// search, not fitted to recorded searches.
pub fn search_scanpath(
    geometry: &ScreenGeometry,
    objects: &[[f64; 2]],
    target: [f64; 2],
    fps: f64,
    seed: u64,
) -> Vec<[f64; 2]> {
    let g = geometry;
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    let stops = search_stops(g.centre_px(), objects, target, 4..=6, &mut rng);
    let dt = 1.0 / fps;
    let px_per_deg = g.local_ppd(g.centre_px());
    let mut frames = Vec::new();
    for (k, &stop) in stops.iter().enumerate() {
        if k > 0 {
            let from = stops[k - 1];
            let amp = g.eccentricity_deg(from, stop);
            let dur = main_sequence_duration_ms(amp) / 1000.0;
            let n = (dur / dt).ceil() as usize;
            for i in 1..n {
                let e = saccade_profile(i as f64 / n as f64);
                frames.push([
                    from[0] + (stop[0] - from[0]) * e,
                    from[1] + (stop[1] - from[1]) * e,
                ]);
            }
        }
        let hold = rng.random_range(0.25..0.45) * if k + 1 == stops.len() { 2.0 } else { 1.0 };
        for _ in 0..((hold / dt).round() as usize).max(1) {
            let j = 0.1 * px_per_deg;
            frames.push([
                stop[0] + rng.random_range(-j..j),
                stop[1] + rng.random_range(-j..j),
            ]);
        }
    }
    frames
}

#[cfg(test)]
mod tests {
    use super::*;

    fn geometry() -> ScreenGeometry {
        crate::test_support::seed_display(540.0)
    }

    fn grid() -> Vec<[f64; 2]> {
        (0..25)
            .map(|i| {
                [
                    340.0 + 150.0 * f64::from(i % 5),
                    212.0 + 150.0 * f64::from(i / 5),
                ]
            })
            .collect()
    }

    #[test]
    fn the_scanpath_starts_at_the_centre_and_ends_on_the_target() {
        let g = geometry();
        let objects = grid();
        let target = objects[16];
        let path = search_scanpath(&g, &objects, target, 30.0, 1);
        let close = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).hypot(a[1] - b[1]) < 5.0;
        assert!(close(path[0], g.centre_px()));
        assert!(close(path[path.len() - 1], target));
        assert_eq!(
            path,
            search_scanpath(&g, &objects, target, 30.0, 1),
            "seeded"
        );
        assert!(path.len() > 30 && path.len() < 200, "{}", path.len());
        // No jump between frames longer than a saccade covers in one frame.
        for w in path.windows(2) {
            assert!((w[1][0] - w[0][0]).hypot(w[1][1] - w[0][1]) < 400.0);
        }
    }

    /// Saccades take their main-sequence time: frames in flight lie on
    /// the line between two stops (fixation frames are jittered off it),
    /// and there are as many as the main-sequence duration spans, less the
    /// frame that lands.
    #[test]
    fn saccades_last_their_main_sequence_duration() {
        let g = geometry();
        let c = g.centre_px();
        // Centre → one object (to the right) → the target (below it).
        let (a, t) = ([c[0] + 300.0, c[1]], [c[0] + 300.0, c[1] + 300.0]);
        for fps in [60.0, 1000.0] {
            let path = search_scanpath(&g, &[a, t], t, fps, 5);
            for (from, to) in [(c, a), (a, t)] {
                let d = [to[0] - from[0], to[1] - from[1]];
                let in_flight = path
                    .iter()
                    .filter(|p| {
                        let q = [p[0] - from[0], p[1] - from[1]];
                        let along = (q[0] * d[0] + q[1] * d[1]) / (d[0] * d[0] + d[1] * d[1]);
                        (q[0] * d[1] - q[1] * d[0]).abs() < 1e-6 && along > 0.0 && along < 1.0
                    })
                    .count() as f64;
                let amp = g.eccentricity_deg(from, to);
                let expected = (main_sequence_duration_ms(amp) * fps / 1000.0).ceil() - 1.0;
                assert!(
                    (in_flight - expected).abs() <= 1.0,
                    "{fps} fps, {amp:.1}°: {in_flight} frames in flight, expected {expected}"
                );
            }
        }
    }
}
