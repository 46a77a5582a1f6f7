//! The analysis figures, drawn with plotters into RGB buffers and written
//! as PNG: grouped bar charts of mean search time with ±1 SE error bars
//! (Murphy 2007, Figs. 7.3 and 7.4) and scanpaths over the trial's
//! stimulus picture (Fig. 7.5).
//!
//! The text uses the embedded DejaVu Sans Mono ([`FONT`], this crate's
//! `assets/fonts`, its licence next to it), registered as plotters'
//! `sans-serif` once ([`register_font`]); the viewer's pictures use it
//! through this module. When the data are
//! synthetic every figure carries a red "SYNTHETIC DATA" band above its
//! title, so no picture of a simulated participant can pass for human data.
//!
//! Errors name no path: the caller adds it.

use crate::session::AtomicFile;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use std::io::BufReader;
use std::path::Path;

/// The embedded plot font, DejaVu Sans Mono (licence:
/// `assets/fonts/LICENSE-DejaVu.txt`).
pub const FONT: &[u8] = include_bytes!("../assets/fonts/DejaVuSansMono.ttf");

/// What drawing or writing a figure fails with.
pub type FigureError = Box<dyn std::error::Error + Send + Sync>;

/// The band every figure of synthetic data carries above its title.
pub const SYNTHETIC_BANNER: &str = "SYNTHETIC DATA - simulated participant, not human data";

/// Registers the embedded font as plotters' `sans-serif` (once).
pub fn register_font() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        // The embedded font is valid; registration can only fail on a bad font file.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

/// One bar: a mean with its standard error.
#[derive(Debug, Clone, PartialEq)]
pub struct Bar {
    /// Series name (legend; also printed under a lone bar).
    pub series: String,
    /// Mean (s).
    pub mean: f64,
    /// Standard error (s); the error bar spans `mean ± se`.
    pub se: f64,
    /// Number of trials, printed above the bar.
    pub n: usize,
    /// Fill colour (RGB).
    pub color: [u8; 3],
}

/// One category on the x axis with its bars side by side.
#[derive(Debug, Clone, PartialEq)]
pub struct BarGroup {
    /// Category label under the group.
    pub label: String,
    /// The bars (a missing cell is simply left out).
    pub bars: Vec<Bar>,
}

/// A horizontal reference across the plot (the control), drawn as a
/// line with a ±SE band.
#[derive(Debug, Clone, PartialEq)]
pub struct Reference {
    /// Legend text.
    pub label: String,
    /// Mean.
    pub mean: f64,
    /// Standard error.
    pub se: f64,
}

/// A grouped bar chart.
#[derive(Debug, Clone, PartialEq)]
pub struct BarChart {
    /// Title.
    pub title: String,
    /// A smaller second line under the title (n, what the bars show).
    pub subtitle: String,
    /// X-axis description.
    pub x_label: String,
    /// Y-axis description, with unit.
    pub y_label: String,
    /// The categories.
    pub groups: Vec<BarGroup>,
    /// Optional horizontal reference (the control).
    pub reference: Option<Reference>,
    /// Show a legend of the bar series.
    pub legend: bool,
    /// The data are synthetic: draw the banner.
    pub synthetic: bool,
}

fn rgb(c: [u8; 3]) -> RGBColor {
    RGBColor(c[0], c[1], c[2])
}

/// Colour of the "edges kept" bars.
pub const EDGES: [u8; 3] = [0x2b, 0x6c, 0xb0];
/// Colour of the "no edges" bars.
pub const NO_EDGES: [u8; 3] = [0xe0, 0x8a, 0x2c];
/// Colour of the control bar / line.
pub const CONTROL: [u8; 3] = [0x70, 0x70, 0x70];

/// Draws `chart` as a `w × h` PNG at `path` (written whole or not at all).
pub fn bar_chart(path: &Path, chart: &BarChart, (w, h): (u32, u32)) -> Result<(), FigureError> {
    let mut buf = vec![255u8; (w * h * 3) as usize];
    draw_bar_chart(&mut buf, (w, h), chart)?;
    write_png_rgb(path, (w, h), &buf)
}

