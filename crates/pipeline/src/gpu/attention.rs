//! Lee's attention model (2009 ch. 3) on the GPU: the per-pixel and
//! per-map part (`attention.wgsl`) on a frame's colour, depth and object-id
//! buffers, ending in one small read-back of per-object statistics
//! ([`attention::FrameMeasure`]); the CPU finishes the frame with the
//! tracker's own code (`AttentionTracker::update_measured`: contexts,
//! Kalman filter, ranking, threshold).
//!
//! Per frame: a buffer clear and 21 compute dispatches (11 entry points,
//! two of them once per pyramid level; see `attention.wgsl`), one wait, and
//! a read-back of `4·(16 + 16·n)` bytes for `n` listed objects (16 KiB for
//! 256 objects);
//! the `M²` map of `S_p` stays on the GPU unless asked for
//! ([`GpuSaliency::read_saliency_map`], `4·M²` bytes: 16 KiB at 64², 1 MiB at
//! 512²). Uploads per frame: the uniform parameters (one 256-byte slot per
//! pyramid level), the per-object table (ids, speeds) when it changed, the
//! cell tables when the frame or map size did. Nothing is made before the
//! first frame (the shader, the buffers); a renderer that runs no attention
//! makes none of it ([`made_on_this_thread`] counts what is made).
//!
//! # Fixed-point sums and their bounds
//!
//! The per-object sums are integers in `u32` words (64-bit ones as two
//! words with a carry), so that they do not depend on the order in which
//! invocations add them. What keeps each from wrapping is checked at
//! compile time below:
//! - the passes that walk frame rows add runs of one id inside one map
//!   column: at most `⌈MAX_FRAME_SIDE / MIN_MAP_SIZE⌉` = [`MAX_RUN_PX`]
//!   (256) pixels, whose `S_p` sum in units of 2^-23 stays below 2^32, as
//!   do a peak cell's (at most 256 × 256 pixels) index sums;
//! - a depth counts at most [`DEPTH_CAP_MM`] = 2^29 mm, in 1/256 mm: a
//!   frame of `MAX_FRAME_PIXELS` = 2^26 pixels sums to at most 2^63, below
//!   2^64. (2^30 mm would reach 2^64 exactly; 2^30 − 1 is no f32.)

use std::cell::Cell;

use attention::contrast::contrast_weight_of_max;
use attention::frame::{MAX_FRAME_PIXELS, MAX_FRAME_SIDE};
use attention::measure::check_frame_size;
use attention::pyramid::{AxisTaps, PYRAMID_LEVELS};
use attention::{
    AttentionConfig, AttentionError, CellAxis, FrameMeasure, ObjectIndex, ObjectInfo,
    ObjectMeasure, MIN_MAP_SIZE,
};
use raycast::gpu::wgpu;
use raycast::gpu::{read_words, storage_buffer, GpuError, TrafficCounter};

use super::{dispatch_groups, level_layout, Kernels, Words, SLOT};
use crate::gpu_attention::DEPTH_CAP_MM;

/// Bytes of `AttParams` in `attention.wgsl`: 32 words, then 7 levels.
const PARAMS_BYTES: u64 = 128 + 16 * PYRAMID_LEVELS as u64;

/// Entry points, in the order of `Kernels::pipelines`.
const ENTRIES: [&str; 11] = [
    "att_stats",
    "att_objects",
    "att_cells",
    "att_rows",
    "att_cols",
    "att_contrast",
    "att_combine",
    "att_normalise",
    "att_saliency",
    "att_peak",
    "att_centroid",
];
const STATS: usize = 0;
const OBJECTS: usize = 1;
const CELLS: usize = 2;
const ROWS: usize = 3;
const COLS: usize = 4;
const CONTRAST: usize = 5;
const COMBINE: usize = 6;
const NORMALISE: usize = 7;
const SALIENCY: usize = 8;
const PEAK: usize = 9;
const CENTROID: usize = 10;

