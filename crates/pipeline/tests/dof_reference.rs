//! The depth-of-field pass (Lee 2009 ch. 4) against thin-lens distributed
//! ray casting (64 stratified pupil rays per pixel), on a background-blur
//! and a foreground-blur scene. The PSNRs print with
//! `cargo test -p pipeline --test dof_reference -- --nocapture`.

use foveation::thin_lens::EyeLens;
use foveation::Display;
use pipeline::effects::dof_reference::{
    concentric_disc, equivalent_pupil_mm, psnr, pupil_samples, render_reference, REFERENCE_SIDE,
};
use pipeline::{BackendChoice, Options, Renderer};
use raycast::{Camera, Scene};

const W: u32 = 160;
const H: u32 = 128;
const PUPIL_MM: f64 = 16.0;

fn display() -> Display {
    Display::seed_17in(W, H)
}

#[path = "common/dof_wall.rs"]
mod dof_wall;
use dof_wall::{NEAR_BALL, SCREEN_BALL};

fn scene(front: &str, effects: &str) -> Scene {
    dof_wall::wall(front, effects).expect("the wall builds")
}

fn render(scene: &Scene) -> Vec<u8> {
    let g = display().geometry().expect("geometry");
    let model = pipeline::sampling_model(g, 1.0).expect("model");
    let mut r = Renderer::new(
        scene,
        Camera::new(&g),
        model,
        &Options {
            backend: BackendChoice::Cpu,
            surface: true,
            ..Options::default()
        },
    )
    .expect("renderer");
    r.render_at([80.0, 64.0], 0.0).expect("renders").0.rgb
}

fn lens() -> EyeLens {
    EyeLens {
        aperture_mm: PUPIL_MM,
        ..EyeLens::default()
    }
}

fn camera() -> Camera {
    Camera::new(&display().geometry().expect("geometry"))
}

/// (PSNR of the pass, PSNR of the sharp frame) against the reference.
fn compare(front: &str, focus_mm: f64) -> (f64, f64) {
    let sharp_scene = scene(front, "");
    let sharp = render(&sharp_scene);
    let dof_scene = scene(
        front,
        &format!("DepthOfField(pupil_mm: {PUPIL_MM}, focus: Fixed(depth_mm: {focus_mm}))"),
    );
    let pass = render(&dof_scene);
    let reference = render_reference(
        &sharp_scene,
        &camera(),
        &lens(),
        focus_mm,
        REFERENCE_SIDE,
        1,
    );
    (psnr(&pass, &reference), psnr(&sharp, &reference))
}

#[test]
fn the_reference_with_a_pinhole_is_the_renderers_frame() {
    let s = scene(SCREEN_BALL, "");
    let sharp = render(&s);
    let pinhole = EyeLens {
        aperture_mm: 0.0,
        ..EyeLens::default()
    };
    let reference = render_reference(&s, &camera(), &pinhole, 480.0, 2, 1);
    let off: Vec<usize> = (0..sharp.len())
        .filter(|&i| sharp[i].abs_diff(reference[i]) > 1)
        .collect();
    // Only rounding of the ray direction may flip a silhouette pixel.
    assert!(
        off.len() * 1000 <= sharp.len(),
        "{} of {} samples differ by more than 1",
        off.len(),
        sharp.len()
    );
    assert!(psnr(&sharp, &reference) > 40.0);
}

#[test]
fn the_pupil_samples_are_stratified_on_the_disc_and_deterministic() {
    let s = pupil_samples(REFERENCE_SIDE, 17, 3);
    assert_eq!(s.len(), 64);
    assert_eq!(s, pupil_samples(REFERENCE_SIDE, 17, 3));
    assert_ne!(s, pupil_samples(REFERENCE_SIDE, 18, 3));
    assert!(s.iter().all(|p| p[0].hypot(p[1]) <= 1.0 + 1e-12));
    // Equal-area strata: 16 in each quadrant, and a quarter inside r = 1/2.
    for q in 0..4 {
        let n = s
            .iter()
            .filter(|p| (p[0] >= 0.0) == (q & 1 == 0) && (p[1] >= 0.0) == (q & 2 == 0))
            .count();
        assert_eq!(n, 16, "quadrant {q}");
    }
    let inner = s.iter().filter(|p| p[0].hypot(p[1]) < 0.5).count();
    assert!((12..=20).contains(&inner), "{inner}");
    assert_eq!(concentric_disc(0.5, 0.5), [0.0, 0.0]);
    // The equivalent pupil gives eq. 4.4's CoC: at infinity E·F/d_r.
    let l = lens();
    let a = equivalent_pupil_mm(&l, f64::INFINITY);
    assert!((a - PUPIL_MM * 16.7 / 24.0).abs() < 1e-12);
    let (d, df, ds) = (2000.0, 480.0, 540.0);
    let geometric = equivalent_pupil_mm(&l, df) * ds * (d - df) / (df * d);
    let lee = l.coc_px(d, df, ds, 1.0).expect("coc");
    assert!((geometric - lee).abs() < 1e-9 * lee, "{geometric} {lee}");
}