fn draw_bar_chart(buf: &mut [u8], (w, h): (u32, u32), chart: &BarChart) -> Result<(), FigureError> {
    register_font();
    let root = BitMapBackend::with_buffer(buf, (w, h)).into_drawing_area();
    root.fill(&WHITE)?;
    let mut top = 10;
    if chart.synthetic {
        root.draw(&Rectangle::new(
            [(0, 0), (w as i32, 34)],
            RGBColor(0xc0, 0x10, 0x10).filled(),
        ))?;
        root.draw(&Text::new(
            SYNTHETIC_BANNER,
            (w as i32 / 2, 17),
            ("sans-serif", 20)
                .into_font()
                .color(&WHITE)
                .pos(Pos::new(HPos::Center, VPos::Center)),
        ))?;
        top = 44;
    }
    let title_style = ("sans-serif", 22)
        .into_font()
        .color(&BLACK)
        .pos(Pos::new(HPos::Center, VPos::Top));
    root.draw(&Text::new(
        chart.title.clone(),
        (w as i32 / 2, top),
        title_style,
    ))?;
    root.draw(&Text::new(
        chart.subtitle.clone(),
        (w as i32 / 2, top + 30),
        ("sans-serif", 15)
            .into_font()
            .color(&RGBColor(60, 60, 60))
            .pos(Pos::new(HPos::Center, VPos::Top)),
    ))?;
    let (_, plot_area) = root.split_vertically(top + 56);

    let n = chart.groups.len().max(1);
    let mut y_max: f64 = 0.0;
    for b in chart.groups.iter().flat_map(|g| &g.bars) {
        y_max = y_max.max(b.mean + b.se);
    }
    if let Some(r) = &chart.reference {
        y_max = y_max.max(r.mean + r.se);
    }
    let headroom = if chart.legend || chart.reference.is_some() {
        1.32
    } else {
        1.18
    };
    let y_max = if y_max.is_finite() && y_max > 0.0 {
        y_max * headroom
    } else {
        1.0
    };

    let mut ctx = ChartBuilder::on(&plot_area)
        .margin_left(20)
        .margin_right(30)
        .margin_bottom(10)
        .x_label_area_size(70)
        .y_label_area_size(80)
        .build_cartesian_2d(0f64..n as f64, 0f64..y_max)?;
    ctx.configure_mesh()
        .disable_x_mesh()
        .x_labels(0)
        .x_label_formatter(&|_| String::new())
        .y_desc(chart.y_label.clone())
        .y_label_formatter(&|v| {
            if y_max >= 5.0 {
                format!("{v:.0}")
            } else {
                format!("{v:.1}")
            }
        })
        .axis_desc_style(("sans-serif", 17))
        .label_style(("sans-serif", 15))
        .y_max_light_lines(1)
        .light_line_style(RGBColor(238, 238, 238))
        .draw()?;

    if let Some(r) = &chart.reference {
        let band = rgb(CONTROL).mix(0.18).filled();
        ctx.draw_series(std::iter::once(Rectangle::new(
            [(0.0, (r.mean - r.se).max(0.0)), (n as f64, r.mean + r.se)],
            band,
        )))?;
    }
    // Series names in first-seen order, for the legend.
    let mut series: Vec<(String, [u8; 3])> = Vec::new();
    for b in chart.groups.iter().flat_map(|g| &g.bars) {
        if !series.iter().any(|(s, _)| s == &b.series) {
            series.push((b.series.clone(), b.color));
        }
    }
    let slots = chart
        .groups
        .iter()
        .map(|g| g.bars.len())
        .max()
        .unwrap_or(1)
        .max(1);
    let slot_w = 0.8 / slots as f64;
    for (name, color) in &series {
        let mut rects = Vec::new();
        for (gi, g) in chart.groups.iter().enumerate() {
            let k = g.bars.len();
            for (bi, b) in g.bars.iter().enumerate() {
                if &b.series != name {
                    continue;
                }
                let x0 = gi as f64 + 0.5 - slot_w * k as f64 / 2.0 + bi as f64 * slot_w;
                rects.push(Rectangle::new(
                    [(x0 + 0.01, 0.0), (x0 + slot_w - 0.01, b.mean)],
                    rgb(b.color).filled(),
                ));
            }
        }
        let drawn = ctx.draw_series(rects)?;
        if chart.legend {
            let c = rgb(*color);
            drawn
                .label(name.clone())
                .legend(move |(x, y)| Rectangle::new([(x, y - 7), (x + 22, y + 7)], c.filled()));
        }
    }
    if let Some(r) = &chart.reference {
        // Over the bars, so it stays visible.
        ctx.draw_series(DashedLineSeries::new(
            vec![(0.0, r.mean), (n as f64, r.mean)],
            10,
            6,
            rgb(CONTROL).stroke_width(3),
        ))?
        .label(r.label.clone())
        .legend(|(x, y)| PathElement::new(vec![(x, y), (x + 22, y)], rgb(CONTROL).stroke_width(3)));
    }

    // Error bars and values.
    for (gi, g) in chart.groups.iter().enumerate() {
        let k = g.bars.len();
        for (bi, b) in g.bars.iter().enumerate() {
            let xc = gi as f64 + 0.5 - slot_w * k as f64 / 2.0 + (bi as f64 + 0.5) * slot_w;
            // ±1 SE error bar: a vertical line with caps (pixel space).
            let (ex, lo) = ctx.backend_coord(&(xc, (b.mean - b.se).max(0.0)));
            let (_, hi) = ctx.backend_coord(&(xc, b.mean + b.se));
            let bar_style = BLACK.stroke_width(2);
            root.draw(&PathElement::new(vec![(ex, lo), (ex, hi)], bar_style))?;
            for y in [lo, hi] {
                root.draw(&PathElement::new(vec![(ex - 8, y), (ex + 8, y)], bar_style))?;
            }
            let (px, py) = ctx.backend_coord(&(xc, b.mean + b.se));
            let value = format!("{:.2}", b.mean);
            let half = value.chars().count() as i32 * 9 / 2 + 3;
            root.draw(&Rectangle::new(
                [(px - half, py - 24), (px + half, py - 5)],
                WHITE.mix(0.85).filled(),
            ))?;
            root.draw(&Text::new(
                value,
                (px, py - 6),
                ("sans-serif", 14)
                    .into_font()
                    .color(&BLACK)
                    .pos(Pos::new(HPos::Center, VPos::Bottom)),
            ))?;
            let (px0, py0) = ctx.backend_coord(&(xc, 0.0));
            root.draw(&Text::new(
                format!("n={}", b.n),
                (px0, py0 - 4),
                ("sans-serif", 12)
                    .into_font()
                    .color(&WHITE)
                    .pos(Pos::new(HPos::Center, VPos::Bottom)),
            ))?;
        }
        let (px, py) = ctx.backend_coord(&(gi as f64 + 0.5, 0.0));
        root.draw(&Text::new(
            g.label.clone(),
            (px, py + 8),
            ("sans-serif", 17)
                .into_font()
                .color(&BLACK)
                .pos(Pos::new(HPos::Center, VPos::Top)),
        ))?;
    }
    // X-axis description under the category labels.
    let (cx, cy) = ctx.backend_coord(&(n as f64 / 2.0, 0.0));
    root.draw(&Text::new(
        chart.x_label.clone(),
        (cx, cy + 38),
        ("sans-serif", 17)
            .into_font()
            .color(&BLACK)
            .pos(Pos::new(HPos::Center, VPos::Top)),
    ))?;
    if chart.legend || chart.reference.is_some() {
        // The legend goes over the lower of the two end groups.
        let top = |g: Option<&BarGroup>| {
            g.map_or(0.0, |g| {
                g.bars.iter().map(|b| b.mean + b.se).fold(0.0, f64::max)
            })
        };
        let legend_side = if top(chart.groups.first()) < top(chart.groups.last()) {
            SeriesLabelPosition::UpperLeft
        } else {
            SeriesLabelPosition::UpperRight
        };
        ctx.configure_series_labels()
            .position(legend_side)
            .background_style(WHITE.mix(0.9))
            .border_style(RGBColor(160, 160, 160))
            .label_font(("sans-serif", 15))
            .draw()?;
    }
    root.present()?;
    Ok(())
}