/// `stats` layout (`attention.wgsl`): globals, then a record per object.
const GLOBALS: usize = 16;
const REC: usize = 16;
const G_BACKGROUND: usize = 0;
const G_UNLISTED: usize = 1;
const G_CMAX: usize = 3;
const G_SMAX: usize = 8;
const O_COUNT: usize = 0;
const O_DEPTH_COUNT: usize = 1;
const O_SUM_X: usize = 2;
const O_SUM_Y: usize = 4;
const O_DEPTH: usize = 6;
const O_SAL: usize = 8;
const O_BEST: usize = 10;
const O_NOT_CELL: usize = 11;
const O_PEAK_COUNT: usize = 12;
const O_PEAK_X: usize = 13;
const O_PEAK_Y: usize = 14;
/// Steps of the fixed-point sums (both handed to the shader as
/// uniforms): depth in 1/256 mm, `S_p` in 2^-23.
const DEPTH_STEPS_PER_MM: u32 = 256;
const SALIENCY_STEPS: u32 = 1 << 23;
const DEPTH_UNIT_MM: f64 = 1.0 / DEPTH_STEPS_PER_MM as f64;
const SALIENCY_UNIT: f64 = 1.0 / SALIENCY_STEPS as f64;
/// Workgroup side of the 2-D entry points, and size of the 1-D ones.
const GROUP_2D: u32 = 8;
const GROUP_1D: u32 = 64;

/// The most pixels of one frame row in one map column: the longest run the
/// row passes (`att_stats`, `att_saliency`) add at once, and the side of a
/// map cell's footprint (`att_centroid`).
const MAX_RUN_PX: u32 = 256;
const _: () = assert!(MAX_FRAME_SIDE.div_ceil(MIN_MAP_SIZE) <= MAX_RUN_PX);
// One run's S_p sum: at most MAX_RUN_PX pixels of S_p ≤ 1 (2^23 steps).
const _: () = assert!(MAX_RUN_PX as u64 * SALIENCY_STEPS as u64 <= u32::MAX as u64);
// One run's column index sum (`att_stats`), and a peak cell's index sums
// (`att_centroid`: at most MAX_RUN_PX² pixels, indices below MAX_FRAME_SIDE).
const _: () = assert!((MAX_RUN_PX as u64).pow(2) * MAX_FRAME_SIDE as u64 <= u32::MAX as u64);
// The depth cap is an f32 integer, and 2^26 pixels at the cap, in 1/256 mm,
// stay below 2^64 (the per-object sum cannot wrap).
const _: () = assert!((DEPTH_CAP_MM as u64) as f32 == DEPTH_CAP_MM);
const _: () = assert!(
    MAX_FRAME_PIXELS as u128 * DEPTH_CAP_MM as u128 * DEPTH_STEPS_PER_MM as u128 <= 1u128 << 63
);

thread_local! {
    /// [`GpuSaliency`] values made on this thread.
    static MADE: Cell<u64> = const { Cell::new(0) };
}

/// How many [`GpuSaliency`] values (the GPU attention state) this thread
/// has made: what pay per use is tested with. Per thread, because tests
/// run in parallel and a renderer makes its state on the thread that
/// renders.
pub(crate) fn made_on_this_thread() -> u64 {
    MADE.with(Cell::get)
}

/// The frame buffers the passes read, on the device they live on.
pub(crate) struct SaliencyInput<'a> {
    pub device: &'a wgpu::Device,
    pub queue: &'a wgpu::Queue,
    /// The counter its uploads, dispatches and read-backs go through.
    pub traffic: &'a TrafficCounter,
    /// Packed colour words (`pack` in cast.wgsl); bit 24 is the hit flag.
    pub pixels: &'a wgpu::Buffer,
    /// Eye distance per pixel, f32 bits.
    pub depth: &'a wgpu::Buffer,
    /// Object id per pixel.
    pub ids: &'a wgpu::Buffer,
    pub width: u32,
    pub height: u32,
    /// `max_storage_buffer_binding_size`.
    pub max_binding: u64,
}

