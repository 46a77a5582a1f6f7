//! Nested layers (Guenter et al. 2012, `--method layers`): the cores
//! follow the display's CSF (every pixel finer than a layer's step is in a
//! finer layer's core, checked pixel by pixel), the inner core is the full
//! frame, fewer rays than the full frame, every edge handled, the GPU's
//! layers equal the CPU's, and nothing allocated before the first frame.
//! The method is reached only by its name, as a lab reaches it.

use foveation::{Display, SamplingModel};
use pipeline::methods::layers::{core_half_size, Layers};
use pipeline::{BackendChoice, Method, Options, Renderer};
use proptest::prelude::*;
use raycast::scene::{Effect, Sampling};
use raycast::{Camera, Frame, Scene};

use fixtures::display_17in as display;

fn scene(name: &str) -> Scene {
    fixtures::scene_with_effects(name, vec![Effect::FoveatedSampling])
}

fn model(d: &Display) -> SamplingModel {
    pipeline::sampling_model(d.geometry().expect("geometry"), 1.0).expect("model")
}

fn layers() -> Method {
    Method::from_name("layers").expect("registered")
}

fn renderer<'s>(s: &'s Scene, d: &Display, method: Method, backend: BackendChoice) -> Renderer<'s> {
    let m = model(d);
    Renderer::new(
        s,
        Camera::new(&m.geometry),
        m,
        &Options {
            method,
            backend,
            ..Options::default()
        },
    )
    .unwrap_or_else(|e| panic!("{e} — the GPU cases need Mesa's lavapipe (scripts/system-deps.sh)"))
}

fn state<'a>(r: &'a Renderer<'_>) -> Option<&'a Layers> {
    r.method_state().as_any().downcast_ref()
}

/// Every pixel whose allowed spacing is below `below` lies within the
/// core's half-size of the gaze — scanned pixel by pixel.
#[test]
fn each_core_holds_every_pixel_finer_than_the_next_layer() {
    for (w, h, inset) in [(1280, 1024, 0.0), (640, 512, 0.0), (1280, 1024, 8.0)] {
        let d = display(w, h);
        let m = model(&d).with_inset_deg(inset).expect("inset");
        for gaze in [
            [640.0, 512.0],
            [10.0, 20.0],
            [1270.5, 1000.0],
            [300.3, 700.7],
            [-40.0, 500.0],
        ] {
            let sampler = m.from_por(gaze);
            for below in [2.0, 4.0] {
                let core = core_half_size(&sampler, gaze, (w, h), below, inset / 2.0);
                let mut worst: f64 = -1.0;
                for y in 0..h {
                    for x in 0..w {
                        let p = [f64::from(x) + 0.5, f64::from(y) + 0.5];
                        let s = sampler.spacing_at(p);
                        let fine = s.eccentricity_deg < inset / 2.0 || s.spacing_px < below;
                        if fine {
                            worst = worst.max((p[0] - gaze[0]).abs().max((p[1] - gaze[1]).abs()));
                        }
                    }
                }
                match core {
                    Some(r) => assert!(
                        worst <= r && r <= worst + 1.5,
                        "{w}x{h} inset {inset} gaze {gaze:?} below {below}: core {r}, farthest fine pixel {worst}"
                    ),
                    None => assert!(worst < 0.0, "{gaze:?} {below}: no core but {worst}"),
                }
            }
        }
    }
}

#[test]
fn the_inner_core_is_the_full_frame_and_costs_fewer_rays() {
    let d = display(1280, 1024);
    let s = scene("search-task");
    let mut full = renderer(&s, &d, Method::Full, BackendChoice::Cpu);
    let mut lay = renderer(&s, &d, layers(), BackendChoice::Cpu);
    assert_eq!(
        state(&lay).expect("layers state").allocated_bytes(),
        0,
        "nothing before the first frame"
    );
    for gaze in [[640.0, 512.0], [200.0, 150.0], [1200.0, 900.0]] {
        let (f, fs) = full.render(gaze).expect("full");
        let (l, ls) = lay.render(gaze).expect("layers");
        let st = state(&lay).expect("layers state");
        let rects = st.last_layers();
        assert_eq!(rects.len(), 3, "{gaze:?}: {rects:?}");
        let core = rects[0].core_px;
        let (mut n, mut differ) = (0usize, 0usize);
        for y in 0..1024usize {
            for x in 0..1280usize {
                let p = [x as f64 + 0.5, y as f64 + 0.5];
                if (p[0] - gaze[0]).abs().max((p[1] - gaze[1]).abs()) <= core {
                    n += 1;
                    let i = 3 * (y * 1280 + x);
                    if f.rgb[i..i + 3] != l.rgb[i..i + 3] {
                        differ += 1;
                    }
                }
            }
        }
        println!(
            "gaze {gaze:?}: inner core ±{core:.1} px ({n} px), {differ} differ from the full frame; \
             rays {} of {} ({:.1} %)",
            ls.rays_total,
            fs.rays_total,
            100.0 * ls.rays_total as f64 / fs.rays_total as f64
        );
        assert!(n > 1000, "{gaze:?}: the core is not empty");
        // The window camera's rays are the display's, bit for bit.
        assert_eq!(differ, 0, "{gaze:?}: {differ} of {n}");
        assert!(ls.rays_total < fs.rays_total, "{gaze:?}");
        assert_eq!(ls.rays_total, ls.rays_fovea + ls.rays_mask);
        assert!(l.hit.iter().any(|&h| h));
    }
    assert!(state(&lay).expect("state").allocated_bytes() > 0);
}

