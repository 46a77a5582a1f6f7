//! The tracker on hand-built and synthetic frames: edge cases, errors,
//! contexts, smoothing and the decisions documented in the crate docs.

mod common;

use attention::synthetic::{SyntheticScene, FLOOR_ID};
use attention::{
    Attention, AttentionConfig, AttentionError, AttentionTracker, CameraMotion, Feature, Features,
    FrameView, ObjectInfo, BACKGROUND_ID,
};
use common::{all_in, Canvas};

const DT: f64 = 1.0 / 60.0;
const GREY: [u8; 3] = [128, 128, 128];

fn tracker(map_size: u32) -> AttentionTracker {
    AttentionTracker::new(AttentionConfig::with_map_size(map_size)).expect("valid config")
}

fn assert_sane(tracker: &AttentionTracker, result: &Attention, frame: &FrameView) {
    for o in &result.ranking {
        for v in [o.attention, o.raw_attention, o.object_saliency] {
            assert!(
                v.is_finite() && (0.0..=1.0).contains(&v),
                "object {} value {v}",
                o.id
            );
        }
        assert!(
            (0.0..=0.5).contains(&o.spatial_context) && (0.0..=0.5).contains(&o.temporal_context)
        );
        assert!(o.distance_mm.is_finite() && o.distance_mm >= 0.0);
        assert!(o.pixel_count > 0);
        for p in [o.peak_px, o.screen_centre_px] {
            assert!(
                p[0] >= 0.0
                    && p[0] <= frame.width as f32
                    && p[1] >= 0.0
                    && p[1] <= frame.height as f32
            );
        }
    }
    for w in result.ranking.windows(2) {
        assert!(
            w[0].attention > w[1].attention
                || (w[0].attention == w[1].attention && w[0].id < w[1].id)
        );
    }
    if let Some(id) = result.attended {
        assert!(
            frame.object.contains(&id),
            "attended {id} is not in the frame"
        );
        assert_eq!(result.ranking[0].id, id);
        assert!(result.gaze_px.is_some());
    } else {
        assert!(result.gaze_px.is_none());
    }
    let maps = tracker.maps();
    for f in Feature::ALL {
        assert!(all_in(maps.contrast(f), 0.0, 1.0), "{f:?} contrast");
        if let Some(m) = maps.feature(f) {
            assert!(all_in(m, 0.0, 1.0), "{f:?} feature");
        }
    }
    let (hx, hy) = maps.hue_vector();
    assert!(all_in(hx, -1.0, 1.0) && all_in(hy, -1.0, 1.0));
    assert!(all_in(maps.pixel_saliency(), 0.0, 1.0));
    assert!(maps.weights().iter().all(|w| w.is_finite() && *w >= 0.0));
}

#[test]
fn an_empty_frame_attends_nothing_and_has_no_nan() {
    let canvas = Canvas::new(160, 120, [40, 60, 200]);
    let mut t = tracker(64);
    let objects = [ObjectInfo::still(1, 1.0), ObjectInfo::still(2, 0.5)];
    for _ in 0..3 {
        let r = t
            .update(&canvas.view(), &objects, CameraMotion::STATIC, DT)
            .expect("valid");
        assert_eq!(r.attended, None);
        assert!(r.ranking.is_empty());
        assert_eq!(r.background_pixels, 160 * 120);
        assert_sane(&t, &r, &canvas.view());
    }
    // Nothing listed at all.
    let r = t
        .update(&canvas.view(), &[], CameraMotion::STATIC, DT)
        .expect("valid");
    assert_eq!(r.attended, None);
}

#[test]
fn one_object_is_attended_and_the_gaze_lies_on_it() {
    let mut canvas = Canvas::new(320, 240, GREY);
    canvas.disc(150.0, 110.0, 30.0, 7, [230, 40, 30], 3000.0);
    let mut t = tracker(64);
    let r = t
        .update(
            &canvas.view(),
            &[ObjectInfo::still(7, 1.0)],
            CameraMotion::STATIC,
            DT,
        )
        .expect("valid");
    assert_sane(&t, &r, &canvas.view());
    assert_eq!(r.attended, Some(7));
    let gaze = r.gaze_px.expect("gaze with an attended object");
    let (dx, dy) = (gaze[0] - 150.0, gaze[1] - 110.0);
    assert!(
        (dx * dx + dy * dy).sqrt() <= 30.0,
        "gaze {gaze:?} off the disc"
    );
    let o = r.get(7).expect("ranked");
    assert!((o.distance_mm - 3000.0).abs() < 1e-3);
    assert!(
        (o.screen_centre_px[0] - 150.0).abs() < 0.5 && (o.screen_centre_px[1] - 110.0).abs() < 0.5
    );
    assert!(
        o.pixel_count > 2700 && o.pixel_count < 2950,
        "π·30² ≈ 2827, got {}",
        o.pixel_count
    );
    assert!(r.bottom_up_informative);
}

