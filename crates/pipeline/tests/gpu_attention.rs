//! The GPU path of Lee's attention model (`pipeline::gpu_attention`, the
//! WGSL in `src/gpu/attention.wgsl`) against the CPU tracker
//! (`attention::AttentionTracker`), the reference, on the same frames:
//! synthetic frames (`attention::synthetic`), hand-made edge cases, random
//! frames (proptest) and frames the renderer cast from the shipped scenes;
//! and the renderer's use of it (depth of field focusing on the attended
//! object on the GPU backend, paid for only by scenes that ask).
//!
//! The stated tolerance is `SALIENCY_TOLERANCE` (module docs of
//! `pipeline::gpu_attention`). `cargo test -p pipeline --test gpu_attention
//! -- --nocapture` prints the largest differences measured. Runs on
//! whatever adapter the machine has (Mesa's lavapipe without a GPU); small
//! frames.

use std::collections::HashMap;
use std::path::Path;

use attention::synthetic::SyntheticScene;
use attention::{
    Attention, AttentionConfig, AttentionTracker, CameraMotion, Features, FrameView, ObjectInfo,
    BACKGROUND_ID,
};
use foveation::{Display, SamplingModel};
use pipeline::effects::depth_of_field::DepthOfField;
use pipeline::effects::{Pass, PassInput};
use pipeline::gpu_attention::{states_made_on_this_thread, GpuAttention, SALIENCY_TOLERANCE};
use pipeline::{BackendChoice, Method, Options, Renderer};
use proptest::prelude::*;
use raycast::gpu::GpuRenderer;
use raycast::scene::PostPass;
use raycast::{Camera, Scene, SceneFile};

const TOL: f32 = SALIENCY_TOLERANCE;
/// Eye distances above this (2^29 mm) count as this on the GPU (module
/// docs).
const DEPTH_CAP_MM: f32 = 536_870_912.0;
// 2^26 pixels (the largest frame) at the cap, in 1/256 mm, stay below 2^64:
// the GPU's 64-bit per-object depth sum cannot wrap.
const _: () =
    assert!(attention::frame::MAX_FRAME_PIXELS as u128 * DEPTH_CAP_MM as u128 * 256 < 1u128 << 64);

fn gpu_model(config: AttentionConfig) -> GpuAttention {
    GpuAttention::new(config).unwrap_or_else(|e| {
        panic!("{e} — install Mesa's software Vulkan (Debian: mesa-vulkan-drivers; scripts/system-deps.sh does)")
    })
}

/// The largest differences seen between the two paths.
#[derive(Debug, Default, Clone, Copy)]
struct Worst {
    map: f32,
    object_saliency: f32,
    raw_attention: f32,
    attention: f32,
    distance_rel: f64,
}

impl Worst {
    fn merge(&mut self, o: Worst) {
        self.map = self.map.max(o.map);
        self.object_saliency = self.object_saliency.max(o.object_saliency);
        self.raw_attention = self.raw_attention.max(o.raw_attention);
        self.attention = self.attention.max(o.attention);
        self.distance_rel = self.distance_rel.max(o.distance_rel);
    }
}

/// The mean eye distance the GPU finds for object `id` when one of its
/// finite depths is above the cap: the mean of its finite depths (negative
/// as 0), each capped. `None` when none is above the cap: the CPU's mean
/// is then what the GPU must find.
fn capped_mean_mm(frame: &FrameView<'_>, id: u32) -> Option<f32> {
    let (mut above, mut sum, mut count) = (false, 0.0f64, 0u64);
    for (&o, &z) in frame.object.iter().zip(frame.depth_mm) {
        if o == id && z.is_finite() {
            above |= z > DEPTH_CAP_MM;
            sum += f64::from(z.clamp(0.0, DEPTH_CAP_MM));
            count += 1;
        }
    }
    (above && count > 0).then(|| (sum / count as f64) as f32)
}