/// Word offsets of the per-frame tables and map regions.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Layout {
    t_sorted: u32,
    t_direct: u32,
    direct_len: u32,
    t_speed: u32,
    t_fx0: u32,
    t_fx1: u32,
    t_fy0: u32,
    t_fy1: u32,
    t_ox0: u32,
    t_ox1: u32,
    t_oy0: u32,
    t_oy1: u32,
    t_celly: u32,
    t_taps: u32,
    m_plane: u32,
    m_scratch: u32,
    m_scratch_plane: u32,
    m_contrast: u32,
    m_sal: u32,
    m_objfeat: u32,
    m_total: u64,
}

struct Buffers {
    /// The frame buffers the bind group was made for (handles: the bind
    /// group holds the same buffers alive anyway, and wgpu compares
    /// buffers only through a handle).
    frame: [wgpu::Buffer; 3],
    tables_words: u64,
    stats_words: u64,
    maps_words: u64,
    params: wgpu::Buffer,
    tables: wgpu::Buffer,
    stats: wgpu::Buffer,
    maps: wgpu::Buffer,
    group: wgpu::BindGroup,
}

/// The GPU state of the attention model's per-pixel part: the shader and,
/// from the first frame, its buffers.
pub(crate) struct GpuSaliency {
    config: AttentionConfig,
    kernels: Option<Kernels>,
    buffers: Option<Buffers>,
    index: ObjectIndex,
    tables: Vec<u32>,
    uploaded_tables: Vec<u32>,
    layout: Layout,
    /// The frame size the cell tables were made for.
    grid: Option<(u32, u32)>,
    cell_tables: Vec<u32>,
    /// The last frame's contrast maxima (eq. 3.6) and the maximum of `S̄_p`.
    maxima: [f32; 6],
    /// Width and height of the last frame measured into the buffers now
    /// held; `None` before, after new buffers and after a failed `measure`.
    measured: Option<(u32, u32)>,
}

impl Buffers {
    /// Made for `frame`, with room for the tables, statistics and maps.
    fn serves(&self, frame: [&wgpu::Buffer; 3], tables: u64, stats: u64, maps: u64) -> bool {
        self.frame.iter().zip(frame).all(|(a, f)| a == f)
            && self.tables_words >= tables
            && self.stats_words >= stats
            && self.maps_words >= maps
    }

    /// New buffers of these sizes (words) and their bind group over
    /// `input`'s frame; nothing is kept on an error.
    fn new(
        kernels: &Kernels,
        input: &SaliencyInput<'_>,
        tables_words: u64,
        stats_words: u64,
        maps_words: u64,
    ) -> Result<Self, GpuError> {
        let device = input.device;
        let max = input.max_binding;
        use wgpu::BufferUsages as U;
        let tables = storage_buffer(
            device,
            "attention tables",
            4 * tables_words,
            U::COPY_DST,
            max,
        )?;
        let stats = storage_buffer(
            device,
            "attention object statistics",
            4 * stats_words,
            U::COPY_DST | U::COPY_SRC,
            max,
        )?;
        let maps = storage_buffer(device, "attention maps", 4 * maps_words, U::COPY_SRC, max)?;
        let params = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("attention params"),
            size: SLOT * PYRAMID_LEVELS as u64,
            usage: U::UNIFORM | U::COPY_DST,
            mapped_at_creation: false,
        });
        let group = kernels.bind(
            device,
            &params,
            PARAMS_BYTES,
            input.pixels,
            &[input.depth, input.ids, &tables, &stats, &maps],
        );
        Ok(Self {
            frame: [input.pixels, input.depth, input.ids].map(Clone::clone),
            tables_words,
            stats_words,
            maps_words,
            params,
            tables,
            stats,
            maps,
            group,
        })
    }
}

impl GpuSaliency {
    /// The state for `config` (checked by the caller's tracker); nothing on
    /// the GPU yet.
    pub fn new(config: AttentionConfig) -> Self {
        MADE.with(|m| m.set(m.get() + 1));
        Self {
            config,
            kernels: None,
            buffers: None,
            index: ObjectIndex::default(),
            tables: Vec::new(),
            uploaded_tables: Vec::new(),
            layout: Layout::default(),
            grid: None,
            cell_tables: Vec::new(),
            maxima: [0.0; 6],
            measured: None,
        }
    }

