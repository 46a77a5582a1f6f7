//! Pictures of the ray mask (like Murphy 2007 Fig. 4.3), of the sampling
//! rate against eccentricity (like Fig. 4.4) and of the benchmarks (the
//! Pareto plot, log–log scaling), drawn with `plotters` and saved with
//! [`crate::picture`].

use std::path::{Path, PathBuf};

use foveation::{RayMask, SamplingModel};
use plotters::prelude::*;

use crate::picture::{register_font, save_png};

type DrawResult = Result<(), Box<dyn std::error::Error>>;

/// `mask.png` → `mask-csf.png`.
pub fn csf_path(png: &Path) -> PathBuf {
    let stem = png.file_stem().and_then(|s| s.to_str()).unwrap_or("mask");
    png.with_file_name(format!("{stem}-csf.png"))
}

/// The screen with the fovea disc and the intermediate mesh, scaled to at
/// most 1600 px wide (small screens are enlarged up to 2× so the mesh stays
/// legible). The caption compares the rays with `nyquist_bound_rays`.
pub fn draw_mask(
    path: &Path,
    m: &RayMask,
    model: &SamplingModel,
    nyquist_bound_rays: f64,
) -> DrawResult {
    register_font();
    let (w, h) = (f64::from(m.width_px), f64::from(m.height_px));
    let scale = (1600.0 / w).min(2.0);
    let plot_w = (w * scale).round() as u32;
    let plot_h = (h * scale).round() as u32;
    let size = (plot_w.max(600) + 20, plot_h + 70);
    draw_png(path, size, |root| {
        let caption = format!(
            "{} layout, C = {}: {} rays = {:.2}x the Nyquist bound, of {} pixels",
            m.layout.name(),
            model.contrast,
            m.rays(),
            m.rays() as f64 / nyquist_bound_rays,
            u64::from(m.width_px) * u64::from(m.height_px)
        );
        let mut chart = ChartBuilder::on(root)
            .caption(caption, ("sans-serif", 16))
            .margin(10)
            .build_cartesian_2d(0.0..w, h..0.0)?;
        let screen = chart.plotting_area();
        screen.fill(&RGBColor(250, 250, 250))?;
        // Opaque colours only: the picture then has few distinct colours and
        // saves as a small palette PNG.
        let mesh = RGBColor(110, 150, 205);
        for i in 0..m.cells.len() {
            let mut c = m.cell_corners(i);
            c.push(c[0]);
            let pts: Vec<(f64, f64)> = c.iter().map(|p| (p[0], p[1])).collect();
            chart.draw_series(std::iter::once(PathElement::new(pts, mesh.stroke_width(1))))?;
        }
        let fovea = RGBColor(200, 40, 40);
        chart.draw_series(m.fovea.iter().map(|s| {
            Rectangle::new(
                [
                    (f64::from(s.x_start), f64::from(s.y)),
                    (f64::from(s.x_end), f64::from(s.y) + 1.0),
                ],
                fovea.filled(),
            )
        }))?;
        let g = (m.por_px[0], m.por_px[1]);
        let arm = 12.0 / scale;
        chart.draw_series([
            PathElement::new(
                vec![(g.0 - arm, g.1), (g.0 + arm, g.1)],
                BLACK.stroke_width(2),
            ),
            PathElement::new(
                vec![(g.0, g.1 - arm), (g.0, g.1 + arm)],
                BLACK.stroke_width(2),
            ),
        ])?;
        Ok(())
    })
}

type Area<'a> = DrawingArea<BitMapBackend<'a>, plotters::coord::Shift>;

/// Draws onto a white RGB canvas of `size` and saves it with [`save_png`].
fn draw_png(path: &Path, size: (u32, u32), draw: impl FnOnce(&Area) -> DrawResult) -> DrawResult {
    let mut rgb = vec![0u8; size.0 as usize * size.1 as usize * 3];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, size).into_drawing_area();
        root.fill(&WHITE)?;
        draw(&root)?;
        root.present()?;
    }
    save_png(path, size, &rgb)
}