/// Checks one frame's results of both paths against the stated tolerance
/// and returns the differences. `cpu_map` is the CPU's `S_p`.
fn compare(
    what: &str,
    frame: &FrameView<'_>,
    cpu: &Attention,
    gpu: &Attention,
    (cpu_map, gpu_map): (&[f32], &[f32]),
    map_size: u32,
    threshold: f32,
) -> Worst {
    let (width, height) = (frame.width, frame.height);
    let mut worst = Worst::default();
    // The map cell of a frame point (a peak is the centroid of an object's
    // pixels inside one cell, so it lies in that cell).
    let (ax, ay) = (
        attention::CellAxis::new(width, map_size).expect("a valid frame side and map size"),
        attention::CellAxis::new(height, map_size).expect("a valid frame side and map size"),
    );
    let cell_value = |p: [f32; 2]| {
        let x = (p[0].floor().max(0.0) as usize).min(width as usize - 1);
        let y = (p[1].floor().max(0.0) as usize).min(height as usize - 1);
        cpu_map[(ay.cell_of[y] * map_size + ax.cell_of[x]) as usize]
    };
    assert_eq!(cpu_map.len(), gpu_map.len(), "{what}: map sizes");
    for (i, (a, b)) in cpu_map.iter().zip(gpu_map).enumerate() {
        assert!(
            b.is_finite() && (0.0..=1.0).contains(b),
            "{what}: S_p[{i}] = {b}"
        );
        let d = (a - b).abs();
        assert!(d <= TOL, "{what}: S_p[{i}] CPU {a} GPU {b}");
        worst.map = worst.map.max(d);
    }
    assert_eq!(
        cpu.bottom_up_informative, gpu.bottom_up_informative,
        "{what}: informative"
    );
    assert_eq!(
        (cpu.background_pixels, cpu.unlisted_pixels),
        (gpu.background_pixels, gpu.unlisted_pixels),
        "{what}: background and unlisted pixels"
    );
    assert_eq!(
        cpu.ranking.len(),
        gpu.ranking.len(),
        "{what}: ranked objects"
    );
    let by_id: HashMap<u32, _> = gpu.ranking.iter().map(|o| (o.id, o)).collect();
    for c in &cpu.ranking {
        let g = by_id
            .get(&c.id)
            .unwrap_or_else(|| panic!("{what}: object {} not ranked on the GPU", c.id));
        for v in [
            g.attention,
            g.raw_attention,
            g.object_saliency,
            g.distance_mm,
        ] {
            assert!(v.is_finite(), "{what}: object {}: {g:?}", c.id);
        }
        assert_eq!(
            c.pixel_count, g.pixel_count,
            "{what}: object {} pixels",
            c.id
        );
        assert_eq!(
            c.screen_centre_px, g.screen_centre_px,
            "{what}: object {} centroid",
            c.id
        );
        assert!(
            (c.spatial_context - g.spatial_context).abs() <= TOL,
            "{what}: object {} spatial context {} vs {}",
            c.id,
            c.spatial_context,
            g.spatial_context
        );
        let ds = (c.object_saliency - g.object_saliency).abs();
        let dr = (c.raw_attention - g.raw_attention).abs();
        let da = (c.attention - g.attention).abs();
        assert!(ds <= TOL, "{what}: object {} Ŝ_o {c:?} vs {g:?}", c.id);
        assert!(dr <= TOL, "{what}: object {} S_o {c:?} vs {g:?}", c.id);
        assert!(
            da <= TOL,
            "{what}: object {} attention {c:?} vs {g:?}",
            c.id
        );
        // The GPU counts eye distances above 2^29 mm as 2^29 mm (stated):
        // where the object has such depths, the mean of its capped depths.
        let expected = capped_mean_mm(frame, c.id).unwrap_or(c.distance_mm);
        let dd = f64::from((expected - g.distance_mm).abs());
        assert!(
            dd <= 0.01 + 1e-5 * f64::from(expected.abs()),
            "{what}: object {} distance CPU {} (expected on the GPU {expected}) vs GPU {}",
            c.id,
            c.distance_mm,
            g.distance_mm
        );
        worst.object_saliency = worst.object_saliency.max(ds);
        worst.raw_attention = worst.raw_attention.max(dr);
        worst.attention = worst.attention.max(da);
        worst.distance_rel = worst
            .distance_rel
            .max(dd / f64::from(expected.abs()).max(1.0));
        if c.peak_px != g.peak_px {
            // Only where the CPU's own map nearly ties the two cells: the
            // GPU's peak must lie on a cell whose CPU S_p is within the
            // tolerance of the CPU peak's.
            assert!(
                (cell_value(c.peak_px) - cell_value(g.peak_px)).abs() <= TOL,
                "{what}: object {} peak {:?} vs {:?}",
                c.id,
                c.peak_px,
                g.peak_px
            );
        }
    }
    // The ranking: the same order except where neighbours are within the
    // tolerance.
    for (i, (c, g)) in cpu.ranking.iter().zip(&gpu.ranking).enumerate() {
        if c.id != g.id {
            let cg = cpu.get(g.id).map(|o| o.attention).unwrap_or(-1.0);
            assert!(
                (c.attention - cg).abs() <= 2.0 * TOL,
                "{what}: rank {i}: CPU {} ({}) GPU {} (CPU {cg})",
                c.id,
                c.attention,
                g.id
            );
        }
    }
    if cpu.attended != gpu.attended {
        let first = cpu.ranking.first().map_or(0.0, |o| o.attention);
        let second = cpu.ranking.get(1).map_or(-1.0, |o| o.attention);
        assert!(
            (first - second).abs() <= 2.0 * TOL || (first - threshold).abs() <= 2.0 * TOL,
            "{what}: attended CPU {:?} GPU {:?}",
            cpu.attended,
            gpu.attended
        );
    } else {
        assert_eq!(cpu.gaze_px.is_some(), gpu.gaze_px.is_some(), "{what}: gaze");
    }
    worst
}

