//! Nested-layer foveated rendering (Guenter, Finch, Drucker, Tan & Snyder
//! 2012, "Foveated 3D Graphics"): three layers centred on the gaze, each
//! rendered at its own resolution — an inner layer at every pixel, a
//! middle layer at every second, an outer layer over the whole screen at
//! every fourth — then upsampled and blended, each inner layer over the
//! one outside it with a smooth ramp at its edge.
//!
//! **Sizes from the display's CSF.** Guenter et al. size their layers from
//! a linear acuity model fitted to their own users; here they follow the
//! same sampling model every other method uses (the Geisler–Perry cut-off
//! at the display's geometry, [`SamplingModel`]). The rule: layer k
//! samples every `s_k` pixels (1, 2, 4 by default), and layer k < 2 has a
//! full-weight square core that holds every pixel whose allowed ray
//! spacing is below `s_{k+1}` — so no pixel is sampled coarser than the
//! CSF allows — plus, outside the core, a blend band of
//! `max(2·s_{k+1}, ⌈0.15·r_k⌉)` pixels (Guenter blends over a band at each
//! layer's edge; the width is ours) over which its weight falls from 1 to
//! 0 by a smoothstep. The pixels inside the sampling model's inset (a
//! design's `inset_deg`) count as needing every pixel. The core's
//! half-size is found on square rings of pixels around the gaze: the
//! smallest ring on which every pixel's allowed spacing is at least
//! `s_{k+1}` bounds the core, by bisection; this relies on the allowed
//! spacing growing along every line from the gaze, which the tests check
//! pixel by pixel.
//!
//! **Rendering.** Each layer is an ordinary full-resolution frame of a
//! window of the screen ([`Camera::window`]) at its own step: on the CPU
//! the ray caster's full mode, on the GPU the GPU core's full frame (each
//! layer read back, the composition on the CPU — not yet a GPU pass). The
//! composition blends in linear light; a pixel in the inner layer's core is
//! that layer's own texel, byte for byte — the full frame's pixel, since a
//! window's rays are the display camera's bit for bit. The G-buffer's hit and surface
//! values come from the nearest sample of the finest layer weighing at
//! least one half there.
//!
//! A layer whose core holds the whole screen (a coarse display, or the
//! eye close to it) leaves nothing to the layers outside it, which are not
//! rendered: the frame is then the full frame.
//!
//! Counts: the inner layer's rays are reported as `rays_fovea`, the two
//! coarser layers' as `rays_mask` (their sample grids), so `rays_total` is
//! every ray of the frame.

use foveation::sampling::PorSampler;
use foveation::SamplingModel;
use raycast::frame::Layer;
use raycast::render::{Mode, Scratch, Settings, Stats, Triggers};
use raycast::{Camera, Frame};
use rayon::prelude::*;

use crate::colour;
use crate::plan::Side;
use crate::registry::{FrameMethod, MethodContext, MethodFrame, MethodModule, MethodSetup};
use crate::RenderError;

/// The method's registration (one line in [`crate::registry::METHODS`]).
pub static METHOD: MethodModule = MethodModule {
    name: "layers",
    aliases: &["guenter", "nested-layers"],
    help: "Guenter et al. 2012's nested layers: an inner layer at every pixel, a middle one at \
           every 2nd, an outer one at every 4th, sized by the display's CSF and blended",
    foveated: true,
    gpu: true,
    gpu_post: false,
    static_scene: false,
    make,
};

fn make(_: &MethodSetup<'_>) -> Result<Box<dyn FrameMethod>, RenderError> {
    Ok(Box::new(Layers::default()))
}

/// One layer of the last frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LayerRect {
    /// Samples every `step` pixels.
    pub step: u32,
    /// Half-size of the full-weight core around the gaze (px, Chebyshev);
    /// infinite for the outer layer.
    pub core_px: f64,
    /// Width of the blend band outside the core (px); 0 for the outer layer.
    pub band_px: f64,
    /// The window rendered: first screen pixel and size in its own samples.
    pub origin_px: [u32; 2],
    /// Size of the window, in the layer's own samples (width, height).
    pub size: [u32; 2],
}

/// A rendered layer: its rectangle, its frame and its colour in linear light.
#[derive(Default)]
struct Rendered {
    rect: Option<LayerRect>,
    frame: Frame,
    linear: Vec<[f32; 3]>,
}