/// Sampling rate (rays per degree) against eccentricity: what the CSF asks
/// for, what one ray per pixel can give, and what the layout casts, on the
/// display named `display`.
pub fn draw_csf(path: &Path, m: &RayMask, model: &SamplingModel, display: &str) -> DrawResult {
    register_font();
    let rings = &m.rings;
    let max_e = rings
        .last()
        .map_or(10.0, |r| r.tightest.eccentricity_deg)
        .max(1.0);
    let required = |e: f64| 2.0 * model.csf.cutoff_frequency_cpd(model.contrast, e);
    let top = required(0.0).max(rings.iter().map(|r| r.tightest.ppd).fold(0.0, f64::max)) * 1.05;
    draw_png(path, (900, 560), |root| {
        let mut chart = ChartBuilder::on(root)
            .caption(
                format!(
                    "Sampling rate vs eccentricity: {} ({} layout, C = {})",
                    display,
                    m.layout.name(),
                    model.contrast
                ),
                ("sans-serif", 16),
            )
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(60)
            .build_cartesian_2d(0.0..max_e, 0.0..top)?;
        chart
            .configure_mesh()
            .x_desc("eccentricity (degrees)")
            .y_desc("rays per degree")
            .label_style(("sans-serif", 13))
            .draw()?;
        let n = 400;
        chart
            .draw_series(LineSeries::new(
                (0..=n).map(|i| {
                    let e = max_e * f64::from(i) / f64::from(n);
                    (e, required(e))
                }),
                RED.stroke_width(2),
            ))?
            .label("CSF cut-off x 2 (Nyquist rate), eq. 4.3")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], RED.stroke_width(2)));
        chart
            .draw_series(LineSeries::new(
                rings
                    .iter()
                    .map(|r| (r.tightest.eccentricity_deg, r.tightest.ppd)),
                BLACK.stroke_width(1),
            ))?
            .label("one ray per pixel (local px/deg)")
            .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], BLACK.stroke_width(1)));
        let mut steps = Vec::with_capacity(rings.len() * 2);
        for (k, r) in rings.iter().enumerate() {
            let rate = r.tightest.ppd / r.radial_step_px;
            let next_e = rings
                .get(k + 1)
                .map_or(max_e, |n| n.tightest.eccentricity_deg);
            steps.push((r.tightest.eccentricity_deg, rate));
            steps.push((next_e, rate));
        }
        let blue = RGBColor(30, 80, 200);
        chart
            .draw_series(LineSeries::new(steps, blue.stroke_width(2)))?
            .label(format!(
                "{} layout (radial rays per degree, per ring)",
                m.layout.name()
            ))
            .legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 20, y)], blue.stroke_width(2))
            });
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .border_style(BLACK)
            .background_style(WHITE.mix(0.9))
            .label_font(("sans-serif", 13))
            .draw()?;
        Ok(())
    })
}

/// One configuration on the accuracy-versus-time plot.
#[derive(Debug, Clone)]
pub struct ParetoPoint {
    /// The configuration's label.
    pub label: String,
    /// Frame time, ms.
    pub time_ms: f64,
    /// Foveated PSNR (dB); ∞ for the exact reference, drawn at the top.
    pub quality_db: f64,
    /// Whether the point is on the Pareto front (drawn joined).
    pub pareto: bool,
    /// The default configuration (drawn larger, always labelled).
    pub highlight: bool,
    /// Uses the uniform grid (drawn as a cross instead of a dot).
    pub grid: bool,
}