/// Runs `frames` through both paths and compares each.
fn run_both(
    what: &str,
    config: AttentionConfig,
    frames: &[(FrameView<'_>, Vec<ObjectInfo>, CameraMotion)],
) -> Worst {
    let mut cpu = AttentionTracker::new(config).expect("config");
    let mut gpu = gpu_model(config);
    let mut worst = Worst::default();
    for (k, (frame, objects, camera)) in frames.iter().enumerate() {
        let a = cpu
            .update(frame, objects, *camera, 1.0 / 60.0)
            .expect("CPU frame");
        let b = gpu
            .update(frame, objects, *camera, 1.0 / 60.0)
            .expect("GPU frame");
        let map = gpu.saliency_map().expect("read").expect("a frame ran");
        let w = compare(
            &format!("{what}, frame {k}"),
            frame,
            &a,
            &b,
            (cpu.maps().pixel_saliency(), &map),
            config.map_size,
            config.attention_threshold,
        );
        let cw = cpu.maps().weights();
        let gw = gpu.weights();
        if w.map > 1e-6 {
            println!(
                "{what}, frame {k}: S_p differs by {:e}; weights {cw:?}",
                w.map
            );
        }
        for f in 0..5 {
            let rel = (cw[f] - gw[f]).abs() / cw[f].abs().max(f32::MIN_POSITIVE);
            assert!(
                (cw[f] == 0.0 && gw[f] == 0.0) || rel <= 1e-4,
                "{what}, frame {k}: w_{f} CPU {} GPU {}",
                cw[f],
                gw[f]
            );
        }
        worst.merge(w);
    }
    worst
}

#[test]
fn synthetic_frames_agree_within_the_tolerance() {
    let mut all = Worst::default();
    for (w, h, map, discs) in [(320u32, 256u32, 64u32, 30usize), (320, 256, 128, 12)] {
        let mut scene = SyntheticScene::new(w, h, discs, u64::from(w + map)).expect("scene");
        let camera = CameraMotion::new([0.0, 0.0, -1.0], [0.0, 0.0, -800.0]);
        let mut frames = Vec::new();
        let mut owned = Vec::new();
        for _ in 0..4 {
            owned.push(scene.clone());
            scene.advance(0.05);
        }
        for s in &owned {
            frames.push((s.view(), s.objects(), camera));
        }
        let worst = run_both(
            &format!("synthetic {w}x{h} at {map}²"),
            AttentionConfig::with_map_size(map),
            &frames,
        );
        println!("synthetic {w}x{h}, {discs} discs, {map}²: {worst:?}");
        all.merge(worst);
    }
    println!("synthetic, all: {all:?}");
}

/// An owned frame that tests paint into (as `attention`'s tests do).
#[derive(Clone, Debug)]
struct Canvas {
    width: u32,
    height: u32,
    rgb: Vec<u8>,
    depth_mm: Vec<f32>,
    object: Vec<u32>,
}

impl Canvas {
    /// Background only: one colour, infinite depth.
    fn new(width: u32, height: u32, rgb: [u8; 3]) -> Self {
        let n = (width * height) as usize;
        Self {
            width,
            height,
            rgb: rgb.iter().copied().cycle().take(n * 3).collect(),
            depth_mm: vec![f32::INFINITY; n],
            object: vec![BACKGROUND_ID; n],
        }
    }

    fn view(&self) -> FrameView<'_> {
        FrameView {
            width: self.width,
            height: self.height,
            rgb: &self.rgb,
            depth_mm: &self.depth_mm,
            object: &self.object,
        }
    }

    /// Paints `[x0, x1) × [y0, y1)` (clipped).
    fn rect(&mut self, [x0, y0, x1, y1]: [u32; 4], id: u32, rgb: [u8; 3], depth_mm: f32) {
        for y in y0..y1.min(self.height) {
            for x in x0..x1.min(self.width) {
                let i = (y * self.width + x) as usize;
                self.rgb[i * 3..i * 3 + 3].copy_from_slice(&rgb);
                self.depth_mm[i] = depth_mm;
                self.object[i] = id;
            }
        }
    }
}

/// One frame, both paths, a static camera.
fn both_on(what: &str, config: AttentionConfig, canvas: &Canvas, objects: &[ObjectInfo]) -> Worst {
    let worst = run_both(
        what,
        config,
        &[(canvas.view(), objects.to_vec(), CameraMotion::STATIC)],
    );
    println!("{what}: {worst:?}");
    worst
}

fn still(ids: impl IntoIterator<Item = u32>) -> Vec<ObjectInfo> {
    ids.into_iter()
        .map(|id| ObjectInfo::still(id, 1.0))
        .collect()
}

#[test]
fn an_empty_frame_attends_nothing_on_both_paths() {
    let config = AttentionConfig::default();
    // Uniform: no contrast at all (S_p is 1 everywhere, not informative).
    let flat = Canvas::new(160, 128, [40, 90, 200]);
    both_on("empty, flat", config, &flat, &still([0, 1, 2]));
    // A sky gradient: contrast, but no object.
    let mut sky = Canvas::new(160, 128, [0, 0, 0]);
    for y in 0..128 {
        sky.rect(
            [0, y, 160, y + 1],
            BACKGROUND_ID,
            [60, 100, (100 + y) as u8],
            f32::INFINITY,
        );
    }
    let mut cpu = AttentionTracker::new(config).expect("config");
    let mut gpu = gpu_model(config);
    let a = cpu
        .update(&sky.view(), &still([0, 1]), CameraMotion::STATIC, 0.0)
        .expect("cpu");
    let b = gpu
        .update(&sky.view(), &still([0, 1]), CameraMotion::STATIC, 0.0)
        .expect("gpu");
    assert!(a.ranking.is_empty() && b.ranking.is_empty());
    assert_eq!((a.attended, b.attended), (None, None));
    assert!(b.bottom_up_informative, "the gradient has contrast");
    both_on("empty, sky gradient", config, &sky, &[]);
}

#[test]
fn one_object_and_a_whole_screen_object_agree() {
    let config = AttentionConfig::default();
    let mut one = Canvas::new(200, 150, [128, 128, 128]);
    one.rect([120, 30, 160, 70], 5, [220, 40, 40], 2500.0);
    both_on("one object", config, &one, &still([5]));
    let mut whole = Canvas::new(200, 150, [0, 0, 0]);
    whole.rect([0, 0, 200, 150], 3, [90, 200, 60], 1500.0);
    let w = both_on("whole screen", config, &whole, &still([3, 4]));
    assert_eq!(w.map, 0.0, "a flat map is 1 on both paths");
    // Textured whole-screen object: contrast inside one object.
    let mut textured = whole.clone();
    for k in 0..10 {
        textured.rect(
            [k * 20, 0, k * 20 + 10, 150],
            3,
            [200, 60, 90],
            1500.0 + k as f32,
        );
    }
    both_on("whole screen, textured", config, &textured, &still([3]));
}

#[test]
fn two_hundred_fifty_six_objects_agree() {
    let mut rng = attention::synthetic::SplitMix64::new(256);
    let mut c = Canvas::new(320, 256, [30, 30, 30]);
    for id in 0..256u32 {
        let (gx, gy) = (id % 16, id / 16);
        let rgb = [
            (rng.unit() * 255.0) as u8,
            (rng.unit() * 255.0) as u8,
            (rng.unit() * 255.0) as u8,
        ];
        let inset = (rng.unit() * 6.0) as u32;
        c.rect(
            [
                gx * 20 + inset,
                gy * 16,
                gx * 20 + 20,
                gy * 16 + 16 - inset / 2,
            ],
            id,
            rgb,
            rng.range(500.0, 30_000.0),
        );
    }
    let objects: Vec<ObjectInfo> = (0..256u32)
        .map(|id| ObjectInfo {
            id,
            importance: rng.range(0.2, 1.0),
            motion_mm_per_s: [rng.range(-500.0, 500.0), 0.0, rng.range(-50.0, 50.0)],
        })
        .collect();
    for map in [64, 128] {
        both_on(
            &format!("256 objects at {map}²"),
            AttentionConfig::with_map_size(map),
            &c,
            &objects,
        );
    }
}

#[test]
fn hue_across_the_0_360_wrap_agrees() {
    // Reds either side of 0°/360° (350° and 10°: 20° apart), on a red
    // background at 0°, beside a cyan object (180°) and a grey one.
    let mut c = Canvas::new(192, 128, [230, 20, 20]);
    c.rect([20, 20, 60, 60], 1, [230, 20, 81], 3000.0); // ≈ 350°
    c.rect([80, 20, 120, 60], 2, [230, 81, 20], 3000.0); // ≈ 10°
    c.rect([140, 20, 180, 60], 3, [20, 230, 230], 3000.0); // 180°
    c.rect([60, 80, 130, 120], 4, [128, 128, 128], 3000.0); // grey
    let config = AttentionConfig {
        features: Features {
            hue: true,
            ..Features::NONE
        },
        ..AttentionConfig::default()
    };
    let mut cpu = AttentionTracker::new(config).expect("config");
    let mut gpu = gpu_model(config);
    let objects = still([1, 2, 3, 4]);
    let a = cpu
        .update(&c.view(), &objects, CameraMotion::STATIC, 0.0)
        .expect("cpu");
    let b = gpu
        .update(&c.view(), &objects, CameraMotion::STATIC, 0.0)
        .expect("gpu");
    assert!(gpu.weights()[1] > 0.0, "hue has contrast");
    // The wrap is handled on both: the cyan object stands out far more
    // than either red, and 350° stands out no more than 10° does by much.
    for r in [&a, &b] {
        let s = |id| r.get(id).map(|o| o.object_saliency).unwrap_or(0.0);
        assert!(s(3) > 2.0 * s(1) && s(3) > 2.0 * s(2), "{:?}", r.ranking);
    }
    both_on("hue wrap, hue only", config, &c, &objects);
    both_on(
        "hue wrap, all features",
        AttentionConfig::default(),
        &c,
        &objects,
    );
}

#[test]
fn non_finite_and_negative_depths_agree_and_stay_finite() {
    let mut c = Canvas::new(160, 128, [100, 120, 140]);
    let specials = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, -5.0, 0.0, 1e-30];
    for (k, &z) in specials.iter().enumerate() {
        let k = k as u32;
        c.rect(
            [10 + 24 * k, 10, 30 + 24 * k, 50],
            k,
            [40 * k as u8, 200, 90],
            2000.0,
        );
        // Half of each object's pixels carry the special depth.
        c.rect(
            [10 + 24 * k, 30, 30 + 24 * k, 50],
            k,
            [40 * k as u8, 200, 90],
            z,
        );
    }
    // One object with every pixel non-finite: distance is z_far on both.
    c.rect([20, 80, 60, 110], 6, [250, 250, 0], f32::NAN);
    // Background pixels with finite and non-finite depths alike.
    c.rect([100, 80, 150, 120], BACKGROUND_ID, [0, 0, 0], 500.0);
    let objects = still(0..7);
    both_on(
        "non-finite depths",
        AttentionConfig::default(),
        &c,
        &objects,
    );
    // Beyond the GPU's 2^29 mm cap: the distance is capped, the rest holds.
    let mut far = c.clone();
    far.rect([20, 80, 60, 110], 6, [250, 250, 0], f32::MAX);
    both_on("depth f32::MAX", AttentionConfig::default(), &far, &objects);
}