/// The method's state: the factors and the layers' buffers, reused frame
/// to frame (allocated by the first frame).
pub struct Layers {
    factors: [u32; 3],
    layers: [Rendered; 3],
    scratch: Scratch,
    /// Per pixel, where its G-buffer values come from (see `compose`).
    sources: Vec<u32>,
    gaze_px: [f64; 2],
    rays: u64,
    screen_px: u64,
}

impl Default for Layers {
    fn default() -> Self {
        Self::new([1, 2, 4]).unwrap_or_else(|_| unreachable!("1, 2, 4 is valid"))
    }
}

/// The fraction of the core's half-size the blend band spans (at least
/// two of the next layer's samples).
pub const BAND_FRACTION: f64 = 0.15;

impl Layers {
    /// Layers sampling every `factors[k]` pixels: `1 = s0 < s1 < s2 ≤ 64`.
    pub fn new(factors: [u32; 3]) -> Result<Self, String> {
        let [s0, s1, s2] = factors;
        if !(s0 == 1 && s0 < s1 && s1 < s2 && s2 <= 64) {
            return Err(format!(
                "layer factors {factors:?}: need 1 = s0 < s1 < s2 ≤ 64"
            ));
        }
        Ok(Self {
            factors,
            layers: Default::default(),
            scratch: Scratch::default(),
            sources: Vec::new(),
            gaze_px: [f64::NAN; 2],
            rays: 0,
            screen_px: 0,
        })
    }

    /// The last frame's layers, inner first (absent: a layer no pixel
    /// needed, e.g. a gaze far off the screen).
    pub fn last_layers(&self) -> Vec<LayerRect> {
        self.layers.iter().filter_map(|l| l.rect).collect()
    }

    /// Rays the last frame cast, and the screen's pixels.
    pub fn last_rays(&self) -> (u64, u64) {
        (self.rays, self.screen_px)
    }

    /// Bytes of the layers' buffers (0 before the first frame).
    pub fn allocated_bytes(&self) -> usize {
        self.layers
            .iter()
            .map(|l| {
                l.frame.rgb.capacity()
                    + l.frame.hit.capacity()
                    + 4 * l.frame.depth_mm.capacity()
                    + 4 * l.frame.object.capacity()
                    + 12 * l.frame.normal.capacity()
                    + l.frame.layer.capacity()
                    + 12 * l.linear.capacity()
            })
            .sum()
    }