#[test]
fn two_hundred_fifty_six_objects_are_ranked_without_nan() {
    let scene = SyntheticScene::new(640, 480, 256, 11).expect("valid size");
    let mut t = tracker(128);
    let objects = scene.objects();
    let r = t
        .update(&scene.view(), &objects, CameraMotion::STATIC, DT)
        .expect("valid");
    assert_sane(&t, &r, &scene.view());
    assert!(
        r.ranking.len() > 100 && r.ranking.len() <= 256,
        "{} ranked",
        r.ranking.len()
    );
    assert!(
        r.ranking.iter().all(|o| o.id != FLOOR_ID),
        "importance 0 is never ranked"
    );
    assert!(r.attended.is_some());
}

#[test]
fn an_object_covering_the_whole_screen_is_attended_from_a_flat_map() {
    let mut canvas = Canvas::new(200, 150, GREY);
    canvas.rect([0, 0, 200, 150], 3, [20, 200, 90], 3000.0);
    let mut t = tracker(64);
    let r = t
        .update(
            &canvas.view(),
            &[ObjectInfo::still(3, 0.8)],
            CameraMotion::STATIC,
            DT,
        )
        .expect("valid");
    assert_sane(&t, &r, &canvas.view());
    assert!(!r.bottom_up_informative, "a uniform frame has no contrast");
    assert_eq!(r.attended, Some(3));
    let o = r.get(3).expect("ranked");
    assert!(
        (o.object_saliency - 0.8).abs() < 1e-6,
        "flat map: Ŝ_o = T_i"
    );
    assert!(
        (o.spatial_context - 0.5).abs() < 1e-3,
        "centred at L: T_s = 0.5"
    );
    let gaze = r.gaze_px.expect("gaze");
    assert!((gaze[0] - 100.0).abs() < 0.5 && (gaze[1] - 75.0).abs() < 0.5);
}

/// Object 1 comes closer every frame, object 2 goes away.
fn approach_and_recede(camera: CameraMotion) -> (f32, f32) {
    let mut t = tracker(64);
    let objects = [ObjectInfo::still(1, 1.0), ObjectInfo::still(2, 1.0)];
    let mut last = (0.0, 0.0);
    for step in 0..3 {
        let mut canvas = Canvas::new(256, 128, GREY);
        canvas.disc(
            64.0,
            64.0,
            25.0,
            1,
            [200, 50, 50],
            4000.0 - 200.0 * step as f32,
        );
        canvas.disc(
            192.0,
            64.0,
            25.0,
            2,
            [50, 50, 200],
            4000.0 + 200.0 * step as f32,
        );
        let r = t
            .update(&canvas.view(), &objects, camera, DT)
            .expect("valid");
        assert_sane(&t, &r, &canvas.view());
        last = (
            r.get(1).expect("1").spatial_context,
            r.get(2).expect("2").spatial_context,
        );
    }
    last
}

#[test]
fn a_forward_moving_camera_ignores_receding_objects_and_a_static_one_does_not() {
    let forward = CameraMotion::new([0.0, 0.0, -1.0], [0.0, 0.0, -1500.0]);
    assert!(forward.moving_forward());
    let (near, far) = approach_and_recede(forward);
    assert!(near > 0.2, "approaching object keeps T_s, got {near}");
    assert_eq!(
        far, 0.0,
        "receding object while moving forward: T_s = 0 (eq. 3.9)"
    );

    let (near, far) = approach_and_recede(CameraMotion::STATIC);
    assert!(
        near > 0.2 && far > 0.2,
        "static camera: both in the 'otherwise' branch"
    );

    let backward = CameraMotion::new([0.0, 0.0, -1.0], [0.0, 0.0, 1500.0]);
    let (_, far) = approach_and_recede(backward);
    assert!(far > 0.2, "moving backward: v·w < 0");
    let broken = CameraMotion::new([f32::NAN, 0.0, -1.0], [f32::INFINITY, 0.0, 0.0]);
    assert!(
        !broken.moving_forward(),
        "non-finite camera counts as at rest"
    );
}

