//! Random frames (smaller and larger than the map, so both the fused and
//! the three-pass paths run), including non-finite depths, importances, motions and
//! camera vectors: every output is finite and in range, and the attended
//! object is one that is in the frame.

mod common;

use attention::{
    AttentionConfig, AttentionTracker, CameraMotion, Feature, FrameView, ObjectInfo, BACKGROUND_ID,
};
use common::all_in;
use proptest::prelude::*;

fn special_f32() -> impl Strategy<Value = f32> {
    prop_oneof![
        6 => 0.0f32..30_000.0,
        1 => Just(f32::NAN),
        1 => Just(f32::INFINITY),
        1 => Just(f32::NEG_INFINITY),
        1 => Just(-1.0f32),
        1 => Just(f32::MAX),
    ]
}

#[derive(Clone, Debug)]
struct Case {
    width: u32,
    height: u32,
    map_size: u32,
    rgb: Vec<u8>,
    depth: Vec<f32>,
    object: Vec<u32>,
    objects: Vec<ObjectInfo>,
    camera: CameraMotion,
    dts: Vec<f64>,
}

fn case() -> impl Strategy<Value = Case> {
    (
        1u32..=200,
        1u32..=160,
        prop::sample::select(vec![64u32, 64, 65, 100, 128]),
    )
        .prop_flat_map(|(width, height, map_size)| {
            let n = (width * height) as usize;
            // Ids 0..8 listed or not; 9 = background. Blocky so objects have area.
            let ids = prop::collection::vec(0u32..10, 16).prop_map(move |palette| {
                (0..n)
                    .map(|i| {
                        let (x, y) = (i as u32 % width, i as u32 / width);
                        let id = palette[((x / 8 + (y / 8) * 4) % 16) as usize];
                        if id == 9 {
                            BACKGROUND_ID
                        } else {
                            id
                        }
                    })
                    .collect::<Vec<u32>>()
            });
            let objects = prop::collection::vec(
                (
                    any::<bool>(),
                    special_f32(),
                    prop::array::uniform3(special_f32()),
                ),
                8,
            )
            .prop_map(|spec| {
                spec.into_iter()
                    .enumerate()
                    .filter(|(_, (listed, _, _))| *listed)
                    .map(|(id, (_, importance, motion))| ObjectInfo {
                        id: id as u32,
                        importance: if importance.is_finite() {
                            importance / 30_000.0 * 1.5
                        } else {
                            importance
                        },
                        motion_mm_per_s: motion,
                    })
                    .collect::<Vec<_>>()
            });
            let camera = (
                prop::array::uniform3(special_f32()),
                prop::array::uniform3(-2.0f32..2.0),
            )
                .prop_map(|(v, d)| CameraMotion::new(d, v));
            (
                Just((width, height, map_size)),
                prop::collection::vec(any::<u8>(), n * 3),
                prop::collection::vec(special_f32(), n),
                ids,
                objects,
                camera,
                prop::collection::vec(prop_oneof![Just(0.0f64), 0.001f64..0.1, Just(100.0)], 3),
            )
        })
        .prop_map(
            |((width, height, map_size), rgb, depth, object, objects, camera, dts)| Case {
                width,
                height,
                map_size,
                rgb,
                depth,
                object,
                objects,
                camera,
                dts,
            },
        )
}

proptest! {
    #![proptest_config(ProptestConfig { cases: fixtures::proptest_cases(48), ..ProptestConfig::default() })]

    #[test]
    fn outputs_are_finite_in_range_and_attend_only_visible_objects(c in case()) {
        let frame = FrameView {
            width: c.width,
            height: c.height,
            rgb: &c.rgb,
            depth_mm: &c.depth,
            object: &c.object,
        };
        let mut t = AttentionTracker::new(AttentionConfig::with_map_size(c.map_size)).expect("valid");
        for &dt in &c.dts {
            let r = t.update(&frame, &c.objects, c.camera, dt).expect("valid frame");
            for o in &r.ranking {
                for v in [o.attention, o.raw_attention, o.object_saliency] {
                    prop_assert!(v.is_finite() && (0.0..=1.0).contains(&v));
                }
                prop_assert!(o.spatial_context.is_finite() && (0.0..=0.5).contains(&o.spatial_context));
                prop_assert!(o.temporal_context.is_finite() && (0.0..=0.5).contains(&o.temporal_context));
                prop_assert!(o.distance_mm.is_finite());
                prop_assert!(o.peak_px.iter().chain(&o.screen_centre_px).all(|v| v.is_finite()));
                prop_assert!(c.objects.iter().any(|l| l.id == o.id), "ranked an unlisted id");
            }
            if let Some(id) = r.attended {
                prop_assert!(c.object.contains(&id), "attended {} not in the frame", id);
                let gaze = r.gaze_px.expect("gaze with attended");
                prop_assert!(gaze[0] >= 0.0 && gaze[0] <= c.width as f32);
                prop_assert!(gaze[1] >= 0.0 && gaze[1] <= c.height as f32);
            } else {
                prop_assert!(r.gaze_px.is_none());
            }
            let maps = t.maps();
            prop_assert!(all_in(maps.pixel_saliency(), 0.0, 1.0));
            for f in Feature::ALL {
                prop_assert!(all_in(maps.contrast(f), 0.0, 1.0));
            }
            for id in 0..8 {
                if let Some(a) = t.smoothed_attention(id) {
                    prop_assert!(a.is_finite() && (0.0..=1.0).contains(&a));
                }
            }
        }
    }
}
