//! The GPU raster path (`GpuRenderer::rasterize`, a wgpu render pipeline)
//! against the CPU rasteriser (`raster::rasterize`) on the same triangles:
//! the bunny, a box-and-quads scene of three objects, triangles through the
//! eye's plane and behind the eye, an empty list, a 1×1 and an odd-size
//! frame. Runs on whatever adapter the machine has — Mesa's lavapipe where
//! there is no GPU, which `scripts/system-deps.sh` installs.
//!
//! `cargo test -p raycast --test gpu_raster -- --nocapture` prints the
//! measured differences.

mod common;

use common::{display, load};

use std::path::Path;

use glam::Vec3;
use raycast::gpu::{GpuError, GpuRenderer};
use raycast::raster::{rasterize, RasterScratch, RasterStats};
use raycast::scene::WorldTriangle;
use raycast::{Camera, Frame, Layer, Scene, SceneFile, NO_OBJECT};

fn gpu(scene: &Scene) -> GpuRenderer {
    GpuRenderer::new(scene).unwrap_or_else(|e| {
        panic!("{e} — install Mesa's software Vulkan (Debian: mesa-vulkan-drivers; scripts/system-deps.sh does)")
    })
}

fn camera(w: u32, h: u32, eye_point_px: Option<(f64, f64)>) -> Camera {
    let mut d = display(w, h);
    // Keep the 17" display's pitch at any pixel count.
    d.size_mm = (337.9 * f64::from(w) / 320.0, 270.3 * f64::from(h) / 256.0);
    d.eye_point_px = eye_point_px;
    Camera::new(&d.geometry().expect("geometry"))
}

fn cpu(scene: &Scene, cam: &Camera, tris: &[WorldTriangle], surface: bool) -> (Frame, RasterStats) {
    let mut frame = Frame::default();
    let stats = rasterize(
        scene,
        cam,
        tris,
        surface,
        &mut frame,
        &mut RasterScratch::default(),
    );
    (frame, stats)
}

fn on_gpu(
    g: &mut GpuRenderer,
    cam: &Camera,
    tris: &[WorldTriangle],
    surface: bool,
) -> (Frame, RasterStats) {
    let mut frame = Frame::default();
    let stats = g
        .rasterize(cam, tris, surface, &mut frame)
        .expect("GPU raster");
    (frame, stats)
}

/// How the GPU frame differs from the CPU one.
#[derive(Debug, Default)]
struct Diff {
    pixels: usize,
    hit_differs: usize,
    both_hit: usize,
    object_differs: usize,
    same_object: usize,
    rgb_exact: usize,
    rgb_within_2: usize,
    rgb_max: u8,
    depth_within: usize,
    depth_max_rel: f32,
    normal_max: f32,
}

/// Relative eye-distance tolerance: the GPU interpolates the world position
/// at the pixel centre of its snapped (1/256 px) vertices, the CPU meets the
/// pixel's ray with the exact plane; at grazing angles a snap moves the
/// depth by more than rounding does.
const DEPTH_REL_TOL: f32 = 1e-3;

fn diff(c: &Frame, g: &Frame) -> Diff {
    assert_eq!((c.width_px, c.height_px), (g.width_px, g.height_px));
    let mut d = Diff {
        pixels: c.len(),
        ..Diff::default()
    };
    for i in 0..c.len() {
        if c.hit[i] != g.hit[i] {
            d.hit_differs += 1;
            continue;
        }
        if !c.hit[i] {
            continue;
        }
        d.both_hit += 1;
        if c.object[i] != g.object[i] {
            d.object_differs += 1;
            continue;
        }
        d.same_object += 1;
        let (p, q) = (&c.rgb[3 * i..3 * i + 3], &g.rgb[3 * i..3 * i + 3]);
        let m = p
            .iter()
            .zip(q)
            .map(|(a, b)| a.abs_diff(*b))
            .max()
            .unwrap_or(0);
        d.rgb_max = d.rgb_max.max(m);
        d.rgb_exact += usize::from(m == 0);
        d.rgb_within_2 += usize::from(m <= 2);
        let rel = (c.depth_mm[i] - g.depth_mm[i]).abs() / c.depth_mm[i];
        d.depth_within += usize::from(rel <= DEPTH_REL_TOL);
        d.depth_max_rel = d.depth_max_rel.max(rel);
        for k in 0..3 {
            d.normal_max = d.normal_max.max((c.normal[i][k] - g.normal[i][k]).abs());
        }
    }
    d
}