/// On a display whose pixels are coarser than any spacing the CSF allows
/// (320×256 on 17"), the inner core holds the whole screen: the frame is
/// the full frame, and the coarser layers are not rendered.
#[test]
fn a_core_that_holds_the_screen_leaves_nothing_to_the_outer_layers() {
    let d = display(320, 256);
    let s = scene("search-task");
    let mut full = renderer(&s, &d, Method::Full, BackendChoice::Cpu);
    let mut lay = renderer(&s, &d, layers(), BackendChoice::Cpu);
    let (f, fs) = full.render([100.0, 80.0]).expect("full");
    let (l, ls) = lay.render([100.0, 80.0]).expect("layers");
    assert_eq!(state(&lay).expect("state").last_layers().len(), 1);
    assert_eq!(ls.rays_total, fs.rays_total);
    let differ = f
        .rgb
        .chunks(3)
        .zip(l.rgb.chunks(3))
        .filter(|(a, b)| a != b)
        .count();
    assert!(differ * 1000 <= f.len(), "{differ}");
}

#[test]
fn the_method_is_named_explained_and_recorded() {
    let d = display(320, 256);
    let s = scene("search-task");
    let r = renderer(&s, &d, layers(), BackendChoice::Cpu);
    assert_eq!(r.method(), layers());
    assert_eq!(r.provenance(), "layers on cpu; passes: none");
    let text = r.explain().join("\n");
    assert!(text.contains("Guenter et al. 2012"), "{text}");
    assert!(text.contains("1. layers [cpu]"), "{text}");
    // Without FoveatedSampling the scene is rendered at full resolution.
    let mut plain = scene("search-task");
    plain.sampling = Sampling::Full;
    plain.passes.clear();
    assert_eq!(layers().for_scene(&plain), Method::Full);
    // Other methods build nothing of it.
    let r = renderer(&s, &d, Method::Hybrid, BackendChoice::Cpu);
    assert!(state(&r).is_none());
}

#[test]
fn the_gpu_layers_are_the_cpu_layers() {
    let d = display(640, 512);
    let s = scene("search-task");
    let mut cpu = renderer(&s, &d, layers(), BackendChoice::Cpu);
    let mut gpu = renderer(&s, &d, layers(), BackendChoice::Gpu);
    assert_eq!(gpu.provenance(), "layers on gpu; passes: none");
    for gaze in [[320.0, 256.0], [20.0, 480.0]] {
        let (c, cs) = cpu.render(gaze).expect("cpu");
        let n_layers = state(&cpu).expect("state").last_layers().len();
        assert!(n_layers >= 2, "{gaze:?}: a coarser layer is exercised");
        let (g, gs) = gpu.render(gaze).expect("gpu");
        assert_eq!(cs.rays_total, gs.rays_total);
        let worst = c
            .rgb
            .iter()
            .zip(&g.rgb)
            .map(|(a, b)| a.abs_diff(*b))
            .max()
            .unwrap_or(0);
        let off = c
            .rgb
            .chunks_exact(3)
            .zip(g.rgb.chunks_exact(3))
            .filter(|(a, b)| a.iter().zip(b.iter()).any(|(x, y)| x.abs_diff(*y) > 2))
            .count();
        println!("gaze {gaze:?}: worst channel difference {worst}, {off} pixels off by > 2");
        // The GPU core's f32 cast against the CPU's (tests/gpu.rs): a few
        // silhouette pixels may take the other surface.
        assert!(off * 200 <= c.len(), "{gaze:?}: {off}");
    }
}

#[test]
fn a_gaze_that_is_not_finite_is_refused_and_tiny_frames_render() {
    let s = scene("search-task");
    let d = display(64, 48);
    let mut r = renderer(&s, &d, layers(), BackendChoice::Cpu);
    for bad in [[f64::NAN, 1.0], [1.0, f64::INFINITY]] {
        let e = r.render(bad).expect_err("refused");
        assert!(e.to_string().contains("finite"), "{e}");
    }
    for (w, h) in [(1, 1), (3, 2), (2, 3)] {
        let d = display(w, h);
        let mut r = renderer(&s, &d, layers(), BackendChoice::Cpu);
        for gaze in [[0.0, 0.0], [0.5, 0.5], [1e9, -1e9], [-3.0, 2.0]] {
            let (f, st) = r.render(gaze).expect("frame");
            assert_eq!((f.width_px, f.height_px), (w, h));
            assert!(st.rays_total >= 1, "some layer covers the screen");
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(fixtures::proptest_cases(24)))]
    /// Any finite gaze, near or far, on small screens: a frame of the
    /// screen's size, the outer layer always there, the rays counted.
    #[test]
    fn any_finite_gaze_gives_a_whole_frame(
        w in 1u32..48, h in 1u32..40,
        gx in prop_oneof![-1e6..1e6f64, -100.0..150.0f64],
        gy in prop_oneof![-1e6..1e6f64, -100.0..150.0f64],
    ) {
        let s = scene("search-task");
        let d = display(w, h);
        let mut r = renderer(&s, &d, layers(), BackendChoice::Cpu);
        let (f, st): (Frame, _) = r.render([gx, gy]).expect("frame");
        prop_assert_eq!(f.rgb.len(), 3 * (w * h) as usize);
        // Never more than the full frame plus the two coarser layers.
        let bound = u64::from(w * h) * 2;
        prop_assert!(st.rays_total >= 1 && st.rays_total <= bound);
        prop_assert_eq!(st.rays_total, st.rays_fovea + st.rays_mask);
    }
}