    /// Renders one frame into `frame` (the camera's size) for the gaze:
    /// each layer cast by `cast` (a window camera and the layer's frame to
    /// fill; returns its rays), then composed.
    fn render_with(
        &mut self,
        camera: &Camera,
        model: &SamplingModel,
        gaze_px: [f64; 2],
        surface: bool,
        frame: &mut Frame,
        cast: &mut dyn FnMut(&Camera, &mut Frame, &mut Scratch) -> Result<u64, String>,
    ) -> Result<Stats, String> {
        let started = std::time::Instant::now();
        if !(gaze_px[0].is_finite() && gaze_px[1].is_finite()) {
            return Err(format!(
                "the point of regard must be finite, got ({}, {})",
                gaze_px[0], gaze_px[1]
            ));
        }
        let (w, h) = (camera.width_px, camera.height_px);
        frame.reshape(w, h, surface);
        self.gaze_px = gaze_px;
        self.screen_px = u64::from(w) * u64::from(h);
        if w == 0 || h == 0 {
            self.layers.iter_mut().for_each(|l| l.rect = None);
            self.rays = 0;
            return Ok(Stats::default());
        }
        let sampler = model.from_por(gaze_px);
        let inset_half = 0.5 * model.inset_deg;
        let [s0, s1, s2] = self.factors;
        // The cores: every pixel finer than the next layer can give.
        let cores = [
            core_half_size(&sampler, gaze_px, (w, h), f64::from(s1), inset_half),
            core_half_size(&sampler, gaze_px, (w, h), f64::from(s2), inset_half),
        ];
        // A core that holds the whole screen leaves nothing to the layers
        // outside it: they are not rendered.
        let far = |g: f64, n: u32| (g - 0.5).abs().max((f64::from(n) - 0.5 - g).abs());
        let farthest = far(gaze_px[0], w).max(far(gaze_px[1], h));
        let covered_by = cores.iter().position(|c| c.is_some_and(|r| r >= farthest));
        let mut rays = [0u64; 3];
        for (k, step) in [s0, s1, s2].into_iter().enumerate() {
            let rect = match k {
                _ if covered_by.is_some_and(|c| k > c) => None,
                2 => Some(LayerRect {
                    step,
                    core_px: f64::INFINITY,
                    band_px: 0.0,
                    origin_px: [0, 0],
                    size: [w.div_ceil(step), h.div_ceil(step)],
                }),
                _ => cores[k].and_then(|core| {
                    let next = f64::from([s1, s2][k]);
                    let band = (2.0 * next).max((BAND_FRACTION * core).ceil());
                    window(gaze_px, core + band + f64::from(step), step, (w, h)).map(
                        |(origin_px, size)| LayerRect {
                            step,
                            core_px: core,
                            band_px: band,
                            origin_px,
                            size,
                        },
                    )
                }),
            };
            let layer = &mut self.layers[k];
            layer.rect = rect;
            let Some(r) = rect else { continue };
            let cam = camera.window(
                r.origin_px[0] as f32,
                r.origin_px[1] as f32,
                step as f32,
                r.size[0],
                r.size[1],
            );
            rays[k] = cast(&cam, &mut layer.frame, &mut self.scratch)?;
            let lut = colour::decode_lut();
            layer.linear.clear();
            layer
                .linear
                .extend(layer.frame.rgb.chunks_exact(3).map(|c| {
                    [
                        lut[usize::from(c[0])],
                        lut[usize::from(c[1])],
                        lut[usize::from(c[2])],
                    ]
                }));
        }
        compose(&self.layers, gaze_px, frame, &mut self.sources);
        self.rays = rays.iter().sum();
        Ok(Stats {
            rays_fovea: rays[0],
            rays_mask: rays[1] + rays[2],
            rays_total: self.rays,
            time_ms: started.elapsed().as_secs_f64() * 1e3,
            ..Stats::default()
        })
    }
}

/// The window of a layer: the square of half-size `half` around the gaze,
/// clipped to the screen, in whole pixels; its size in samples of `step`.
/// `None` when nothing of it is on the screen.
fn window(
    gaze: [f64; 2],
    half: f64,
    step: u32,
    (w, h): (u32, u32),
) -> Option<([u32; 2], [u32; 2])> {
    let span = |c: f64, n: u32| {
        let lo = (c - half).floor().max(0.0);
        let hi = (c + half).ceil().min(f64::from(n));
        (lo < hi).then(|| {
            let lo = lo as u32;
            (lo, (hi as u32 - lo).div_ceil(step))
        })
    };
    let (x0, nx) = span(gaze[0], w)?;
    let (y0, ny) = span(gaze[1], h)?;
    Some(([x0, y0], [nx, ny]))
}

/// The allowed spacing at pixel centre `p`, 1 inside the inset.
fn spacing(sampler: &PorSampler, p: [f64; 2], inset_half: f64) -> f64 {
    let s = sampler.spacing_at(p);
    if s.eccentricity_deg < inset_half {
        1.0
    } else {
        s.spacing_px
    }
}