#[test]
fn temporal_context_builds_up_and_the_filter_smooths_a_jump() {
    let config = AttentionConfig {
        temporal_window_frames: 10,
        ..AttentionConfig::with_map_size(64)
    };
    let mut t = AttentionTracker::new(config).expect("valid");
    let mut canvas = Canvas::new(128, 128, GREY);
    canvas.disc(64.0, 64.0, 20.0, 1, [220, 30, 30], 3000.0);
    let objects = [ObjectInfo::still(1, 1.0)];
    let mut tt = Vec::new();
    for _ in 0..12 {
        let r = t
            .update(&canvas.view(), &objects, CameraMotion::STATIC, DT)
            .expect("valid");
        tt.push(r.get(1).expect("ranked").temporal_context);
    }
    assert!(
        tt.windows(2).take(9).all(|w| w[1] > w[0]),
        "T_t ramps over λ frames: {tt:?}"
    );
    assert!((tt[11] - tt[10]).abs() < 1e-6, "then holds");
    // The object leaves: its raw attention drops to 0, the smoothed one lags.
    let empty = Canvas::new(128, 128, GREY);
    t.update(&empty.view(), &objects, CameraMotion::STATIC, DT)
        .expect("valid");
    let lagging = t.smoothed_attention(1).expect("still tracked");
    assert!(lagging > 0.05, "the filter does not jump to 0: {lagging}");
    for _ in 0..120 {
        t.update(&empty.view(), &objects, CameraMotion::STATIC, DT)
            .expect("valid");
    }
    assert!(t.smoothed_attention(1).expect("tracked") < 0.01);
    // Dropped from the list: forgotten.
    t.update(&empty.view(), &[], CameraMotion::STATIC, DT)
        .expect("valid");
    assert_eq!(t.smoothed_attention(1), None);
}

#[test]
fn nan_and_infinite_depth_stay_finite() {
    let mut canvas = Canvas::new(128, 96, GREY);
    canvas.rect([10, 10, 50, 50], 1, [200, 0, 0], f32::NAN);
    canvas.rect([60, 10, 100, 50], 2, [0, 200, 0], 2500.0);
    canvas.rect([10, 60, 50, 90], 3, [0, 0, 200], f32::MAX);
    for (i, z) in canvas.depth_mm.iter_mut().enumerate() {
        match i % 7 {
            0 => *z = f32::NEG_INFINITY,
            1 => *z = -5.0,
            2 if canvas.object[i] == 2 => *z = f32::INFINITY,
            _ => {}
        }
    }
    let objects = [
        ObjectInfo::still(1, 1.0),
        ObjectInfo::still(2, 1.0),
        ObjectInfo::still(3, 1.0),
    ];
    let mut t = tracker(64);
    for _ in 0..3 {
        let r = t
            .update(&canvas.view(), &objects, CameraMotion::STATIC, DT)
            .expect("valid");
        assert_sane(&t, &r, &canvas.view());
        assert_eq!(r.ranking.len(), 3);
    }
    let depth = t.maps().feature(Feature::Depth).expect("scalar").to_vec();
    assert!(all_in(&depth, 0.0, 1.0));
}

#[test]
fn map_sizes_outside_64_to_512_are_refused() {
    for size in [0, 1, 63, 513, 4096, u32::MAX] {
        match AttentionTracker::new(AttentionConfig::with_map_size(size)) {
            Err(AttentionError::MapSizeOutOfRange {
                size: s,
                min: 64,
                max: 512,
            }) => assert_eq!(s, size),
            other => panic!("size {size}: {:?}", other.err()),
        }
    }
    for size in [64, 100, 512] {
        assert!(AttentionTracker::new(AttentionConfig::with_map_size(size)).is_ok());
    }
}