/// Quality against frame time, one point per configuration, the Pareto front
/// joined and labelled. Exact results (∞ dB) sit on a line at the top.
pub fn draw_pareto(path: &Path, title: &str, points: &[ParetoPoint]) -> DrawResult {
    register_font();
    let finite: Vec<f64> = points
        .iter()
        .map(|p| p.quality_db)
        .filter(|q| q.is_finite())
        .collect();
    let lo = finite.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = finite.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let (lo, hi) = if lo.is_finite() {
        (lo, hi)
    } else {
        (0.0, 40.0)
    };
    let exact_y = hi + (hi - lo).max(4.0) * 0.12;
    let y_range = (lo - (hi - lo).max(4.0) * 0.05)..(exact_y + (hi - lo).max(4.0) * 0.05);
    let t_max = points.iter().map(|p| p.time_ms).fold(0.0, f64::max) * 1.08;
    let y = |p: &ParetoPoint| {
        if p.quality_db.is_infinite() {
            exact_y
        } else {
            p.quality_db
        }
    };
    draw_png(path, (1100, 720), |root| {
        let mut chart = ChartBuilder::on(root)
            .caption(
                format!("Foveated PSNR against frame time: {title}"),
                ("sans-serif", 17),
            )
            .margin(14)
            .x_label_area_size(44)
            .y_label_area_size(64)
            .build_cartesian_2d(0.0..t_max.max(1e-3), y_range)?;
        chart
            .configure_mesh()
            .x_desc("frame time (ms, lower is better)")
            .y_desc("foveated PSNR (dB, higher is better)")
            .label_style(("sans-serif", 13))
            .draw()?;
        chart.draw_series(std::iter::once(PathElement::new(
            vec![(0.0, exact_y), (t_max, exact_y)],
            RGBColor(200, 200, 200).stroke_width(1),
        )))?;
        chart.draw_series(std::iter::once(Text::new(
            "exact (full resolution)",
            (t_max * 0.01, exact_y),
            ("sans-serif", 12)
                .into_font()
                .color(&RGBColor(120, 120, 120)),
        )))?;
        let grey = RGBColor(150, 160, 180);
        chart
            .draw_series(
                points
                    .iter()
                    .filter(|p| !p.grid)
                    .map(|p| Circle::new((p.time_ms, y(p)), 3, grey.filled())),
            )?
            .label("configuration, BVH")
            .legend(move |(x, y)| Circle::new((x + 10, y), 3, grey.filled()));
        if points.iter().any(|p| p.grid) {
            chart
                .draw_series(
                    points
                        .iter()
                        .filter(|p| p.grid)
                        .map(|p| Cross::new((p.time_ms, y(p)), 4, grey.stroke_width(1))),
                )?
                .label("configuration, uniform grid")
                .legend(move |(x, y)| Cross::new((x + 10, y), 4, grey.stroke_width(1)));
        }
        let mut front: Vec<&ParetoPoint> = points.iter().filter(|p| p.pareto).collect();
        front.sort_by(|a, b| a.time_ms.total_cmp(&b.time_ms));
        let red = RGBColor(200, 40, 40);
        chart
            .draw_series(LineSeries::new(
                front.iter().map(|p| (p.time_ms, y(p))),
                red.stroke_width(2),
            ))?
            .label("Pareto front")
            .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], red.stroke_width(2)));
        chart.draw_series(
            front
                .iter()
                .map(|p| Circle::new((p.time_ms, y(p)), 4, red.filled())),
        )?;
        let blue = RGBColor(30, 80, 200);
        chart
            .draw_series(
                points
                    .iter()
                    .filter(|p| p.highlight)
                    .map(|p| Circle::new((p.time_ms, y(p)), 7, blue.stroke_width(2))),
            )?
            .label("default configuration")
            .legend(move |(x, y)| Circle::new((x + 10, y), 6, blue.stroke_width(2)));
        // Labels: the default first, then the front from the fastest; a
        // label goes right or left of its point, above or below, wherever it
        // overlaps no label already placed; where none fits it is left out
        // (every point is in the report's table).
        let labelled = points
            .iter()
            .filter(|p| p.highlight)
            .chain(front.iter().copied().filter(|p| !p.highlight));
        let mut placed: Vec<(i32, i32, i32, i32)> = Vec::new();
        for p in labelled {
            let (px, py) = chart.backend_coord(&(p.time_ms, y(p)));
            let w = 7 * p.label.chars().count() as i32;
            let h = 13;
            let spot = [(6, -16), (6, 4), (-w - 6, -16), (-w - 6, 4)]
                .into_iter()
                .map(|(dx, dy)| (px + dx, py + dy, px + dx + w, py + dy + h))
                .find(|b| {
                    placed
                        .iter()
                        .all(|o| b.2 <= o.0 || b.0 >= o.2 || b.3 <= o.1 || b.1 >= o.3)
                });
            let Some(b) = spot else { continue };
            placed.push(b);
            let colour = if p.highlight { blue } else { BLACK };
            chart.draw_series(std::iter::once(
                EmptyElement::at((p.time_ms, y(p)))
                    + Text::new(
                        p.label.clone(),
                        (b.0 - px, b.1 - py),
                        ("sans-serif", 11).into_font().color(&colour),
                    ),
            ))?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::LowerRight)
            .border_style(BLACK)
            .background_style(WHITE.mix(0.9))
            .label_font(("sans-serif", 13))
            .draw()?;
        Ok(())
    })
}