    /// Whether the buffers exist (made by the first frame).
    pub fn has_buffers(&self) -> bool {
        self.buffers.is_some()
    }

    /// `w_f` of eq. 3.6 in `Feature::ALL` order, from the last frame's
    /// maxima (0 for switched-off or flat features).
    pub fn weights(&self) -> [f32; 5] {
        let on = self.config.features.as_array();
        std::array::from_fn(|f| {
            if on[f] {
                contrast_weight_of_max(self.maxima[f])
            } else {
                0.0
            }
        })
    }

    /// Decision 7 of the attention crate: whether `S_p` carried anything.
    fn informative(&self) -> bool {
        let active = self.weights().iter().any(|&w| w > 0.0);
        let smax = self.maxima[5];
        self.config.features.any_bottom_up() && active && smax > 0.0 && smax.is_finite()
    }

    /// Checks the frame and the object list and makes what the frame needs
    /// (tables, buffers); nothing is encoded. Errors here leave every GPU
    /// buffer as it was.
    pub fn prepare(
        &mut self,
        input: &SaliencyInput<'_>,
        objects: &[ObjectInfo],
    ) -> Result<(), PrepareError> {
        let (w, h) = (input.width, input.height);
        check_frame_size(w, h)?;
        self.index.rebuild(objects)?;
        let m = self.config.map_size;
        if self.grid != Some((w, h)) {
            self.build_cell_tables(w, h, m)?;
            self.grid = Some((w, h));
        }
        let n = self.index.len();
        // The per-object table: sorted ids, speeds, the direct lookup.
        self.tables.clear();
        self.tables.extend_from_slice(&self.cell_tables);
        let mut layout = self.layout;
        layout.t_sorted = self.tables.len() as u32;
        self.tables.extend_from_slice(self.index.sorted_ids());
        layout.t_speed = self.tables.len() as u32;
        self.tables.extend(
            self.index
                .sources()
                .iter()
                .map(|&s| objects[s].speed_used().to_bits()),
        );
        layout.t_direct = self.tables.len() as u32;
        let direct = self.index.direct_table();
        layout.direct_len = direct.map_or(0, |t| t.len() as u32);
        self.tables.extend_from_slice(direct.unwrap_or_default());
        // Maps: the pyramids, the REDUCE scratch, contrast, S_p, B_s and B_m.
        let (levels, texels) = level_layout(m, m, PYRAMID_LEVELS);
        let plane = texels;
        let scratch_plane = u64::from(m.div_ceil(2)) * u64::from(m);
        let cells = u64::from(m) * u64::from(m);
        layout.m_plane = plane as u32;
        layout.m_scratch = (6 * plane) as u32;
        layout.m_scratch_plane = scratch_plane as u32;
        layout.m_contrast = (6 * plane + 6 * scratch_plane) as u32;
        layout.m_sal = (u64::from(layout.m_contrast) + 5 * cells) as u32;
        layout.m_objfeat = (u64::from(layout.m_sal) + cells) as u32;
        layout.m_total = u64::from(layout.m_objfeat) + 2 * n.max(1) as u64;
        self.layout = layout;
        debug_assert_eq!(levels.len(), PYRAMID_LEVELS);

        let tables_words = self.tables.len().max(1) as u64;
        let stats_words = (GLOBALS + REC * n.max(1)) as u64;
        let device = input.device;
        let kernels = &*self.kernels.get_or_insert_with(|| {
            // Only the packed colour words are read: no colour tables.
            Kernels::without_colour_tables(
                device,
                input.traffic,
                "attention.wgsl",
                include_str!("attention.wgsl"),
                &ENTRIES,
                &[true, true, true, false, false],
                PARAMS_BYTES,
            )
        });
        let frame = [input.pixels, input.depth, input.ids];
        let b = match &mut self.buffers {
            Some(b) if b.serves(frame, tables_words, stats_words, layout.m_total) => &*b,
            held => {
                // New buffers: for a new frame, or more room. The tables
                // and statistics never shrink (keeping the larger of the
                // old and new sizes), so an object list that shrinks and
                // grows back does not reallocate.
                let (tables_words, stats_words) =
                    held.as_ref().map_or((tables_words, stats_words), |b| {
                        (
                            tables_words.max(b.tables_words),
                            stats_words.max(b.stats_words),
                        )
                    });
                let new = Buffers::new(kernels, input, tables_words, stats_words, layout.m_total)?;
                // Nothing of the old buffers is left: no tables uploaded,
                // no map measured.
                self.uploaded_tables.clear();
                self.measured = None;
                &*held.insert(new)
            }
        };
        if self.uploaded_tables != self.tables {
            input.traffic.write_buffer(
                input.queue,
                &b.tables,
                0,
                bytemuck::cast_slice(&self.tables),
            );
            self.uploaded_tables.clone_from(&self.tables);
        }
        // One uniform slot per pyramid level (the rows/cols dispatches read
        // `level`); slot 0 serves every other dispatch.
        let cfg = &self.config;
        let flags = cfg
            .features
            .as_array()
            .iter()
            .enumerate()
            .fold(0u32, |acc, (i, &on)| acc | (u32::from(on) << i));
        let near = cfg.depth_near_mm;
        let inv_range = 1.0 / (cfg.depth_far_mm - near);
        let mut all = Vec::with_capacity(SLOT as usize * PYRAMID_LEVELS);
        for level in 0..PYRAMID_LEVELS as u32 {
            let mut words = Words::default();
            words
                .u(w)
                .u(h)
                .u(m)
                .u(n as u32)
                .u(flags)
                .u(u32::from(direct.is_some()))
                .u(layout.direct_len)
                .u(level)
                .f(near)
                .f(inv_range)
                .f((u64::from(w) * u64::from(h)) as f32)
                .f(DEPTH_CAP_MM)
                .u(layout.t_sorted)
                .u(layout.t_direct)
                .u(layout.t_speed)
                .u(layout.t_fx0)
                .u(layout.t_fx1)
                .u(layout.t_fy0)
                .u(layout.t_fy1)
                .u(layout.t_ox0)
                .u(layout.t_ox1)
                .u(layout.t_oy0)
                .u(layout.t_oy1)
                .u(layout.t_celly)
                .u(layout.t_taps)
                .u(layout.m_plane)
                .u(layout.m_scratch)
                .u(layout.m_scratch_plane)
                .u(layout.m_contrast)
                .u(layout.m_sal)
                .u(layout.m_objfeat)
                .f(SALIENCY_STEPS as f32);
            for l in &levels {
                words.u(l[0]).u(l[1]).u(l[2]).u(0);
            }
            words.pad_to(SLOT as usize);
            all.extend(words.0);
        }
        input.traffic.write_buffer(input.queue, &b.params, 0, &all);
        Ok(())
    }