/// The depth cap on a small frame at huge depths: a depth above 2^29 mm
/// counts as 2^29 mm, in the mean of an object's depths too, and one below
/// it is summed exactly; the CPU path keeps the true mean.
#[test]
fn depths_beyond_the_cap_count_as_the_cap() {
    assert_eq!(DEPTH_CAP_MM, pipeline::gpu_attention::DEPTH_CAP_MM);
    let mut c = Canvas::new(96, 64, [100, 120, 140]);
    // 1: every pixel at 1e9 mm (above 2^29 mm, below 2^30 mm).
    c.rect([4, 4, 28, 28], 1, [220, 40, 40], 1e9);
    // 2: half its pixels at f32::MAX, half at 1 m.
    c.rect([36, 4, 60, 28], 2, [40, 220, 40], 1000.0);
    c.rect([36, 16, 60, 28], 2, [40, 220, 40], f32::MAX);
    // 3: every pixel at 4e8 mm, just below the cap (an f32 integer).
    c.rect([68, 4, 92, 28], 3, [40, 40, 220], 4e8);
    let objects = still([1, 2, 3]);
    let config = AttentionConfig::default();
    let mut cpu = AttentionTracker::new(config).expect("config");
    let mut gpu = gpu_model(config);
    let a = cpu
        .update(&c.view(), &objects, CameraMotion::STATIC, 0.0)
        .expect("cpu");
    let b = gpu
        .update(&c.view(), &objects, CameraMotion::STATIC, 0.0)
        .expect("gpu");
    let distance = |r: &Attention, id| r.get(id).map(|o| o.distance_mm);
    assert_eq!(distance(&a, 1), Some(1e9), "the CPU keeps the true mean");
    assert_eq!(distance(&b, 1), Some(DEPTH_CAP_MM), "capped at 2^29 mm");
    let half = ((f64::from(DEPTH_CAP_MM) + 1000.0) / 2.0) as f32;
    assert_eq!(distance(&b, 2), Some(half), "the mean of the capped depths");
    assert_eq!(distance(&a, 3), Some(4e8));
    assert_eq!(distance(&b, 3), Some(4e8), "below the cap: exact");
    both_on("depths beyond the cap", config, &c, &objects);
}