/// The pass is closer to the ground truth than the unblurred frame, and
/// the PSNRs (Lee reports 37.66 dB background, 35.41 dB foreground).
#[test]
fn the_ch4_pass_is_closer_to_the_reference_than_the_sharp_frame() {
    let (bg_pass, bg_sharp) = compare(SCREEN_BALL, 480.0);
    let (fg_pass, fg_sharp) = compare(NEAR_BALL, 1950.0);
    eprintln!(
        "DOF vs thin-lens reference ({W}×{H}, pupil {PUPIL_MM} mm, N = 64): \
         background blur: ch. 4 {bg_pass:.2} dB, unblurred {bg_sharp:.2} dB; \
         foreground blur: ch. 4 {fg_pass:.2} dB, unblurred {fg_sharp:.2} dB"
    );
    assert!(bg_pass > bg_sharp + 1.0, "{bg_pass} vs {bg_sharp}");
    assert!(fg_pass > fg_sharp, "{fg_pass} vs {fg_sharp}");
}

/// 64 rays per pixel are converged well beyond the pass's error: the
/// reference against itself with 256 rays (another jitter) is far closer
/// than any method compared to it.
#[test]
fn sixty_four_rays_are_converged_beyond_the_methods_error() {
    for (front, focus_mm) in [(SCREEN_BALL, 480.0), (NEAR_BALL, 1950.0)] {
        let s = scene(front, "");
        let n64 = render_reference(&s, &camera(), &lens(), focus_mm, REFERENCE_SIDE, 1);
        let n256 = render_reference(&s, &camera(), &lens(), focus_mm, 16, 2);
        let floor = psnr(&n64, &n256);
        eprintln!("reference N = 64 vs N = 256, focus {focus_mm} mm: {floor:.2} dB");
        assert!(floor > 40.0, "{floor}");
    }
}

/// Lee §4.3's foreground smoothing (eqs. 4.10–4.11, `smooth_foreground:
/// true`): in the foreground-blur scene it spreads the near ball's blur
/// over the sharp wall behind its silhouette (printed against the
/// reference, next to the pass without it); in the background-blur scene
/// nothing is in front of the focus, so it changes nothing.
#[test]
fn foreground_smoothing_spreads_the_foreground_blur_and_leaves_a_background_blur_alone() {
    let dof = |focus_mm: f64, smooth: bool| {
        format!(
            "DepthOfField(pupil_mm: {PUPIL_MM}, focus: Fixed(depth_mm: {focus_mm}), smooth_foreground: {smooth})"
        )
    };
    let s = scene(SCREEN_BALL, &dof(480.0, false));
    let t = scene(SCREEN_BALL, &dof(480.0, true));
    assert_eq!(render(&s), render(&t), "no foreground: nothing to smooth");
    let sharp_scene = scene(NEAR_BALL, "");
    let sharp = render(&sharp_scene);
    let plain = render(&scene(NEAR_BALL, &dof(1950.0, false)));
    let smooth = render(&scene(NEAR_BALL, &dof(1950.0, true)));
    let reference = render_reference(&sharp_scene, &camera(), &lens(), 1950.0, REFERENCE_SIDE, 1);
    let changed = plain.iter().zip(&smooth).filter(|(a, b)| a != b).count();
    eprintln!(
        "foreground blur against the reference: ch. 4 {:.2} dB, with foreground smoothing {:.2} dB \
         ({changed} channels changed), unblurred {:.2} dB",
        psnr(&plain, &reference),
        psnr(&smooth, &reference),
        psnr(&sharp, &reference)
    );
    assert!(changed > 30, "smoothing changed only {changed} channels");
    assert!(psnr(&smooth, &reference) > psnr(&sharp, &reference));
}