    /// The frame-size tables: footprints and owned pixel ranges on both
    /// axes, each frame row's map row, and the CPU's magnification taps.
    /// Sizes are checked (by [`CellAxis::new`]) before anything changes.
    fn build_cell_tables(&mut self, w: u32, h: u32, m: u32) -> Result<(), AttentionError> {
        let x = CellAxis::new(w, m)?;
        let y = CellAxis::new(h, m)?;
        let t = &mut self.cell_tables;
        t.clear();
        let l = &mut self.layout;
        let push = |t: &mut Vec<u32>, values: &[u32]| {
            let at = t.len() as u32;
            t.extend_from_slice(values);
            at
        };
        let owned_x = x.owned();
        let owned_y = y.owned();
        let first = |r: &[[u32; 2]]| r.iter().map(|r| r[0]).collect::<Vec<u32>>();
        let end = |r: &[[u32; 2]]| r.iter().map(|r| r[1]).collect::<Vec<u32>>();
        l.t_fx0 = push(t, &x.lo);
        l.t_fx1 = push(t, &x.hi);
        l.t_fy0 = push(t, &y.lo);
        l.t_fy1 = push(t, &y.hi);
        l.t_ox0 = push(t, &first(&owned_x));
        l.t_ox1 = push(t, &end(&owned_x));
        l.t_oy0 = push(t, &first(&owned_y));
        l.t_oy1 = push(t, &end(&owned_y));
        l.t_celly = push(t, &y.cell_of);
        // The magnification taps of levels 1-6 as contrast.rs makes them
        // (`pyramid::AxisTaps`; the map is square: one table, both axes),
        // interleaved: lower texel, upper texel, the upper one's weight.
        l.t_taps = t.len() as u32;
        let (levels, _) = level_layout(m, m, PYRAMID_LEVELS);
        let mut taps = AxisTaps::default();
        for level in &levels[1..] {
            taps.fill(m as usize, level[1] as usize);
            for ((&lo, &hi), &frac) in taps.lo.iter().zip(&taps.hi).zip(&taps.frac) {
                t.extend([lo, hi, frac.to_bits()]);
            }
        }
        Ok(())
    }