#[test]
fn map_sizes_64_and_512_and_frames_smaller_than_the_map_agree() {
    let scene = SyntheticScene::new(320, 256, 20, 64).expect("scene");
    let camera = CameraMotion::STATIC;
    for map in [64u32, 512] {
        // At 512² the 320×256 frame is smaller than the map.
        let w = run_both(
            &format!("320x256 at {map}²"),
            AttentionConfig::with_map_size(map),
            &[(scene.view(), scene.objects(), camera)],
        );
        println!("synthetic 320x256 at {map}²: {w:?}");
    }
    for (w, h, map) in [
        (50u32, 40u32, 64u32),
        (7, 3, 512),
        (1, 1, 64),
        (100, 30, 64),
    ] {
        let small = SyntheticScene::new(w, h, 4, u64::from(w * h)).expect("scene");
        let worst = run_both(
            &format!("{w}x{h} at {map}²"),
            AttentionConfig::with_map_size(map),
            &[(small.view(), small.objects(), camera)],
        );
        println!("synthetic {w}x{h} at {map}²: {worst:?}");
    }
}

#[test]
fn large_ids_and_unlisted_ids_agree() {
    // Ids past the direct table (a binary search on the GPU) and ids the
    // list does not have (background).
    let mut c = Canvas::new(160, 128, [10, 60, 10]);
    let ids = [70_000u32, 1 << 20, u32::MAX - 1, 3];
    for (k, &id) in ids.iter().enumerate() {
        let k = k as u32;
        c.rect(
            [10 + 35 * k, 20, 40 + 35 * k, 60],
            id,
            [60 * k as u8, 40, 220],
            1000.0 + 500.0 * k as f32,
        );
    }
    c.rect([40, 80, 120, 110], 99, [255, 255, 255], 900.0);
    let objects = still(ids);
    let mut cpu = AttentionTracker::new(AttentionConfig::default()).expect("config");
    let mut gpu = gpu_model(AttentionConfig::default());
    let a = cpu
        .update(&c.view(), &objects, CameraMotion::STATIC, 0.0)
        .expect("cpu");
    let b = gpu
        .update(&c.view(), &objects, CameraMotion::STATIC, 0.0)
        .expect("gpu");
    assert_eq!(b.unlisted_pixels, 80 * 30);
    assert_eq!(a.ranking.len(), 4);
    both_on("large ids", AttentionConfig::default(), &c, &objects);
}

#[test]
fn lee_ablations_agree() {
    let mut scene = SyntheticScene::new(240, 180, 16, 3).expect("scene");
    let camera = CameraMotion::new([0.0, 0.0, -1.0], [0.0, 0.0, -600.0]);
    let mut owned = Vec::new();
    for _ in 0..2 {
        owned.push(scene.clone());
        scene.advance(0.1);
    }
    for (name, features) in [
        ("B", Features::lee_groups(true, false, false)),
        ("E", Features::lee_groups(false, true, false)),
        ("T", Features::lee_groups(false, false, true)),
        ("none", Features::NONE),
        (
            "motion only",
            Features {
                motion: true,
                ..Features::NONE
            },
        ),
    ] {
        let config = AttentionConfig {
            features,
            ..AttentionConfig::default()
        };
        let frames: Vec<_> = owned
            .iter()
            .map(|s| (s.view(), s.objects(), camera))
            .collect();
        let w = run_both(&format!("features {name}"), config, &frames);
        println!("features {name}: {w:?}");
    }
}