#[test]
fn frame_buffer_length_mismatches_are_errors_not_panics() {
    let canvas = Canvas::new(100, 80, GREY);
    let mut t = tracker(64);
    let good = canvas.view();
    let cases = [
        (
            FrameView {
                rgb: &canvas.rgb[1..],
                ..good
            },
            "rgb",
        ),
        (
            FrameView {
                depth_mm: &canvas.depth_mm[..10],
                ..good
            },
            "depth_mm",
        ),
        (
            FrameView {
                object: &[],
                ..good
            },
            "object",
        ),
        (FrameView { width: 101, ..good }, "rgb"),
    ];
    for (frame, name) in cases {
        match t.update(&frame, &[], CameraMotion::STATIC, DT) {
            Err(AttentionError::BufferLength { buffer, .. }) => assert_eq!(buffer, name),
            other => panic!("{name}: {other:?}"),
        }
    }
    let zero = FrameView { width: 0, ..good };
    assert!(matches!(
        t.update(&zero, &[], CameraMotion::STATIC, DT),
        Err(AttentionError::EmptyFrame { .. })
    ));
    // Sizes whose product would be huge are refused before any allocation.
    for (w, h) in [(u32::MAX, u32::MAX), (20_000, 1), (16_384, 16_384)] {
        let huge = FrameView {
            width: w,
            height: h,
            ..good
        };
        assert!(matches!(
            t.update(&huge, &[], CameraMotion::STATIC, DT),
            Err(AttentionError::FrameTooLarge { .. })
        ));
    }
}

#[test]
fn bad_object_lists_and_time_steps_are_errors_and_leave_history_alone() {
    let mut canvas = Canvas::new(128, 128, GREY);
    canvas.disc(64.0, 64.0, 20.0, 1, [220, 30, 30], 3000.0);
    let mut t = tracker(64);
    let one = [ObjectInfo::still(1, 1.0)];
    t.update(&canvas.view(), &one, CameraMotion::STATIC, DT)
        .expect("valid");
    let before = t.smoothed_attention(1);
    let dup = [ObjectInfo::still(1, 1.0), ObjectInfo::still(1, 0.5)];
    assert_eq!(
        t.update(&canvas.view(), &dup, CameraMotion::STATIC, DT),
        Err(AttentionError::DuplicateObjectId(1))
    );
    let reserved = [ObjectInfo::still(BACKGROUND_ID, 1.0)];
    assert_eq!(
        t.update(&canvas.view(), &reserved, CameraMotion::STATIC, DT),
        Err(AttentionError::ReservedObjectId)
    );
    let many: Vec<ObjectInfo> = (0..4097).map(|id| ObjectInfo::still(id, 1.0)).collect();
    assert!(matches!(
        t.update(&canvas.view(), &many, CameraMotion::STATIC, DT),
        Err(AttentionError::TooManyObjects {
            count: 4097,
            max: 4096
        })
    ));
    for dt in [-1.0, f64::NAN, f64::INFINITY] {
        assert!(matches!(
            t.update(&canvas.view(), &one, CameraMotion::STATIC, dt),
            Err(AttentionError::InvalidTimeStep(_))
        ));
    }
    assert_eq!(t.smoothed_attention(1), before);
    // A zero step is fine (e.g. the first frame).
    assert!(t
        .update(&canvas.view(), &one, CameraMotion::STATIC, 0.0)
        .is_ok());
}

#[test]
fn unlisted_ids_count_as_background() {
    let mut canvas = Canvas::new(128, 128, GREY);
    canvas.rect([0, 0, 32, 32], 99, [255, 0, 0], 1000.0);
    canvas.disc(80.0, 80.0, 20.0, 1, [0, 0, 255], 3000.0);
    let mut t = tracker(64);
    let r = t
        .update(
            &canvas.view(),
            &[ObjectInfo::still(1, 1.0)],
            CameraMotion::STATIC,
            DT,
        )
        .expect("valid");
    assert_eq!(r.unlisted_pixels, 32 * 32);
    assert_eq!(r.ranking_ids(), vec![1]);
}

#[test]
fn equal_attention_ranks_the_lower_id_first() {
    let mut canvas = Canvas::new(128, 128, GREY);
    canvas.disc(40.0, 64.0, 15.0, 9, [200, 0, 0], 3000.0);
    canvas.disc(90.0, 64.0, 15.0, 4, [0, 200, 0], 3000.0);
    let config = AttentionConfig {
        features: Features::NONE,
        ..AttentionConfig::with_map_size(64)
    };
    let mut t = AttentionTracker::new(config).expect("valid");
    let objects = [ObjectInfo::still(9, 0.7), ObjectInfo::still(4, 0.7)];
    let r = t
        .update(&canvas.view(), &objects, CameraMotion::STATIC, DT)
        .expect("valid");
    assert_eq!(r.ranking[0].attention, r.ranking[1].attention);
    assert_eq!(r.ranking_ids(), vec![4, 9]);
    assert_eq!(r.attended, Some(4));
}