fn pct(n: usize, of: usize) -> f64 {
    100.0 * n as f64 / of.max(1) as f64
}

/// Prints the differences and checks them: hit masks differ at < 0.5 % of
/// the pixels, object ids agree where both hit (up to `max_object` pixels
/// on an edge between two objects), depth within [`DEPTH_REL_TOL`] at
/// ≥ 99.9 % and colour within 2 levels at ≥ 99 % of the pixels both
/// cover with one object.
fn check(what: &str, c: &Frame, g: &Frame, max_object: usize) -> Diff {
    let d = diff(c, g);
    println!(
        "{what} ({}×{}): hit mask differs at {} of {} px ({:.3} %); object differs at {} of {} px both hit; \
         of {} px on the same object: colour exact {:.2} %, within 2/255 {:.3} % (max {}), \
         depth within {DEPTH_REL_TOL:e} {:.3} % (max rel {:.2e}), normal max diff {:.2e}",
        c.width_px,
        c.height_px,
        d.hit_differs,
        d.pixels,
        pct(d.hit_differs, d.pixels),
        d.object_differs,
        d.both_hit,
        d.same_object,
        pct(d.rgb_exact, d.same_object),
        pct(d.rgb_within_2, d.same_object),
        d.rgb_max,
        pct(d.depth_within, d.same_object),
        d.depth_max_rel,
        d.normal_max,
    );
    assert!(
        pct(d.hit_differs, d.pixels) < 0.5,
        "{what}: hit masks differ at {} px",
        d.hit_differs
    );
    assert!(
        d.object_differs <= max_object,
        "{what}: object ids differ at {} px",
        d.object_differs
    );
    if d.same_object > 0 {
        assert!(
            pct(d.rgb_within_2, d.same_object) >= 99.0,
            "{what}: colour within 2/255 at {:.3} %",
            pct(d.rgb_within_2, d.same_object)
        );
        assert!(
            pct(d.depth_within, d.same_object) >= 99.9,
            "{what}: depth within {DEPTH_REL_TOL} at {:.3} %",
            pct(d.depth_within, d.same_object)
        );
    }
    // The G-buffer's invariants on the GPU frame.
    assert!(g.has_surface());
    for i in 0..g.len() {
        assert_eq!(g.layer[i], Layer::Full, "{what}: layer at {i}");
        assert_eq!(g.object[i] != NO_OBJECT, g.hit[i], "{what}: object at {i}");
        assert_eq!(g.depth_mm[i].is_finite(), g.hit[i], "{what}: depth at {i}");
    }
    d
}

/// The stats both count the same way (the GPU does not report coverage:
/// its `drawn` includes triangles that cover no pixel centre).
fn check_stats(what: &str, c: &RasterStats, g: &RasterStats, frame: &Frame) {
    println!("{what}: CPU {c:?}\n{what}: GPU {g:?}");
    assert_eq!(g.triangles_in, c.triangles_in, "{what}");
    assert_eq!(g.culled_invalid, c.culled_invalid, "{what}");
    assert_eq!(g.culled_behind, c.culled_behind, "{what}");
    assert_eq!(g.drawn, c.drawn + c.culled_no_pixels, "{what}");
    assert_eq!(g.triangles_in, g.drawn + g.culled, "{what}");
    assert_eq!(
        g.pixels_covered,
        frame.hit.iter().filter(|h| **h).count() as u64
    );
}

fn assert_background(scene: &Scene, f: &Frame, what: &str) {
    assert!(f.has_surface());
    for i in 0..f.len() {
        assert!(
            !f.hit[i]
                && f.depth_mm[i] == f32::INFINITY
                && f.object[i] == NO_OBJECT
                && f.normal[i] == [0.0; 3]
                && f.layer[i] == Layer::Full
                && f.rgb[3 * i..3 * i + 3] == scene.background_rgb8,
            "{what}: pixel {i} is not background"
        );
    }
}