/// A log–log plot of time (ms) against `x_desc`, one line per series.
pub fn draw_log_log(
    path: &Path,
    title: &str,
    x_desc: &str,
    series: &[(&str, &[(f64, f64)])],
) -> DrawResult {
    register_font();
    let all: Vec<(f64, f64)> = series
        .iter()
        .flat_map(|(_, v)| v.iter().copied())
        .filter(|(x, y)| *x > 0.0 && *y > 0.0)
        .collect();
    if all.is_empty() {
        return Err("no positive points to plot".into());
    }
    let fold = |f: fn(f64, f64) -> f64, init: f64, pick: fn(&(f64, f64)) -> f64| {
        all.iter().map(pick).fold(init, f)
    };
    let (x0, x1) = (
        fold(f64::min, f64::INFINITY, |p| p.0),
        fold(f64::max, 0.0, |p| p.0),
    );
    let (y0, y1) = (
        fold(f64::min, f64::INFINITY, |p| p.1),
        fold(f64::max, 0.0, |p| p.1),
    );
    let colours = [
        RGBColor(200, 40, 40),
        RGBColor(30, 80, 200),
        RGBColor(30, 140, 60),
        RGBColor(200, 130, 0),
        RGBColor(130, 50, 170),
        RGBColor(20, 20, 20),
    ];
    draw_png(path, (900, 600), |root| {
        let mut chart = ChartBuilder::on(root)
            .caption(title, ("sans-serif", 16))
            .margin(14)
            .x_label_area_size(44)
            .y_label_area_size(64)
            .build_cartesian_2d(
                (x0 / 1.5..x1 * 1.5).log_scale(),
                (y0 / 1.5..y1 * 1.5).log_scale(),
            )?;
        chart
            .configure_mesh()
            .x_desc(x_desc)
            .y_desc("frame time (ms)")
            .x_labels(6)
            .y_labels(10)
            .x_label_formatter(&|v| format!("{v:.1e}"))
            .y_label_formatter(&|v| {
                if *v >= 10.0 {
                    format!("{v:.0}")
                } else {
                    format!("{v:.2}")
                }
            })
            .label_style(("sans-serif", 13))
            .draw()?;
        for (k, (name, pts)) in series.iter().enumerate() {
            let c = colours[k % colours.len()];
            chart
                .draw_series(LineSeries::new(pts.iter().copied(), c.stroke_width(2)))?
                .label(*name)
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2))
                });
            chart.draw_series(pts.iter().map(|&p| Circle::new(p, 4, c.filled())))?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .border_style(BLACK)
            .background_style(WHITE.mix(0.9))
            .label_font(("sans-serif", 13))
            .draw()?;
        Ok(())
    })
}

/// One measured threshold on the thresholds plot.
#[derive(Debug, Clone, Copy)]
pub struct ThresholdPoint {
    /// Spatial frequency, cycles/degree.
    pub frequency_cpd: f64,
    /// Eccentricity, degrees.
    pub eccentricity_deg: f64,
    /// Threshold, log10 contrast.
    pub log10_threshold: f64,
    /// Its spread (sd), log10; the bar is ±1.96 sd.
    pub sd_log10: f64,
    /// Censored (beyond the display's highest contrast): drawn hollow at
    /// its estimate (at the top edge when above contrast 1.5), not in the
    /// fit.
    pub censored: bool,
}