    /// Encodes the passes on the frame `prepare` checked, submits them with
    /// `encoder`, waits, and reads the per-object statistics back: the
    /// frame's [`FrameMeasure`], its records in the order of `objects`
    /// (the list given to `prepare`), and a fresh encoder.
    pub fn measure(
        &mut self,
        input: &SaliencyInput<'_>,
        mut encoder: wgpu::CommandEncoder,
    ) -> Result<(FrameMeasure, wgpu::CommandEncoder), GpuError> {
        // Until this frame is read back, the maps hold no finished frame.
        self.measured = None;
        let (Some(kernels), Some(b)) = (self.kernels.as_ref(), self.buffers.as_ref()) else {
            return Err(GpuError::Readback(
                "attention: measure before prepare".into(),
            ));
        };
        let (w, h) = (input.width, input.height);
        let m = self.config.map_size;
        let n = self.index.len() as u32;
        let p = &kernels.pipelines;
        let g = &b.group;
        let groups2 = |x: u32, y: u32| [x.div_ceil(GROUP_2D), y.div_ceil(GROUP_2D), 1];
        let groups1 = |x: u32| [x.div_ceil(GROUP_1D), 1, 1];
        let stats_words = (GLOBALS + REC * n as usize) as u64;
        encoder.clear_buffer(&b.stats, 0, Some(4 * stats_words));
        dispatch_groups(&mut encoder, input.traffic, &p[STATS], g, 0, groups2(m, h));
        if self.config.features.any_bottom_up() {
            dispatch_groups(&mut encoder, input.traffic, &p[OBJECTS], g, 0, groups1(n));
            dispatch_groups(&mut encoder, input.traffic, &p[CELLS], g, 0, groups2(m, m));
            let (levels, _) = level_layout(m, m, PYRAMID_LEVELS);
            for l in 0..PYRAMID_LEVELS - 1 {
                let [_, _, src_h] = levels[l];
                let [_, dst_w, dst_h] = levels[l + 1];
                let [gx, gy, _] = groups2(dst_w, src_h);
                dispatch_groups(
                    &mut encoder,
                    input.traffic,
                    &p[ROWS],
                    g,
                    l as u32,
                    [gx, gy, 6],
                );
                let [gx, gy, _] = groups2(dst_w, dst_h);
                dispatch_groups(
                    &mut encoder,
                    input.traffic,
                    &p[COLS],
                    g,
                    l as u32,
                    [gx, gy, 6],
                );
            }
            dispatch_groups(
                &mut encoder,
                input.traffic,
                &p[CONTRAST],
                g,
                0,
                groups2(m, m),
            );
            dispatch_groups(
                &mut encoder,
                input.traffic,
                &p[COMBINE],
                g,
                0,
                groups2(m, m),
            );
        }
        dispatch_groups(
            &mut encoder,
            input.traffic,
            &p[NORMALISE],
            g,
            0,
            groups2(m, m),
        );
        dispatch_groups(
            &mut encoder,
            input.traffic,
            &p[SALIENCY],
            g,
            0,
            groups2(m, h),
        );
        dispatch_groups(&mut encoder, input.traffic, &p[PEAK], g, 0, groups2(m, h));
        dispatch_groups(&mut encoder, input.traffic, &p[CENTROID], g, 0, groups1(n));
        let (mut words, next) = read_words(
            input.device,
            input.queue,
            input.traffic,
            encoder,
            &[(&b.stats, 0, stats_words)],
        )?;
        let words = words.pop().unwrap_or_default();
        if words.len() as u64 != stats_words {
            return Err(GpuError::Readback(
                "attention statistics: short read".into(),
            ));
        }
        let f = |i: usize| f32::from_bits(words[i]);
        self.maxima = [
            f(G_CMAX),
            f(G_CMAX + 1),
            f(G_CMAX + 2),
            f(G_CMAX + 3),
            f(G_CMAX + 4),
            f(G_SMAX),
        ];
        let wide = |i: usize| u64::from(words[i]) | (u64::from(words[i + 1]) << 32);
        let mut records = vec![ObjectMeasure::default(); n as usize];
        for (d, &source) in self.index.sources().iter().enumerate() {
            let r = GLOBALS + REC * d;
            let not_cell = words[r + O_NOT_CELL];
            let count = u64::from(words[r + O_COUNT]);
            let peak_count = if not_cell == 0 {
                0
            } else {
                u64::from(words[r + O_PEAK_COUNT])
            };
            records[source] = ObjectMeasure {
                pixel_count: count,
                depth_sum_mm: wide(r + O_DEPTH) as f64 * DEPTH_UNIT_MM,
                depth_count: u64::from(words[r + O_DEPTH_COUNT]),
                sum_x: wide(r + O_SUM_X),
                sum_y: wide(r + O_SUM_Y),
                saliency_sum: wide(r + O_SAL) as f64 * SALIENCY_UNIT,
                peak_saliency: f32::from_bits(words[r + O_BEST]),
                peak_cell: !not_cell,
                peak_count,
                peak_sum_x: u64::from(words[r + O_PEAK_X]),
                peak_sum_y: u64::from(words[r + O_PEAK_Y]),
            };
        }
        self.measured = Some((w, h));
        Ok((
            FrameMeasure {
                width: w,
                height: h,
                objects: records,
                background_pixels: u64::from(words[G_BACKGROUND]),
                unlisted_pixels: u64::from(words[G_UNLISTED]),
                bottom_up_informative: self.informative(),
            },
            next,
        ))
    }