#[test]
fn the_bunny_matches_the_cpu_raster() {
    let s = load("bunny");
    let mut g = gpu(&s);
    for eye in [None, Some((40.0, 230.0))] {
        let cam = camera(320, 256, eye);
        let (c, cs) = cpu(&s, &cam, &s.triangles, true);
        let (f, gs) = on_gpu(&mut g, &cam, &s.triangles, true);
        let what = format!("bunny, eye at {eye:?}");
        check_stats(&what, &cs, &gs, &f);
        let d = check(&what, &c, &f, 0);
        assert!(d.same_object > d.pixels / 50, "{what}: the bunny is seen");
    }
    assert!(g.has_raster_buffers());
}

/// Three objects of different materials (only their materials are used:
/// the triangles are drawn by hand), a headlight and a point light.
fn box_scene() -> Scene {
    let text = r#"Scene(
    name: "boxes",
    background: (0.1, 0.2, 0.3),
    meshes: { "t": Triangle(a: (0.0, 0.0, 0.0), b: (1.0, 0.0, 0.0), c: (0.0, 1.0, 0.0)) },
    materials: {
        "red": (diffuse: (0.8, 0.2, 0.2)),
        "green": (diffuse: (0.2, 0.7, 0.3), specular: (0.5, 0.5, 0.5), shininess: 64.0),
        "grey": (diffuse: (0.6, 0.6, 0.6)),
    },
    objects: [
        (mesh: "t", material: Some("red"), translate_mm: (0.0, 0.0, 0.0), rotate_deg: (0.0, 0.0, 0.0), scale_mm: 1.0),
        (mesh: "t", material: Some("green"), translate_mm: (0.0, 0.0, 0.0), rotate_deg: (0.0, 0.0, 0.0), scale_mm: 1.0),
        (mesh: "t", material: Some("grey"), translate_mm: (0.0, 0.0, 0.0), rotate_deg: (0.0, 0.0, 0.0), scale_mm: 1.0),
    ],
    lights: [Headlight(intensity: 0.6), Point(position_mm: (200.0, 300.0, 400.0), intensity: 0.6)],
    effects: [],
)"#;
    let file: SceneFile = ron::from_str(text).expect("parses");
    Scene::build(&file, Path::new(".")).expect("builds")
}

fn v(x: f32, y: f32, z: f32) -> Vec3 {
    Vec3::new(x, y, z)
}

/// A triangle with its face normal at every corner.
fn tri(p: [Vec3; 3], object: u32) -> WorldTriangle {
    let n = (p[1] - p[0]).cross(p[2] - p[0]).normalize_or_zero();
    WorldTriangle {
        p,
        n: [n; 3],
        object,
    }
}

/// The two triangles of the quad `a b c d` (in order around it).
fn quad(a: Vec3, b: Vec3, c: Vec3, d: Vec3, object: u32) -> [WorldTriangle; 2] {
    [tri([a, b, c], object), tri([a, c, d], object)]
}

/// A box (object 0) turned to show three faces, a quad (1) in front of part
/// of it, tilted, and a large wall (2) behind both; smooth normals on the
/// tilted quad (so the interpolation is tested, not just flat faces).
fn box_triangles() -> Vec<WorldTriangle> {
    let mut out = Vec::new();
    // The box: a unit cube scaled to 60 mm, rotated 30° about y and 20°
    // about x, at z = −40.
    let r = glam::Mat3::from_rotation_x(20f32.to_radians())
        * glam::Mat3::from_rotation_y(30f32.to_radians());
    let corner = |x: f32, y: f32, z: f32| r * v(x, y, z) * 30.0 + v(-30.0, 10.0, -40.0);
    let c = [
        corner(-1.0, -1.0, -1.0),
        corner(1.0, -1.0, -1.0),
        corner(1.0, 1.0, -1.0),
        corner(-1.0, 1.0, -1.0),
        corner(-1.0, -1.0, 1.0),
        corner(1.0, -1.0, 1.0),
        corner(1.0, 1.0, 1.0),
        corner(-1.0, 1.0, 1.0),
    ];
    for f in [
        [0, 1, 2, 3],
        [4, 5, 6, 7],
        [0, 1, 5, 4],
        [3, 2, 6, 7],
        [0, 3, 7, 4],
        [1, 2, 6, 5],
    ] {
        out.extend(quad(c[f[0]], c[f[1]], c[f[2]], c[f[3]], 0));
    }
    // The tilted quad, with smooth normals fanning out.
    let q = [
        v(0.0, -60.0, 30.0),
        v(90.0, -50.0, -10.0),
        v(80.0, 40.0, -30.0),
        v(-10.0, 30.0, 10.0),
    ];
    let n = [
        v(-0.3, -0.3, 1.0).normalize(),
        v(0.4, -0.2, 1.0).normalize(),
        v(0.3, 0.4, 1.0).normalize(),
        v(-0.2, 0.3, 1.0).normalize(),
    ];
    for (i, j, k) in [(0, 1, 2), (0, 2, 3)] {
        out.push(WorldTriangle {
            p: [q[i], q[j], q[k]],
            n: [n[i], n[j], n[k]],
            object: 1,
        });
    }
    // The wall behind, larger than the view at its depth.
    out.extend(quad(
        v(-400.0, -300.0, -200.0),
        v(400.0, -300.0, -200.0),
        v(400.0, 300.0, -200.0),
        v(-400.0, 300.0, -200.0),
        2,
    ));
    out
}