fn special_depth() -> impl Strategy<Value = f32> {
    prop_oneof![
        6 => 0.0f32..30_000.0,
        1 => Just(f32::NAN),
        1 => Just(f32::INFINITY),
        1 => Just(f32::NEG_INFINITY),
        1 => Just(-1.0f32),
    ]
}

#[derive(Clone, Debug)]
struct Case {
    canvas: Canvas,
    map_size: u32,
    objects: Vec<ObjectInfo>,
}

fn case() -> impl Strategy<Value = Case> {
    (
        1u32..=96,
        1u32..=80,
        prop::sample::select(vec![64u32, 65, 100]),
    )
        .prop_flat_map(|(width, height, map_size)| {
            let n = (width * height) as usize;
            // Ids 0..8 listed or not, 9 background; blocks of 8 px so that
            // objects have area.
            let ids = prop::collection::vec(0u32..10, 16);
            let colours = prop::collection::vec(any::<[u8; 3]>(), 16);
            let depths = prop::collection::vec(special_depth(), 16);
            let objects = prop::collection::vec(
                (0u32..9, 0.0f32..1.0, -300.0f32..300.0, any::<bool>()),
                0..9,
            );
            (
                Just((width, height, map_size, n)),
                ids,
                colours,
                depths,
                objects,
            )
        })
        .prop_map(
            |((width, height, map_size, n), ids, colours, depths, objects)| {
                let mut canvas = Canvas::new(width, height, [0, 0, 0]);
                for i in 0..n {
                    let (x, y) = (i as u32 % width, i as u32 / width);
                    let block = ((x / 8 + (y / 8) * 4) % 16) as usize;
                    let id = if ids[block] == 9 {
                        BACKGROUND_ID
                    } else {
                        ids[block]
                    };
                    canvas.rgb[3 * i..3 * i + 3].copy_from_slice(&colours[block]);
                    canvas.depth_mm[i] = depths[(block + (x % 2) as usize) % 16];
                    canvas.object[i] = id;
                }
                let mut seen = std::collections::HashSet::new();
                let objects = objects
                    .into_iter()
                    .filter(|o| seen.insert(o.0))
                    .map(|(id, importance, speed, moving)| ObjectInfo {
                        id,
                        importance,
                        motion_mm_per_s: if moving { [speed, 0.0, 0.0] } else { [0.0; 3] },
                    })
                    .collect();
                Case {
                    canvas,
                    map_size,
                    objects,
                }
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig { cases: fixtures::proptest_cases(16), ..ProptestConfig::default() })]

    /// Random frames (smaller and larger than the map, non-finite depths,
    /// unlisted ids, random importances and motions): the GPU path is the
    /// CPU's within the tolerance, and never NaN.
    #[test]
    fn random_frames_agree(case in case()) {
        let config = AttentionConfig::with_map_size(case.map_size);
        run_both(
            "random frame",
            config,
            &[(case.canvas.view(), case.objects.clone(), CameraMotion::STATIC)],
        );
    }
}

/// The 17" display at 320×256 (pixel pitch of 640×512, the middle quarter).
fn display() -> Display {
    Display {
        name: "17in, middle quarter".into(),
        resolution_px: (320, 256),
        size_mm: (337.9 / 2.0, 270.3 / 2.0),
        eye_distance_mm: 540.0,
        eye_point_px: None,
    }
}

fn model() -> SamplingModel {
    pipeline::sampling_model(display().geometry().expect("geometry"), 1.0).expect("model")
}

fn shipped(name: &str) -> Scene {
    let repo = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."));
    let path = repo.join("config/scenes").join(format!("{name}.ron"));
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut file: SceneFile = ron::from_str(&text).unwrap_or_else(|e| panic!("{name}: {e}"));
    file.set_effects(Vec::new());
    Scene::build(&file, path.parent().expect("dir")).unwrap_or_else(|e| panic!("{name}: {e}"))
}

#[test]
fn rendered_scenes_agree() {
    for name in ["search-task", "bunny", "faces", "stress"] {
        let scene = shipped(name);
        let model = model();
        let mut r = Renderer::new(
            &scene,
            Camera::new(&model.geometry),
            model,
            &Options {
                method: Method::Full,
                backend: BackendChoice::Cpu,
                surface: true,
                ..Options::default()
            },
        )
        .expect("renderer");
        let (frame, _) = r.render_at([160.0, 128.0], 0.0).expect("frame");
        let objects: Vec<ObjectInfo> = scene
            .object_importance
            .iter()
            .enumerate()
            .map(|(id, &i)| ObjectInfo::still(id as u32, i))
            .collect();
        let view = FrameView {
            width: frame.width_px,
            height: frame.height_px,
            rgb: &frame.rgb,
            depth_mm: &frame.depth_mm,
            object: &frame.object,
        };
        for map in [64u32, 256] {
            let w = run_both(
                &format!("{name} at {map}²"),
                AttentionConfig::with_map_size(map),
                &[(view, objects.clone(), CameraMotion::STATIC)],
            );
            println!("rendered {name} 320x256 at {map}²: {w:?}");
        }
    }
}