#[test]
fn importance_zero_excludes_and_below_threshold_attends_nothing() {
    let mut canvas = Canvas::new(128, 128, GREY);
    canvas.disc(64.0, 64.0, 20.0, 1, [220, 30, 30], 3000.0);
    let mut t = tracker(64);
    let r = t
        .update(
            &canvas.view(),
            &[ObjectInfo::still(1, 0.0)],
            CameraMotion::STATIC,
            DT,
        )
        .expect("valid");
    assert!(r.ranking.is_empty() && r.attended.is_none());
    let mut t = tracker(64);
    let r = t
        .update(
            &canvas.view(),
            &[ObjectInfo::still(1, 0.001)],
            CameraMotion::STATIC,
            DT,
        )
        .expect("valid");
    assert_eq!(r.ranking.len(), 1);
    assert!(r.ranking[0].attention < 0.01);
    assert_eq!(r.attended, None, "below the 0.01 threshold");
}

#[test]
fn motion_alone_picks_the_moving_object() {
    let mut canvas = Canvas::new(192, 128, GREY);
    for (i, x) in [32.0, 96.0, 160.0].into_iter().enumerate() {
        canvas.disc(x, 64.0, 18.0, i as u32 + 1, [128, 128, 128], 3000.0);
    }
    let features = Features {
        motion: true,
        ..Features::NONE
    };
    let config = AttentionConfig {
        features,
        ..AttentionConfig::with_map_size(64)
    };
    let mut t = AttentionTracker::new(config).expect("valid");
    let objects = [
        ObjectInfo::still(1, 1.0),
        ObjectInfo {
            id: 2,
            importance: 1.0,
            motion_mm_per_s: [0.0, 500.0, 0.0],
        },
        ObjectInfo::still(3, 1.0),
    ];
    let r = t
        .update(&canvas.view(), &objects, CameraMotion::STATIC, DT)
        .expect("valid");
    assert_eq!(r.attended, Some(2));
    let w = t.maps().weights();
    assert!(
        w[4] > 0.0 && w[..4].iter().all(|&v| v == 0.0),
        "weights {w:?}"
    );
}

#[test]
fn every_lee_ablation_runs_and_stays_in_range() {
    let scene = SyntheticScene::new(320, 256, 30, 5).expect("valid");
    let objects = scene.objects();
    for bits in 0..8u8 {
        let features = Features::lee_groups(bits & 4 != 0, bits & 2 != 0, bits & 1 != 0);
        let config = AttentionConfig {
            features,
            ..AttentionConfig::with_map_size(64)
        };
        let mut t = AttentionTracker::new(config).expect("valid");
        let r = t
            .update(&scene.view(), &objects, CameraMotion::STATIC, DT)
            .expect("valid");
        assert_sane(&t, &r, &scene.view());
        assert_eq!(
            r.bottom_up_informative,
            features.any_bottom_up(),
            "{features:?}"
        );
    }
}

#[test]
fn feature_maps_are_area_averages_of_the_frame() {
    // 128 → 64: each map cell averages a 2×2 block.
    let mut canvas = Canvas::new(128, 128, [0, 0, 0]);
    for y in 0..128u32 {
        for x in 0..128u32 {
            let v = ((x * 7 + y * 3) % 256) as u8;
            canvas.set(
                x,
                y,
                BACKGROUND_ID,
                [v, v, v],
                100.0 + 1000.0 * (x % 3) as f32,
            );
        }
    }
    let mut t = tracker(64);
    t.update(&canvas.view(), &[], CameraMotion::STATIC, DT)
        .expect("valid");
    let maps = t.maps();
    let lum = maps.feature(Feature::Luminance).expect("scalar");
    let depth = maps.feature(Feature::Depth).expect("scalar");
    let far = AttentionConfig::default().depth_far_mm;
    for my in 0..64usize {
        for mx in 0..64usize {
            let (mut l, mut d) = (0.0f64, 0.0f64);
            for (x, y) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
                let (px, py) = (2 * mx + x, 2 * my + y);
                let i = py * 128 + px;
                l += f64::from(canvas.rgb[3 * i]) / 255.0 / 4.0;
                d += f64::from((canvas.depth_mm[i] - 100.0) / (far - 100.0)) / 4.0;
            }
            assert!((f64::from(lum[my * 64 + mx]) - l).abs() < 1e-5);
            assert!((f64::from(depth[my * 64 + mx]) - d).abs() < 1e-5);
        }
    }
}