/// One fixation of a scanpath, in display pixels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fixation {
    /// Centroid x (display px, origin top-left).
    pub x: f64,
    /// Centroid y (display px, y down).
    pub y: f64,
    /// Duration within the search (ms).
    pub duration_ms: f64,
}

/// A scanpath picture (Murphy 2007, Fig. 7.5).
#[derive(Debug, Clone, PartialEq)]
pub struct Scanpath {
    /// The fixations in order.
    pub fixations: Vec<Fixation>,
    /// Display size the fixation coordinates refer to; they are scaled
    /// to the stimulus picture if its size differs.
    pub display_px: (u32, u32),
    /// Caption lines (participant, trial, condition, RT).
    pub caption: Vec<String>,
    /// The data are synthetic: draw the banner.
    pub synthetic: bool,
}

/// Radius (px at a 1280-px-wide picture) of a fixation's circle: grows
/// with the square root of the duration, so the area grows with it.
pub fn fixation_radius(duration_ms: f64) -> f64 {
    (6.0 + 1.2 * duration_ms.max(0.0).sqrt()).min(70.0)
}

/// Draws `sp` over the stimulus picture `stimulus` (RGB or RGBA PNG) and
/// writes the result to `path`.
pub fn scanpath(path: &Path, stimulus: &Path, sp: &Scanpath) -> Result<(), FigureError> {
    let (w, h, mut buf) = read_png_rgb(stimulus)?;
    draw_scanpath(&mut buf, (w, h), sp)?;
    write_png_rgb(path, (w, h), &buf)
}