/// The depth-of-field tests' three bumpy balls (`tests/gpu_effects.rs`):
/// at the screen (object 0), halfway to the eye (1), 1.5 m behind the
/// screen (2).
fn balls(effects: &str) -> Scene {
    let text = format!(
        r#"Scene(
    name: "dof",
    meshes: {{ "ball": Bumpy(triangles: 1500, amplitude: 0.12, seed: 3) }},
    objects: [
        (mesh: "ball", translate_mm: (-80.0, 0.0, 0.0), scale_mm: 35.0),
        (mesh: "ball", translate_mm: (30.0, 40.0, 270.0), scale_mm: 12.0),
        (mesh: "ball", translate_mm: (150.0, -100.0, -1500.0), scale_mm: 100.0),
    ],
    effects: [{effects}],
)"#
    );
    let file: SceneFile = ron::from_str(&text).expect("parses");
    Scene::build(&file, Path::new(".")).expect("builds")
}

/// The seed's 17" display at 160×128 pixels (as `tests/gpu_effects.rs`).
fn small_display() -> Display {
    Display::seed_17in(160, 128)
}

fn renderer(scene: &Scene, backend: BackendChoice) -> Renderer<'_> {
    let d = small_display();
    let model = pipeline::sampling_model(d.geometry().expect("geometry"), 1.0).expect("model");
    Renderer::new(
        scene,
        Camera::new(&model.geometry),
        model,
        &Options {
            method: Method::Full,
            backend,
            ..Options::default()
        },
    )
    .expect("renderer")
}

const GAZE: [f64; 2] = [80.0 - 80.0 * 160.0 / 337.9, 64.0];

/// Depth of field focusing on the attended object, on the GPU backend: the
/// model runs on the GPU frame (no CPU pass is left, the surface buffers
/// are not read back) and focuses where the CPU pass, run on the GPU's own
/// cast, focuses — over frames, for Lee's ch. 4 and ch. 5 passes.
#[test]
fn depth_of_field_on_the_attended_object_runs_on_the_gpu_as_the_cpu_pass() {
    let plain = balls("");
    let mut reference = GpuRenderer::new(&plain).expect("GPU");
    reference.set_surface(true);
    let d = small_display();
    let cam = Camera::new(&d.geometry().expect("geometry"));
    let (cast, _) = reference.render_full(&cam).expect("cast");
    for effect in [
        "DepthOfField(pupil_mm: 8.0, focus: Attention)",
        "DepthOfField(pupil_mm: 8.0, focus: Attention, method: Splat)",
    ] {
        let s = balls(effect);
        let mut r = renderer(&s, BackendChoice::Gpu);
        assert_eq!(r.gpu_pass_names().len(), 1, "{effect}: on the GPU");
        assert!(r.depth_of_field().is_none(), "{effect}: no CPU pass");
        assert!(
            !r.has_attention_buffers(),
            "buffers come with the first frame"
        );
        let e = s.pass(&PostPass::DEPTH_OF_FIELD).expect("listed");
        let mut cpu: Box<dyn Pass> = match DepthOfField::from_effect(e) {
            Some(d) => Box::new(d),
            None => Box::new(
                pipeline::effects::dof_splat::DepthOfFieldSplat::from_effect(e).expect("splat"),
            ),
        };
        for (k, t) in [0.0, 0.05, 0.1].into_iter().enumerate() {
            let mut expected = cast.clone();
            cpu.run(
                &mut expected,
                &PassInput {
                    scene: &s,
                    camera: &cam,
                    gaze_px: GAZE,
                    time_s: Some(t),
                    vergence_mm: None,
                },
            );
            let (got, _) = r.render_at(GAZE, t).expect("renders");
            assert!(r.has_attention_buffers(), "{effect}");
            assert!(
                got.depth_mm.is_empty() && got.object.is_empty(),
                "{effect}: the surface buffers stay on the GPU"
            );
            let cpu_focus = focal_depth(cpu.as_ref()).expect("the CPU pass focused");
            let gpu_focus = r.gpu_focal_depth_mm().expect("the GPU pass focused");
            let diff = (cpu_focus - gpu_focus).abs();
            println!(
                "{effect}, frame {k}: focus CPU {cpu_focus} mm, GPU {gpu_focus} mm (difference {diff:e} mm)"
            );
            assert!(diff <= 0.01 + 1e-5 * cpu_focus, "{effect}, frame {k}");
            let worst = got
                .rgb
                .iter()
                .zip(&expected.rgb)
                .map(|(a, b)| a.abs_diff(*b))
                .max()
                .unwrap_or(0);
            println!("{effect}, frame {k}: largest channel difference {worst}");
            assert!(worst <= 1, "{effect}, frame {k}: {worst}");
        }
    }
}

/// The focal depth of either CPU depth-of-field pass.
fn focal_depth(pass: &dyn Pass) -> Option<f64> {
    let any = pass.as_any();
    if let Some(d) = any.downcast_ref::<DepthOfField>() {
        return d.focal_depth_mm();
    }
    any.downcast_ref::<pipeline::effects::dof_splat::DepthOfFieldSplat>()
        .and_then(|d| d.focal_depth_mm())
}