    /// The last frame's `S_p` map (`M²` values, row-major), read back: a
    /// wait on the GPU and `4·M²` bytes. `None` unless a frame was measured
    /// into the buffers now held (before the first frame, after `prepare`
    /// made new buffers, after a failed `measure`).
    pub fn read_saliency_map(
        &self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        traffic: &TrafficCounter,
    ) -> Result<Option<Vec<f32>>, GpuError> {
        let (Some(b), Some(_)) = (self.buffers.as_ref(), self.measured) else {
            return Ok(None);
        };
        let m = u64::from(self.config.map_size);
        let encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("attention map read"),
        });
        let (mut words, _) = read_words(
            device,
            queue,
            traffic,
            encoder,
            &[(&b.maps, u64::from(self.layout.m_sal), m * m)],
        )?;
        Ok(Some(
            words
                .pop()
                .unwrap_or_default()
                .into_iter()
                .map(f32::from_bits)
                .collect(),
        ))
    }
}

/// Why a frame could not be prepared: the model refused it (size, object
/// list) or the GPU could not hold it.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PrepareError {
    #[error(transparent)]
    Attention(#[from] AttentionError),
    #[error(transparent)]
    Gpu(#[from] GpuError),
}

#[cfg(test)]
mod tests {
    use super::*;
    use raycast::gpu::{open_device, GpuDevice};

    fn device() -> GpuDevice {
        open_device().unwrap_or_else(|e| {
            panic!("{e} — install Mesa's software Vulkan (Debian: mesa-vulkan-drivers)")
        })
    }

    /// A `w`×`h` frame's colour, depth and id buffers: object 1 in the
    /// top-left quarter on a background, every pixel a hit.
    fn frame(gpu: &GpuDevice, w: u32, h: u32) -> [wgpu::Buffer; 3] {
        let n = (w * h) as usize;
        let mut colour = vec![0x0180_8080u32; n];
        let mut ids = vec![attention::BACKGROUND_ID; n];
        for y in 0..h / 2 {
            for x in 0..w / 2 {
                let i = (y * w + x) as usize;
                colour[i] = 0x0120_20e0;
                ids[i] = 1;
            }
        }
        let depth = vec![1500.0f32; n];
        let make = |what, bytes: &[u8]| {
            let b = storage_buffer(
                &gpu.device,
                what,
                bytes.len() as u64,
                wgpu::BufferUsages::COPY_DST,
                gpu.max_binding,
            )
            .expect("a small buffer");
            gpu.traffic.write_buffer(&gpu.queue, &b, 0, bytes);
            b
        };
        [
            make("test colour", bytemuck::cast_slice(&colour)),
            make("test depth", bytemuck::cast_slice(&depth)),
            make("test ids", bytemuck::cast_slice(&ids)),
        ]
    }

    fn input<'a>(
        gpu: &'a GpuDevice,
        f: &'a [wgpu::Buffer; 3],
        w: u32,
        h: u32,
    ) -> SaliencyInput<'a> {
        SaliencyInput {
            device: &gpu.device,
            queue: &gpu.queue,
            traffic: &gpu.traffic,
            pixels: &f[0],
            depth: &f[1],
            ids: &f[2],
            width: w,
            height: h,
            max_binding: gpu.max_binding,
        }
    }

    fn encoder(gpu: &GpuDevice) -> wgpu::CommandEncoder {
        gpu.device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None })
    }

    /// The `S_p` map read back is always the last frame measured into the
    /// buffers held: none once `prepare` made new buffers (as for a new
    /// frame) until a frame is measured into them, never their zeros.
    #[test]
    fn new_buffers_hold_no_map_until_a_frame_is_measured() {
        let gpu = device();
        let config = AttentionConfig::default();
        let m = config.map_size as usize;
        let objects = [ObjectInfo::still(1, 1.0)];
        let mut s = GpuSaliency::new(config);
        let map = |s: &GpuSaliency| {
            s.read_saliency_map(&gpu.device, &gpu.queue, &gpu.traffic)
                .expect("read back")
        };
        assert_eq!(map(&s), None, "before any frame");
        let a = frame(&gpu, 96, 64);
        s.prepare(&input(&gpu, &a, 96, 64), &objects)
            .expect("prepared");
        assert_eq!(map(&s), None, "prepared, not measured");
        let (measure, _) = s
            .measure(&input(&gpu, &a, 96, 64), encoder(&gpu))
            .expect("measured");
        assert_eq!(measure.objects[0].pixel_count, 48 * 32);
        let first = map(&s).expect("a map after a frame");
        assert_eq!(first.len(), m * m);
        assert!(first.iter().any(|&v| v > 0.0), "not the buffers' zeros");
        // A refused object list leaves the buffers, and the map, alone.
        let refused = s.prepare(
            &input(&gpu, &a, 96, 64),
            &[ObjectInfo::still(1, 1.0), ObjectInfo::still(1, 1.0)],
        );
        assert!(matches!(refused, Err(PrepareError::Attention(_))));
        assert_eq!(map(&s).as_ref(), Some(&first));
        // Another frame's buffers: new attention buffers, whose zeros must
        // not be read as the last frame's map (a `measure` that failed
        // after this `prepare` would leave just this).
        let b = frame(&gpu, 80, 60);
        s.prepare(&input(&gpu, &b, 80, 60), &objects)
            .expect("prepared");
        assert_eq!(map(&s), None, "new buffers, nothing measured into them");
        s.measure(&input(&gpu, &b, 80, 60), encoder(&gpu))
            .expect("measured");
        assert!(map(&s).is_some_and(|v| v.len() == m * m && v.iter().any(|&v| v > 0.0)));
    }
}