#[test]
fn a_box_and_quads_of_three_objects_match_the_cpu_raster() {
    let s = box_scene();
    let mut g = gpu(&s);
    let tris = box_triangles();
    for eye in [None, Some((300.0, 20.0))] {
        let cam = camera(320, 256, eye);
        let (c, cs) = cpu(&s, &cam, &tris, true);
        let (f, gs) = on_gpu(&mut g, &cam, &tris, true);
        let what = format!("box and quads, eye at {eye:?}");
        check_stats(&what, &cs, &gs, &f);
        // Where two objects meet on the screen a pixel centre may fall on
        // either side of the edge: at most the edges' length in pixels.
        let d = check(&what, &c, &f, 320);
        assert!(d.hit_differs == 0, "{what}: the wall covers the screen");
        for o in 0..3 {
            assert!(f.object.contains(&o), "{what}: object {o} is seen");
        }
    }
}

#[test]
fn triangles_through_the_eye_plane_are_clipped_and_those_behind_draw_nothing() {
    let s = box_scene();
    let mut g = gpu(&s);
    let cam = camera(320, 256, None);
    // The eye is at z = 540.
    let through = [
        // One corner behind the eye, two in front.
        tri(
            [
                v(0.0, 0.0, 1000.0),
                v(-100.0, -50.0, -100.0),
                v(100.0, -50.0, -100.0),
            ],
            0,
        ),
        // Two corners behind, one in front.
        tri(
            [
                v(-80.0, 20.0, 900.0),
                v(80.0, 20.0, 900.0),
                v(0.0, -60.0, -50.0),
            ],
            1,
        ),
    ];
    for (k, t) in through.iter().enumerate() {
        let (c, cs) = cpu(&s, &cam, std::slice::from_ref(t), true);
        let (f, gs) = on_gpu(&mut g, &cam, std::slice::from_ref(t), true);
        let what = format!("through the eye plane, {} corner(s) behind", k + 1);
        check_stats(&what, &cs, &gs, &f);
        check(&what, &c, &f, 0);
        assert_eq!(gs.drawn, 1);
        assert!(gs.pixels_covered > 0, "{what}: the part in front is drawn");
        // Not wrapped: the top centre stays background for the first.
        if k == 0 {
            assert!(!f.hit[160], "{what}: the top centre is not covered");
            assert!(f.hit[255 * 320 + 160], "{what}: the bottom centre is");
        }
    }
    let behind = [
        tri(
            [
                v(-50.0, -50.0, 600.0),
                v(50.0, -50.0, 600.0),
                v(0.0, 50.0, 600.0),
            ],
            0,
        ),
        tri(
            [
                v(-50.0, -50.0, 540.0),
                v(50.0, -50.0, 540.0),
                v(0.0, 50.0, 540.0),
            ],
            0,
        ),
    ];
    let (f, gs) = on_gpu(&mut g, &cam, &behind, true);
    let (_, cs) = cpu(&s, &cam, &behind, true);
    check_stats("behind the eye", &cs, &gs, &f);
    assert_eq!((gs.culled_behind, gs.drawn), (2, 0));
    assert_background(&s, &f, "behind the eye");
}