/// Pay per use: a scene that asks for no attention makes no GPU attention
/// state and runs no attention pass, on either backend; the CPU backend
/// keeps its CPU model. Counted where the state is made
/// (`states_made_on_this_thread`), wherever a renderer would keep it.
#[test]
fn attention_on_the_gpu_is_paid_per_use() {
    let base = states_made_on_this_thread();
    let made = || states_made_on_this_thread() - base;
    for effects in [
        "",
        "DepthOfField(pupil_mm: 8.0)",
        "DepthOfField(pupil_mm: 8.0, method: Splat)",
    ] {
        let s = balls(effects);
        for backend in [BackendChoice::Cpu, BackendChoice::Gpu] {
            let mut r = renderer(&s, backend);
            r.render_at(GAZE, 0.0).expect("renders");
            r.render_at(GAZE, 0.1).expect("renders");
            assert_eq!(
                made(),
                0,
                "{effects:?} {backend:?}: GPU attention state made"
            );
            assert!(!r.has_attention_buffers(), "{effects:?} {backend:?}");
            let text = r.explain().join("\n");
            assert!(
                !text.contains("attention"),
                "{effects:?} {backend:?}: {text}"
            );
        }
    }
    // The CPU backend runs its CPU model and never makes GPU state.
    let s = balls("DepthOfField(pupil_mm: 8.0, focus: Attention)");
    let mut r = renderer(&s, BackendChoice::Cpu);
    r.render_at(GAZE, 0.0).expect("renders");
    assert!(!r.has_attention_buffers());
    let dof = r.depth_of_field().expect("a CPU pass");
    assert!(dof.attended_object().is_some());
    assert!(dof.attention().is_some_and(|a| !a.has_gpu_buffers()));
    assert_eq!(made(), 0, "the CPU backend makes no GPU attention state");
    // The GPU backend names what it runs, and makes its state with the
    // first frame, once.
    let mut r = renderer(&s, BackendChoice::Gpu);
    let text = r.explain().join("\n");
    assert!(
        text.contains("Lee's attention model") && text.contains("on the GPU"),
        "{text}"
    );
    assert_eq!(made(), 0, "nothing before the first frame");
    r.render_at(GAZE, 0.0).expect("renders");
    r.render_at(GAZE, 0.1).expect("renders");
    assert_eq!(made(), 1, "one GPU attention state for the scene that asks");
    assert!(r.has_attention_buffers());
}

/// Bad input is an error, checked before anything is sized from it, and
/// leaves the history alone; the model goes on working afterwards.
#[test]
fn bad_input_is_an_error_not_a_panic() {
    use attention::AttentionError;
    use pipeline::gpu_attention::GpuAttentionError;
    let config = AttentionConfig::default();
    assert!(matches!(
        GpuAttention::new(AttentionConfig::with_map_size(1024)).err(),
        Some(GpuAttentionError::Attention(
            AttentionError::MapSizeOutOfRange { .. }
        ))
    ));
    let mut gpu = gpu_model(config);
    let mut c = Canvas::new(64, 48, [20, 20, 20]);
    c.rect([10, 10, 30, 30], 1, [200, 50, 50], 1000.0);
    let objects = still([1]);
    assert!(gpu.measure(&objects).is_err(), "nothing uploaded yet");
    let first = gpu
        .update(&c.view(), &objects, CameraMotion::STATIC, 0.0)
        .expect("frame");
    let before = gpu.tracker().smoothed_attention(1);
    assert_eq!(first.attended, Some(1));
    let mut short = c.clone();
    short.depth_mm.pop();
    let huge = FrameView {
        width: 1 << 20,
        height: 1 << 20,
        ..c.view()
    };
    let empty = FrameView {
        width: 0,
        ..c.view()
    };
    for (what, frame, objects, dt) in [
        ("short depth buffer", short.view(), objects.clone(), 0.0),
        ("huge frame", huge, objects.clone(), 0.0),
        ("empty frame", empty, objects.clone(), 0.0),
        ("duplicate ids", c.view(), still([1, 1]), 0.0),
        ("background id", c.view(), still([BACKGROUND_ID]), 0.0),
        ("negative time step", c.view(), objects.clone(), -1.0),
        ("NaN time step", c.view(), objects.clone(), f64::NAN),
    ] {
        let r = gpu.update(&frame, &objects, CameraMotion::STATIC, dt);
        assert!(
            matches!(r, Err(GpuAttentionError::Attention(_))),
            "{what}: {r:?}"
        );
        assert_eq!(gpu.tracker().smoothed_attention(1), before, "{what}");
    }
    // One object more than the model takes (its id table would be sized
    // from the list).
    let max = attention::frame::MAX_OBJECTS;
    let too_many = still(0..=max as u32);
    let r = gpu.update(&c.view(), &too_many, CameraMotion::STATIC, 0.0);
    assert!(
        matches!(
            &r,
            Err(GpuAttentionError::Attention(AttentionError::TooManyObjects { count, max: m }))
                if *count == max + 1 && *m == max
        ),
        "too many objects: {r:?}"
    );
    assert_eq!(
        gpu.tracker().smoothed_attention(1),
        before,
        "too many objects"
    );
    let again = gpu
        .update(&c.view(), &objects, CameraMotion::STATIC, 0.0)
        .expect("frame after errors");
    assert_eq!(again.attended, Some(1));
}