/// The half-size (px, Chebyshev, from the gaze point to pixel centres) of
/// the smallest square around the gaze holding every pixel of the `w`×`h`
/// screen whose allowed spacing is below `below`; `None` when no pixel's
/// is. Square rings of pixels around the gaze's pixel, by bisection on the
/// ring index (see the module notes).
pub fn core_half_size(
    sampler: &PorSampler,
    gaze: [f64; 2],
    (w, h): (u32, u32),
    below: f64,
    inset_half: f64,
) -> Option<f64> {
    let (cx, cy) = (gaze[0].floor(), gaze[1].floor());
    // Ring indices that meet the screen: from the nearest to the farthest.
    let dist = |c: f64, n: u32| {
        if c < 0.0 {
            -c
        } else if c >= f64::from(n) {
            c - f64::from(n) + 1.0
        } else {
            0.0
        }
    };
    let first = dist(cx, w).max(dist(cy, h));
    let far = |c: f64, n: u32| (c - 0.0).abs().max((f64::from(n) - 1.0 - c).abs());
    let last = far(cx, w).max(far(cy, h));
    if !(first.is_finite() && last.is_finite()) || first > last {
        return None;
    }
    let coarse_enough = |n: f64| {
        ring_all(cx, cy, n, (w, h), |p| {
            spacing(sampler, p, inset_half) >= below
        })
    };
    if coarse_enough(first) {
        return None;
    }
    // The smallest ring in (first, last + 1] that is coarse enough (the
    // ring past the last is empty, so coarse enough).
    let (mut lo, mut hi) = (first, last + 1.0);
    while hi - lo > 1.0 {
        let mid = (0.5 * (lo + hi)).floor();
        if coarse_enough(mid) {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    // Ring `lo` holds a pixel finer than `below`; its centre lies at most
    // lo + ½ px from the gaze (the gaze is inside pixel (cx, cy)).
    Some(lo + 0.5)
}

/// Whether `ok` holds at the centre of every on-screen pixel of ring `n`
/// (the pixels at Chebyshev index `n` from pixel `(cx, cy)`).
fn ring_all(cx: f64, cy: f64, n: f64, (w, h): (u32, u32), ok: impl Fn([f64; 2]) -> bool) -> bool {
    let (wf, hf) = (f64::from(w), f64::from(h));
    let row = |y: f64| -> bool {
        if !(0.0..hf).contains(&y) {
            return true;
        }
        let (a, b) = ((cx - n).max(0.0), (cx + n).min(wf - 1.0));
        let mut x = a;
        while x <= b {
            if !ok([x + 0.5, y + 0.5]) {
                return false;
            }
            x += 1.0;
        }
        true
    };
    let column = |x: f64| -> bool {
        if !(0.0..wf).contains(&x) {
            return true;
        }
        let (a, b) = ((cy - n + 1.0).max(0.0), (cy + n - 1.0).min(hf - 1.0));
        let mut y = a;
        while y <= b {
            if !ok([x + 0.5, y + 0.5]) {
                return false;
            }
            y += 1.0;
        }
        true
    };
    if n == 0.0 {
        return row(cy);
    }
    row(cy - n) && row(cy + n) && column(cx - n) && column(cx + n)
}

/// A layer's weight at Chebyshev distance `d` from the gaze: 1 in the
/// core, 0 past the band, a smoothstep between.
fn weight(r: &LayerRect, d: f64) -> f32 {
    if d <= r.core_px {
        return 1.0;
    }
    let t = ((r.core_px + r.band_px - d) / r.band_px).clamp(0.0, 1.0) as f32;
    t * t * (3.0 - 2.0 * t)
}

/// The layer's sample nearest to screen point `p` and the bilinear taps
/// around it: (index of the nearest, [(index, weight); 4]).
fn taps(r: &LayerRect, p: [f64; 2]) -> (usize, [(usize, f32); 4]) {
    let s = f64::from(r.step);
    let [nx, ny] = r.size;
    let u = (p[0] - f64::from(r.origin_px[0])) / s - 0.5;
    let v = (p[1] - f64::from(r.origin_px[1])) / s - 0.5;
    let clampi = |t: f64, n: u32| t.clamp(0.0, f64::from(n - 1)) as usize;
    let (u0, v0) = (u.floor(), v.floor());
    let (fu, fv) = (
        (u - u0).clamp(0.0, 1.0) as f32,
        (v - v0).clamp(0.0, 1.0) as f32,
    );
    let (i0, i1) = (clampi(u0, nx), clampi(u0 + 1.0, nx));
    let (j0, j1) = (clampi(v0, ny), clampi(v0 + 1.0, ny));
    let at = |i: usize, j: usize| j * nx as usize + i;
    let nearest = at(clampi(u.round(), nx), clampi(v.round(), ny));
    (
        nearest,
        [
            (at(i0, j0), (1.0 - fu) * (1.0 - fv)),
            (at(i1, j0), fu * (1.0 - fv)),
            (at(i0, j1), (1.0 - fu) * fv),
            (at(i1, j1), fu * fv),
        ],
    )
}

/// No G-buffer source for a pixel.
const NO_SOURCE: u32 = u32::MAX;

/// Blends the layers into `frame`'s colour, hit and layer channels, row by
/// row in parallel; `sources` gets, per pixel, the layer (top 2 bits) and
/// sample (the rest) its G-buffer values come from, which fill the surface
/// buffers afterwards when the frame has them.
fn compose(layers: &[Rendered; 3], gaze: [f64; 2], frame: &mut Frame, sources: &mut Vec<u32>) {
    let w = frame.width_px as usize;
    let n = frame.len();
    sources.clear();
    sources.resize(n, NO_SOURCE);
    let Frame {
        rgb,
        hit,
        depth_mm,
        object,
        normal,
        layer,
        ..
    } = frame;
    rgb.par_chunks_mut(3 * w)
        .zip(hit.par_chunks_mut(w))
        .zip(layer.par_chunks_mut(w))
        .zip(sources.par_chunks_mut(w))
        .enumerate()
        .for_each(|(y, (((rgb_row, hit_row), layer_row), source_row))| {
            for x in 0..w {
                let p = [x as f64 + 0.5, y as f64 + 0.5];
                let d = (p[0] - gaze[0]).abs().max((p[1] - gaze[1]).abs());
                let mut colour = [0.0f32; 3];
                let mut exact: Option<usize> = None;
                // The finest layer weighing at least ½ gives the G-buffer.
                let mut source: Option<(usize, usize)> = None;
                let weights = [0, 1, 2].map(|k| layers[k].rect.as_ref().map_or(0.0, |r| weight(r, d)));
                // Layers outside the finest one at full weight are covered
                // by it: blending them in would multiply them by 0.
                let start = (0..3).find(|&k| weights[k] >= 1.0).unwrap_or(2);
                for k in (0..=start).rev() {
                    let l = &layers[k];
                    let Some(r) = &l.rect else { continue };
                    let wk = weights[k];
                    if wk <= 0.0 {
                        continue;
                    }
                    let (nearest, taps) = taps(r, p);
                    if k == 0 && wk >= 1.0 {
                        // The inner core: its own texel, nothing to blend.
                        exact = Some(nearest);
                        source = Some((0, nearest));
                        break;
                    }
                    let mut c = [0.0f32; 3];
                    for (i, t) in taps {
                        if t > 0.0 {
                            let v = l.linear[i];
                            c[0] += t * v[0];
                            c[1] += t * v[1];
                            c[2] += t * v[2];
                        }
                    }
                    for ch in 0..3 {
                        colour[ch] = colour[ch] * (1.0 - wk) + c[ch] * wk;
                    }
                    if wk >= 0.5 || source.is_none() {
                        source = Some((k, nearest));
                    }
                }
                let out = &mut rgb_row[3 * x..3 * x + 3];
                match exact {
                    // The inner layer's core: its own texel, byte for byte.
                    Some(i) => out.copy_from_slice(&layers[0].frame.rgb[3 * i..3 * i + 3]),
                    None => out.copy_from_slice(&colour::encode3(colour)),
                }
                let Some((k, i)) = source else { continue };
                hit_row[x] = layers[k].frame.hit.get(i).copied().unwrap_or(false);
                layer_row[x] = if exact.is_some() {
                    Layer::Fovea
                } else {
                    Layer::Interpolated
                };
                source_row[x] = ((k as u32) << 30) | (i as u32 & 0x3fff_ffff);
            }
        });
    if depth_mm.len() != n || object.len() != n || normal.len() != n {
        return;
    }
    depth_mm
        .par_iter_mut()
        .zip(object.par_iter_mut())
        .zip(normal.par_iter_mut())
        .zip(sources.par_iter())
        .for_each(|(((d, o), nrm), &src)| {
            if src == NO_SOURCE {
                return;
            }
            let f = &layers[(src >> 30) as usize].frame;
            let i = (src & 0x3fff_ffff) as usize;
            if let (Some(&dv), Some(&ov), Some(&nv)) =
                (f.depth_mm.get(i), f.object.get(i), f.normal.get(i))
            {
                *d = dv;
                *o = ov;
                *nrm = nv;
            }
        });
}

impl FrameMethod for Layers {
    fn render(&mut self, input: MethodFrame<'_>, frame: &mut Frame) -> Result<Stats, RenderError> {
        let settings = Settings {
            mode: Mode::Full,
            layout: foveation::Layout::Nyquist,
            triggers: Triggers {
                silhouette: false,
                crease_deg: None,
                depth_jump: None,
                margin: false,
            },
            test: input.test,
            check_coverage: false,
        };
        let (scene, model, gaze, surface) =
            (input.scene, input.model, input.gaze_px, input.surface);
        let rendered = match input.gpu {
            None => self.render_with(
                input.camera,
                model,
                gaze,
                surface,
                frame,
                &mut |cam, f, scratch| {
                    raycast::render::render_with(
                        scene, cam, model, &settings, gaze, surface, f, scratch,
                    )
                    .map(|s| s.rays_total)
                    .map_err(|e| e.to_string())
                },
            ),
            Some(g) => {
                g.set_surface(surface);
                self.render_with(
                    input.camera,
                    model,
                    gaze,
                    surface,
                    frame,
                    &mut |cam, f, _| {
                        let (got, stats) =
                            g.render_full_with(cam, None).map_err(|e| e.to_string())?;
                        *f = got;
                        Ok(stats.rays_total)
                    },
                )
            }
        };
        rendered.map_err(RenderError::Unsupported)
    }

    fn detail(&self, _: &MethodContext<'_>) -> String {
        let [s0, s1, s2] = self.factors;
        let mut out = format!(
            "per frame (Guenter et al. 2012): three layers around the gaze sampling every \
             {s0}, {s1} and {s2} px, each cast as a window of the screen at its own step; the \
             core of layer k holds every pixel whose CSF spacing is below the next layer's \
             step, with a smoothstep blend band of max(2·s, ⌈{BAND_FRACTION}·core⌉) px; \
             composed on the CPU in linear light"
        );
        let layers = self.last_layers();
        if !layers.is_empty() {
            let sizes: Vec<String> = layers
                .iter()
                .map(|l| {
                    if l.core_px.is_finite() {
                        format!(
                            "{}×: core ±{:.1} px + {:.0} px band",
                            l.step, l.core_px, l.band_px
                        )
                    } else {
                        format!("{}×: the whole screen", l.step)
                    }
                })
                .collect();
            out.push_str(&format!(
                "\nlast frame: {}; {} rays ({:.1} % of the screen's pixels)",
                sizes.join("; "),
                self.rays,
                100.0 * self.rays as f64 / self.screen_px.max(1) as f64
            ));
        }
        out
    }

    fn owns(&self, _: Side) -> String {
        "three layer frames with their linear colour (sized by the last frame)".into()
    }

    fn as_any(&self) -> &dyn std::any::Any {
        self
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn factors_are_checked() {
        assert!(Layers::new([1, 2, 4]).is_ok());
        for bad in [[2, 4, 8], [1, 1, 4], [1, 4, 2], [1, 2, 128], [0, 2, 4]] {
            assert!(Layers::new(bad).is_err(), "{bad:?}");
        }
    }

    #[test]
    fn the_window_is_clipped_to_the_screen() {
        assert_eq!(
            window([50.0, 40.0], 10.0, 2, (100, 80)),
            Some(([40, 30], [10, 10]))
        );
        assert_eq!(
            window([0.0, 0.0], 10.0, 1, (100, 80)),
            Some(([0, 0], [10, 10]))
        );
        assert_eq!(window([-50.0, 40.0], 10.0, 1, (100, 80)), None);
        assert_eq!(
            window([99.0, 79.0], 10.0, 4, (100, 80)),
            Some(([89, 69], [3, 3]))
        );
    }

    #[test]
    fn the_weight_falls_from_one_to_zero_across_the_band() {
        let r = LayerRect {
            step: 1,
            core_px: 10.0,
            band_px: 4.0,
            origin_px: [0, 0],
            size: [1, 1],
        };
        assert_eq!(weight(&r, 0.0), 1.0);
        assert_eq!(weight(&r, 10.0), 1.0);
        assert_eq!(weight(&r, 14.0), 0.0);
        assert!((weight(&r, 12.0) - 0.5).abs() < 1e-6);
        let ws: Vec<f32> = (0..=40)
            .map(|i| weight(&r, 10.0 + 0.1 * f64::from(i)))
            .collect();
        assert!(ws.windows(2).all(|w| w[0] >= w[1]), "{ws:?}");
    }
}