#[test]
fn an_empty_list_and_invalid_triangles_give_the_background() {
    let s = box_scene();
    let mut g = gpu(&s);
    let cam = camera(320, 256, None);
    let tris = box_triangles();
    let mut frame = Frame::default();
    // Draw something first: the empty frame must overwrite every pixel.
    let first = g
        .rasterize(&cam, &tris, true, &mut frame)
        .expect("GPU raster");
    assert!(first.pixels_covered > 0);
    let stats = g.rasterize(&cam, &[], true, &mut frame).expect("empty");
    assert_eq!(
        (
            stats.triangles_in,
            stats.drawn,
            stats.culled,
            stats.pixels_covered
        ),
        (0, 0, 0, 0)
    );
    assert_eq!((frame.width_px, frame.height_px), (320, 256));
    assert_background(&s, &frame, "no triangles");
    // Non-finite corners, zero area and an object without a material are
    // skipped as the CPU skips them; NaN normals fall back to the face.
    let nan = f32::NAN;
    let good = tris[0];
    let mut bad_object = good;
    bad_object.object = 7;
    let mut nan_normals = tris[12];
    nan_normals.n = [Vec3::splat(nan); 3];
    let list = [
        tri(
            [
                v(-50.0, 0.0, -10.0),
                v(0.0, 0.0, -10.0),
                v(50.0, 0.0, -10.0),
            ],
            0,
        ),
        tri(
            [v(nan, 0.0, -10.0), v(50.0, 0.0, -10.0), v(0.0, 50.0, -10.0)],
            0,
        ),
        tri(
            [
                v(f32::INFINITY, 0.0, -10.0),
                v(50.0, 0.0, -10.0),
                v(0.0, 50.0, -10.0),
            ],
            0,
        ),
        bad_object,
        nan_normals,
    ];
    let (c, cs) = cpu(&s, &cam, &list, true);
    let (f, gs) = on_gpu(&mut g, &cam, &list, true);
    check_stats("invalid triangles", &cs, &gs, &f);
    assert_eq!(gs.culled_invalid, 4);
    check("invalid triangles", &c, &f, 0);
}

#[test]
fn one_pixel_and_odd_sizes_match_and_buffers_are_reused() {
    let s = load("bunny");
    let mut g = gpu(&s);
    // A frame size change remakes the targets; a smaller list after a
    // larger one reuses the vertex buffer.
    for (w, h) in [(1, 1), (97, 61), (1, 1), (321, 255)] {
        let cam = camera(w, h, None);
        let (c, _) = cpu(&s, &cam, &s.triangles, true);
        let (f, _) = on_gpu(&mut g, &cam, &s.triangles, true);
        check(&format!("bunny {w}×{h}"), &c, &f, 0);
        let half = &s.triangles[..s.triangles.len() / 2];
        let (c, _) = cpu(&s, &cam, half, true);
        let (f, _) = on_gpu(&mut g, &cam, half, true);
        check(&format!("half the bunny {w}×{h}"), &c, &f, 0);
    }
    // The 1×1 frame sees the bunny's middle.
    let cam = camera(1, 1, None);
    let (f, _) = on_gpu(&mut g, &cam, &s.triangles, true);
    assert!(f.hit[0], "the centre pixel shows the bunny");
}

#[test]
fn without_surface_buffers_the_colours_are_the_same() {
    let s = load("bunny");
    let mut g = gpu(&s);
    let cam = camera(160, 128, None);
    let (with, _) = on_gpu(&mut g, &cam, &s.triangles, true);
    let (without, _) = on_gpu(&mut g, &cam, &s.triangles, false);
    assert!(!without.has_surface());
    assert_eq!(with.rgb, without.rgb);
    assert_eq!(with.hit, without.hit);
}

/// The widest frame a display may have (16384 px): drawn where the
/// adapter's textures are that wide (lavapipe's are), else refused with the
/// texture limit named, never a panic.
#[test]
fn the_widest_frame_is_drawn_or_refused_by_the_texture_limit() {
    let s = box_scene();
    let mut g = gpu(&s);
    let cam = camera(16384, 1, None);
    let tris = box_triangles();
    let mut frame = Frame::default();
    match g.rasterize(&cam, &tris, true, &mut frame) {
        Ok(_) => {
            let (c, _) = cpu(&s, &cam, &tris, true);
            check("16384×1", &c, &frame, 0);
        }
        Err(e) => {
            assert!(matches!(e, GpuError::TextureTooLarge { .. }), "{e}");
            assert!(e.to_string().contains("max_texture_dimension_2d"), "{e}");
        }
    }
}