/// Measured thresholds (with ±1.96 sd bars) against frequency, one colour
/// per eccentricity, and the fitted Geisler–Perry curve at each
/// eccentricity; log–log. `synthetic` puts SYNTHETIC in the title.
pub fn draw_thresholds(
    path: &Path,
    participant: &str,
    synthetic: bool,
    fit: &foveation::GeislerPerry,
    fit_note: &str,
    points: &[ThresholdPoint],
) -> DrawResult {
    register_font();
    let mut ecc: Vec<f64> = points.iter().map(|p| p.eccentricity_deg).collect();
    ecc.sort_by(f64::total_cmp);
    ecc.dedup();
    let f_lo = points
        .iter()
        .map(|p| p.frequency_cpd)
        .fold(f64::INFINITY, f64::min)
        .max(0.1);
    let f_hi = points
        .iter()
        .map(|p| p.frequency_cpd)
        .fold(0.0, f64::max)
        .max(f_lo * 2.0);
    let (x0, x1) = (f_lo / 1.4, f_hi * 1.4);
    let bar = |p: &ThresholdPoint, k: f64| 10f64.powf(p.log10_threshold + k * 1.96 * p.sd_log10);
    let y0 = points
        .iter()
        .map(|p| bar(p, -1.0))
        .chain([fit.ct0])
        .fold(1.0, f64::min)
        / 1.5;
    let y1 = points
        .iter()
        .map(|p| bar(p, 1.0))
        .fold(1.0, f64::max)
        .min(1.0)
        * 1.5;
    let colours = [
        RGBColor(200, 40, 40),
        RGBColor(30, 80, 200),
        RGBColor(30, 140, 60),
        RGBColor(200, 130, 0),
        RGBColor(130, 50, 170),
        RGBColor(20, 20, 20),
    ];
    let title = format!(
        "{}thresholds of {participant}: measured (±1.96 sd) and fitted Geisler–Perry CSF",
        if synthetic {
            "SYNTHETIC (simulated observer) — "
        } else {
            ""
        }
    );
    draw_png(path, (1000, 640), |root| {
        let (top, rest) = root.split_vertically(44);
        for (k, line) in fit_note.lines().enumerate() {
            top.draw(&Text::new(
                line.to_string(),
                (14, 4 + 19 * k as i32),
                ("sans-serif", 14).into_font().color(&BLACK),
            ))?;
        }
        let mut chart = ChartBuilder::on(&rest)
            .caption(title, ("sans-serif", 16))
            .margin(14)
            .x_label_area_size(44)
            .y_label_area_size(64)
            .build_cartesian_2d((x0..x1).log_scale(), (y0..y1).log_scale())?;
        chart
            .configure_mesh()
            .x_desc("spatial frequency (cycles/degree)")
            .y_desc("threshold contrast (Michelson)")
            .x_label_formatter(&|v| format!("{v:.1}"))
            .y_label_formatter(&|v| format!("{v:.3}"))
            .label_style(("sans-serif", 13))
            .draw()?;
        for (k, &e) in ecc.iter().enumerate() {
            let c = colours[k % colours.len()];
            let n = 200;
            chart
                .draw_series(LineSeries::new(
                    (0..=n).map(|i| {
                        let f = x0 * (x1 / x0).powf(f64::from(i) / f64::from(n));
                        (f, fit.contrast_threshold(f, e).min(y1))
                    }),
                    c.stroke_width(2),
                ))?
                .label(format!("{e}°: fit (line), measured (dots)"))
                .legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 20, y)], c.stroke_width(2))
                });
            let pts: Vec<&ThresholdPoint> =
                points.iter().filter(|p| p.eccentricity_deg == e).collect();
            chart.draw_series(pts.iter().map(|p| {
                PathElement::new(
                    vec![
                        (p.frequency_cpd, bar(p, -1.0).max(y0)),
                        (p.frequency_cpd, bar(p, 1.0).min(y1)),
                    ],
                    c.stroke_width(1),
                )
            }))?;
            chart.draw_series(pts.iter().map(|p| {
                let at = (p.frequency_cpd, 10f64.powf(p.log10_threshold).min(y1));
                if p.censored {
                    Circle::new(at, 5, c.stroke_width(2))
                } else {
                    Circle::new(at, 4, c.filled())
                }
            }))?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperLeft)
            .border_style(BLACK)
            .background_style(WHITE.mix(0.9))
            .label_font(("sans-serif", 13))
            .draw()?;
        Ok(())
    })
}
