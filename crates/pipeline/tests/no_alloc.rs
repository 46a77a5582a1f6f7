//! A renderer allocates nothing per frame once it has rendered frames of
//! its size (issue 15): the hybrid method's mask (its ring slots and arc
//! lists included), vertex hits, flags and owners live in its scratch, the
//! frame's buffers come back through `Renderer::recycle`, and the effect
//! passes keep their buffers. Counted with a global allocator that tallies
//! every allocation on every thread (rayon's workers included) while a
//! flag is up.
//!
//! The frames run inside rayon's pool (`ThreadPool::install`). Called from
//! a thread outside it, each parallel loop of a frame enters the pool
//! through rayon's global job queue, which allocates a block of about
//! 1.5 KB every 63 entries (measured here: 2 blocks in 24 frames) — the
//! queue's, not the renderer's.

use std::alloc::{GlobalAlloc, Layout, System};
use std::path::Path;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

use foveation::Display;
use pipeline::{Method, Options, Renderer};
use raycast::{Camera, Scene, SceneFile};

struct Counting;

static COUNTING: AtomicBool = AtomicBool::new(false);
static ALLOCATIONS: AtomicUsize = AtomicUsize::new(0);
static BYTES: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if COUNTING.load(Ordering::Relaxed) {
            ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
            BYTES.fetch_add(layout.size(), Ordering::Relaxed);
        }
        // SAFETY: forwarded unchanged to the system allocator.
        unsafe { System.alloc(layout) }
    }
    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        // SAFETY: `ptr` came from `alloc` or `realloc` with this layout.
        unsafe { System.dealloc(ptr, layout) }
    }
    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        if COUNTING.load(Ordering::Relaxed) {
            ALLOCATIONS.fetch_add(1, Ordering::Relaxed);
            BYTES.fetch_add(new_size, Ordering::Relaxed);
        }
        // SAFETY: as for `alloc` and `dealloc`.
        unsafe { System.realloc(ptr, layout, new_size) }
    }
}

#[global_allocator]
static ALLOC: Counting = Counting;

fn scene(name: &str) -> Scene {
    let root = Path::new(concat!(env!("CARGO_MANIFEST_DIR"), "/../.."));
    let path = root.join("config/scenes").join(format!("{name}.ron"));
    let text = std::fs::read_to_string(&path).expect("scene file");
    let file: SceneFile = ron::from_str(&text).expect("scene");
    Scene::build(&file, path.parent().expect("dir")).expect("scene builds")
}

/// The seed's 17" display at a quarter of its pixels (same size and
/// distance), so the test stays quick.
fn display() -> Display {
    Display::seed_17in(640, 512)
}

/// Allocations (count, bytes) made while rendering `gazes` with `r`, each
/// frame given back for the next.
fn allocations(r: &mut Renderer<'_>, gazes: &[[f64; 2]]) -> (usize, usize) {
    ALLOCATIONS.store(0, Ordering::SeqCst);
    BYTES.store(0, Ordering::SeqCst);
    COUNTING.store(true, Ordering::SeqCst);
    for &g in gazes {
        let (frame, _) = r.render_at(g, 0.0).expect("frame");
        r.recycle(frame);
    }
    COUNTING.store(false, Ordering::SeqCst);
    (
        ALLOCATIONS.load(Ordering::SeqCst),
        BYTES.load(Ordering::SeqCst),
    )
}

#[test]
fn frames_after_the_first_allocate_nothing() {
    // The counter counts (else the zeros below would say nothing). One test
    // function, so that no other test toggles the counter meanwhile.
    ALLOCATIONS.store(0, Ordering::SeqCst);
    COUNTING.store(true, Ordering::SeqCst);
    let v: Vec<u64> = std::hint::black_box((0..1000).collect());
    COUNTING.store(false, Ordering::SeqCst);
    drop(v);
    assert!(
        ALLOCATIONS.load(Ordering::SeqCst) >= 1,
        "the counter counts"
    );

    let g = display().geometry().expect("geometry");
    // A walk over the screen: every frame a new gaze, so every frame builds
    // its mask, casts its vertices and rasterises its owners afresh.
    let walk: Vec<[f64; 2]> = (0..24)
        .map(|k| {
            let a = k as f64 * 0.7;
            [320.0 + 250.0 * a.cos(), 256.0 + 200.0 * (1.3 * a).sin()]
        })
        .collect();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(2)
        .build()
        .expect("thread pool");
    for (name, method, reuse) in [
        ("search-task", Method::Hybrid, false),
        ("search-task", Method::Hybrid, true),
        ("search-task", Method::Full, false),
        ("search-task", Method::Image, false),
        ("bunny", Method::Hybrid, false),
    ] {
        let scene = scene(name);
        let options = Options {
            method,
            reuse,
            // An effect pass too: the POR box.
            por_overlay: true,
            ..Options::default()
        };
        let mut r = Renderer::new(
            &scene,
            Camera::new(&g),
            pipeline::sampling_model(g, 1.0).expect("model"),
            &options,
        )
        .expect("renderer");
        // Warm-up: the buffers grow to what this size and these masks need
        // (the walk's largest mask sets the capacities).
        let (n, bytes) = pool.install(|| {
            allocations(&mut r, &walk);
            allocations(&mut r, &walk)
        });
        assert_eq!(
            (n, bytes),
            (0, 0),
            "{name} {method:?} reuse {reuse}: {n} allocations ({bytes} bytes) in {} frames after warm-up",
            walk.len()
        );
    }
}