fn draw_scanpath(buf: &mut [u8], (w, h): (u32, u32), sp: &Scanpath) -> Result<(), FigureError> {
    register_font();
    let root = BitMapBackend::with_buffer(buf, (w, h)).into_drawing_area();
    let sx = if sp.display_px.0 > 0 {
        w as f64 / sp.display_px.0 as f64
    } else {
        1.0
    };
    let sy = if sp.display_px.1 > 0 {
        h as f64 / sp.display_px.1 as f64
    } else {
        1.0
    };
    let scale = w as f64 / 1280.0;
    let font_px = (20.0 * scale.max(0.5)).round() as i32;
    let pts: Vec<(i32, i32)> = sp
        .fixations
        .iter()
        .map(|f| ((f.x * sx).round() as i32, (f.y * sy).round() as i32))
        .collect();
    // Saccade lines first, under the circles: one segment at a time (a
    // thick polyline's miter joins spike far out at sharp turns).
    for (style, width) in [
        (RGBColor(20, 20, 20), (5.0 * scale).max(2.0)),
        (RGBColor(255, 230, 0), (3.0 * scale).max(1.0)),
    ] {
        for seg in pts.windows(2) {
            root.draw(&PathElement::new(
                seg.to_vec(),
                style.stroke_width(width as u32),
            ))?;
        }
    }
    let last = pts.len().saturating_sub(1);
    for (i, (f, &p)) in sp.fixations.iter().zip(&pts).enumerate() {
        let r = (fixation_radius(f.duration_ms) * scale).max(4.0) as i32;
        let color = if i == 0 {
            RGBColor(0, 190, 60)
        } else if i == last {
            RGBColor(230, 30, 30)
        } else {
            RGBColor(255, 200, 0)
        };
        root.draw(&Circle::new(p, r, color.mix(0.45).filled()))?;
        root.draw(&Circle::new(p, r, color.stroke_width(3)))?;
        root.draw(&Circle::new(p, r + 2, BLACK.stroke_width(1)))?;
    }
    // The order numbers, over every circle; a refixation of the same spot
    // gets its number beside the earlier one instead of on top of it.
    let mut placed: Vec<(i32, i32)> = Vec::new();
    for (i, &p) in pts.iter().enumerate() {
        let label = format!("{}", i + 1);
        let mut at = p;
        while placed
            .iter()
            .any(|q| (q.0 - at.0).abs() < font_px && (q.1 - at.1).abs() < font_px)
        {
            at.0 += font_px;
        }
        placed.push(at);
        // Dark outline for the number so it reads on any background.
        for (dx, dy) in [(-1, 0), (1, 0), (0, -1), (0, 1), (-1, -1), (1, 1)] {
            root.draw(&Text::new(
                label.clone(),
                (at.0 + dx, at.1 + dy),
                ("sans-serif", font_px)
                    .into_font()
                    .color(&BLACK)
                    .pos(Pos::new(HPos::Center, VPos::Center)),
            ))?;
        }
        root.draw(&Text::new(
            label,
            at,
            ("sans-serif", font_px)
                .into_font()
                .color(&WHITE)
                .pos(Pos::new(HPos::Center, VPos::Center)),
        ))?;
    }
    if let (Some(&s), Some(&e)) = (pts.first(), pts.last()) {
        let tag = |text: &str, p: (i32, i32), c: RGBColor| -> Result<(), FigureError> {
            let style = ("sans-serif", font_px)
                .into_font()
                .color(&c)
                .pos(Pos::new(HPos::Left, VPos::Bottom));
            let at = (
                p.0 + (12.0 * scale) as i32 + 8,
                p.1 - (12.0 * scale) as i32 - 8,
            );
            let width = font_px * text.chars().count() as i32 * 6 / 10 + 8;
            root.draw(&Rectangle::new(
                [(at.0 - 4, at.1 - font_px - 4), (at.0 + width, at.1 + 2)],
                RGBColor(10, 10, 12).mix(0.75).filled(),
            ))?;
            root.draw(&Text::new(text.to_string(), at, style))?;
            Ok(())
        };
        tag("start", s, RGBColor(90, 255, 120))?;
        if pts.len() > 1 {
            tag("end", e, RGBColor(255, 110, 110))?;
        }
    }
    // Caption band at the bottom; synthetic banner at the top.
    let line_h = font_px + 8;
    let band_h = line_h * sp.caption.len() as i32 + 8;
    root.draw(&Rectangle::new(
        [(0, h as i32 - band_h), (w as i32, h as i32)],
        RGBColor(10, 10, 12).mix(0.8).filled(),
    ))?;
    for (k, line) in sp.caption.iter().enumerate() {
        root.draw(&Text::new(
            line.clone(),
            (8, h as i32 - band_h + 6 + k as i32 * line_h),
            ("sans-serif", font_px).into_font().color(&WHITE),
        ))?;
    }
    if sp.synthetic {
        let bh = font_px + 14;
        root.draw(&Rectangle::new(
            [(0, 0), (w as i32, bh)],
            RGBColor(0xc0, 0x10, 0x10).filled(),
        ))?;
        root.draw(&Text::new(
            SYNTHETIC_BANNER,
            (w as i32 / 2, bh / 2),
            ("sans-serif", font_px)
                .into_font()
                .color(&WHITE)
                .pos(Pos::new(HPos::Center, VPos::Center)),
        ))?;
    }
    root.present()?;
    Ok(())
}