#[test]
fn results_do_not_depend_on_the_thread_count() {
    let scene = SyntheticScene::new(400, 300, 40, 9).expect("valid");
    let objects = scene.objects();
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool");
        pool.install(|| {
            let mut t = tracker(128);
            t.update(&scene.view(), &objects, CameraMotion::STATIC, DT)
                .expect("valid")
        })
    };
    assert_eq!(run(1), run(2));
}

#[test]
fn small_frames_below_the_map_size_work() {
    let mut canvas = Canvas::new(17, 9, GREY);
    canvas.rect([3, 2, 9, 7], 1, [250, 250, 0], 2000.0);
    let mut t = tracker(64);
    let r = t
        .update(
            &canvas.view(),
            &[ObjectInfo::still(1, 1.0)],
            CameraMotion::STATIC,
            DT,
        )
        .expect("valid");
    assert_sane(&t, &r, &canvas.view());
    assert_eq!(r.attended, Some(1));
    let gaze = r.gaze_px.expect("gaze");
    assert!(
        gaze[0] >= 3.0 && gaze[0] <= 9.0 && gaze[1] >= 2.0 && gaze[1] <= 7.0,
        "{gaze:?}"
    );
}

#[test]
fn a_measured_frame_finishes_exactly_as_update_does() {
    // The finishing steps (contexts, filter, ranking) exist once:
    // `measure` + `update_measured` is `update`, bit for bit, over frames
    // with history, on frames larger and smaller than the map.
    for (w, h, map) in [(320u32, 256u32, 64u32), (50, 40, 64)] {
        let mut scene = SyntheticScene::new(w, h, 12, 7).expect("valid");
        let camera = CameraMotion::new([0.0, 0.0, -1.0], [0.0, 0.0, -400.0]);
        let mut whole = tracker(map);
        let mut split = tracker(map);
        for _ in 0..5 {
            let objects = scene.objects();
            let a = whole
                .update(&scene.view(), &objects, camera, DT)
                .expect("frame");
            let measure = split.measure(&scene.view(), &objects).expect("measure");
            assert_eq!(measure.objects.len(), objects.len());
            let b = split
                .update_measured(&measure, &objects, camera, DT)
                .expect("finish");
            assert_eq!(a, b, "{w}x{h}");
            assert!(!a.ranking.is_empty());
            scene.advance(0.05);
        }
    }
}

#[test]
fn inconsistent_measures_are_refused_and_leave_history_alone() {
    let scene = SyntheticScene::new(160, 128, 6, 3).expect("valid");
    let objects = scene.objects();
    let mut t = tracker(64);
    let good = t.measure(&scene.view(), &objects).expect("measure");
    let first = t
        .update_measured(&good, &objects, CameraMotion::STATIC, DT)
        .expect("finish");
    let before = t.smoothed_attention(first.ranking[0].id);
    let mut short = good.clone();
    short.objects.pop();
    let mut miscounted = good.clone();
    miscounted.background_pixels += 1;
    let mut nan = good.clone();
    nan.objects[0].saliency_sum = f64::NAN;
    let mut sub = good.clone();
    sub.objects[0].depth_count = sub.objects[0].pixel_count + 1;
    let mut cell = good.clone();
    let visible = cell
        .objects
        .iter()
        .position(|o| o.peak_count > 0)
        .expect("a peak");
    cell.objects[visible].peak_cell = 64 * 64;
    for (what, bad) in [
        ("short", short),
        ("miscounted", miscounted),
        ("nan", nan),
        ("sub-count", sub),
        ("cell", cell),
    ] {
        let r = t.update_measured(&bad, &objects, CameraMotion::STATIC, DT);
        assert!(
            matches!(r, Err(AttentionError::InvalidMeasure(_))),
            "{what}: {r:?}"
        );
    }
    assert_eq!(t.smoothed_attention(first.ranking[0].id), before);
    let mut empty = good.clone();
    empty.width = 0;
    assert!(matches!(
        t.update_measured(&empty, &objects, CameraMotion::STATIC, DT),
        Err(AttentionError::EmptyFrame { .. })
    ));
}