/// Reads a PNG as 8-bit RGB (palette, grey, 16-bit and alpha converted;
/// alpha is composited over black).
pub fn read_png_rgb(path: &Path) -> Result<(u32, u32, Vec<u8>), FigureError> {
    let (file, _) = input_file::open(path, input_file::PICTURE)?;
    let mut decoder = png::Decoder::new(BufReader::new(file));
    decoder.set_transformations(png::Transformations::normalize_to_color8());
    let mut reader = decoder.read_info()?;
    let mut raw = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut raw)?;
    raw.truncate(info.buffer_size());
    let (w, h) = (info.width, info.height);
    let px = (w * h) as usize;
    let rgb = match info.color_type {
        png::ColorType::Rgb => raw,
        png::ColorType::Rgba => raw
            .chunks_exact(4)
            .flat_map(|p| {
                let a = u16::from(p[3]);
                [0, 1, 2].map(|c| ((u16::from(p[c]) * a + 127) / 255) as u8)
            })
            .collect(),
        png::ColorType::Grayscale => raw.iter().flat_map(|&g| [g, g, g]).collect(),
        png::ColorType::GrayscaleAlpha => raw
            .chunks_exact(2)
            .flat_map(|p| {
                let g = ((u16::from(p[0]) * u16::from(p[1]) + 127) / 255) as u8;
                [g, g, g]
            })
            .collect(),
        png::ColorType::Indexed => return Err("indexed PNG was not expanded".into()),
    };
    if rgb.len() != px * 3 {
        return Err(format!("decoded {} bytes for {w}x{h} RGB", rgb.len()).into());
    }
    Ok((w, h, rgb))
}

/// Writes an RGB buffer as PNG, whole or not at all.
pub fn write_png_rgb(path: &Path, (w, h): (u32, u32), rgb: &[u8]) -> Result<(), FigureError> {
    let mut file = AtomicFile::create(path)?;
    {
        let mut enc = png::Encoder::new(&mut file, w, h);
        enc.set_color(png::ColorType::Rgb);
        enc.set_depth(png::BitDepth::Eight);
        enc.set_compression(png::Compression::Fast);
        let mut writer = enc.write_header()?;
        writer.write_image_data(rgb)?;
        writer.finish()?;
    }
    file.commit()?;
    Ok(())
}
