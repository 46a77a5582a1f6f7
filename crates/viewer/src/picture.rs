//! Pictures as 8-bit RGB buffers: writing them (PNG, animated PNG),
//! halving them, and drawing text (HUD, status lines) and the POR box on
//! them. Errors name no path: the caller adds it.

use std::path::Path;

use plotters::prelude::*;

use crate::output::AtomicFile;

/// The POR box (the pipeline's own drawing, shared, not copied).
pub use pipeline::effects::por_overlay::draw_box;

/// What the writers and drawers fail with.
pub type PictureResult = Result<(), Box<dyn std::error::Error>>;

/// Registers the embedded font as plotters' `sans-serif` (once): the
/// experiment crate's figure font, one registration for both crates.
pub use experiment::figures::register_font;

/// Writes an RGB buffer as PNG: indexed colour when it has at most 256
/// distinct colours (mesh pictures do, and shrink several-fold), else RGB.
pub fn save_png(path: &Path, (w, h): (u32, u32), rgb: &[u8]) -> PictureResult {
    let mut palette: Vec<[u8; 3]> = Vec::new();
    let mut lookup = std::collections::HashMap::new();
    let mut indices = Vec::with_capacity(rgb.len() / 3);
    for px in rgb.chunks_exact(3) {
        let c = [px[0], px[1], px[2]];
        let next = palette.len();
        let i = *lookup.entry(c).or_insert(next);
        if i == next {
            if next == 256 {
                break;
            }
            palette.push(c);
        }
        indices.push(i as u8);
    }
    // Written whole or not at all (crate::output).
    let mut file = AtomicFile::create(path)?;
    let mut enc = png::Encoder::new(&mut file, w, h);
    enc.set_depth(png::BitDepth::Eight);
    enc.set_compression(png::Compression::Best);
    let writer = if indices.len() == rgb.len() / 3 {
        enc.set_color(png::ColorType::Indexed);
        enc.set_palette(palette.concat());
        let mut writer = enc.write_header()?;
        writer.write_image_data(&indices)?;
        writer
    } else {
        enc.set_color(png::ColorType::Rgb);
        let mut writer = enc.write_header()?;
        writer.write_image_data(rgb)?;
        writer
    };
    writer.finish()?;
    file.commit()?;
    Ok(())
}

/// Writes RGB frames of `w × h` as an animated PNG (APNG) at `fps`,
/// looping forever.
pub fn save_apng(path: &Path, (w, h): (u32, u32), fps: u16, frames: &[Vec<u8>]) -> PictureResult {
    let mut file = AtomicFile::create(path)?;
    let mut enc = png::Encoder::new(&mut file, w, h);
    enc.set_color(png::ColorType::Rgb);
    enc.set_depth(png::BitDepth::Eight);
    enc.set_compression(png::Compression::Fast);
    enc.set_animated(u32::try_from(frames.len())?, 0)?;
    enc.set_frame_delay(1, fps)?;
    let mut writer = enc.write_header()?;
    for f in frames {
        writer.write_image_data(f)?;
    }
    writer.finish()?;
    file.commit()?;
    Ok(())
}

/// Half the size in each direction: each output pixel is the rounded mean
/// of a 2 × 2 block of the `w × h` RGB input (an odd last row or column is
/// dropped).
pub fn half_size(rgb: &[u8], w: usize, h: usize) -> Vec<u8> {
    let (hw, hh) = (w / 2, h / 2);
    let mut out = vec![0u8; hw * hh * 3];
    for y in 0..hh {
        for x in 0..hw {
            for c in 0..3 {
                let at =
                    |dx: usize, dy: usize| u32::from(rgb[3 * ((2 * y + dy) * w + 2 * x + dx) + c]);
                out[3 * (y * hw + x) + c] =
                    ((at(0, 0) + at(1, 0) + at(0, 1) + at(1, 1) + 2) / 4) as u8;
            }
        }
    }
    out
}

/// Draws text lines (HUD, status) in the top-left corner of an RGB frame,
/// white on a dark band.
pub fn draw_text_lines(rgb: &mut [u8], (w, h): (u32, u32), lines: &[&str]) -> PictureResult {
    register_font();
    let root = BitMapBackend::with_buffer(rgb, (w, h)).into_drawing_area();
    for (k, line) in lines.iter().enumerate() {
        let (y, width) = line_box(k, line);
        root.draw(&Rectangle::new(
            [(0, y - 2), (width, y + 16)],
            TEXT_BOX.mix(0.75).filled(),
        ))?;
        root.draw(&line_text(line, y))?;
    }
    root.present()?;
    Ok(())
}

/// The dark of the boxes behind text lines.
const TEXT_BOX: RGBColor = RGBColor(10, 10, 12);

/// Line `k`'s text baseline row and its box's right edge (its box spans
/// rows `y - 2 ..= y + 16` and columns `0 ..= width`).
fn line_box(k: usize, line: &str) -> (i32, i32) {
    (4 + 18 * k as i32, 8 * line.chars().count() as i32 + 8)
}

fn line_text(line: &str, y: i32) -> Text<'_, (i32, i32), String> {
    Text::new(
        line.to_string(),
        (4, y),
        ("sans-serif", 14).into_font().color(&WHITE),
    )
}

/// An overlay's RGBA words (row-major) and its width and height.
pub type Overlay = (Vec<u32>, (u32, u32));

/// The text lines of [`draw_text_lines`] as an overlay for a frame drawn
/// elsewhere (on the GPU): RGBA words (red in the low byte) of the
/// top-left strip that holds the lines' boxes, at most `max_width` wide;
/// alpha 255 inside a box, 0 outside. The boxes are opaque (the blend
/// with the frame that [`draw_text_lines`] does would need the frame).
pub fn text_overlay(lines: &[&str], max_width: u32) -> Result<Overlay, Box<dyn std::error::Error>> {
    register_font();
    let boxes: Vec<(i32, i32)> = lines
        .iter()
        .enumerate()
        .map(|(k, l)| line_box(k, l))
        .collect();
    let widest = boxes.iter().map(|b| b.1 + 1).max().unwrap_or(0).max(1);
    let w = (widest as u32).min(max_width.max(1));
    let h = (boxes.last().map_or(0, |b| b.0 + 17)).max(1) as u32;
    let mut rgb = [TEXT_BOX.0, TEXT_BOX.1, TEXT_BOX.2].repeat(w as usize * h as usize);
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area();
        for (line, &(y, _)) in lines.iter().zip(&boxes) {
            root.draw(&line_text(line, y))?;
        }
        root.present()?;
    }
    let inside = |x: i32, y: i32| {
        boxes
            .iter()
            .any(|&(by, bw)| x <= bw && (by - 2..=by + 16).contains(&y))
    };
    let words = rgb
        .chunks_exact(3)
        .enumerate()
        .map(|(i, p)| {
            let (x, y) = ((i % w as usize) as i32, (i / w as usize) as i32);
            if inside(x, y) {
                0xff00_0000 | u32::from(p[2]) << 16 | u32::from(p[1]) << 8 | u32::from(p[0])
            } else {
                0
            }
        })
        .collect();
    Ok((words, (w, h)))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn decode(path: &Path) -> (png::OutputInfo, Vec<u8>) {
        let file = std::fs::File::open(path).expect("written");
        let mut reader = png::Decoder::new(std::io::BufReader::new(file))
            .read_info()
            .expect("a PNG");
        let mut buf = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut buf).expect("a frame");
        buf.truncate(info.buffer_size());
        (info, buf)
    }

    /// The overlay holds the lines' boxes where `draw_text_lines` draws
    /// them (opaque, text included) and nothing elsewhere; it is clipped to
    /// the frame's width.
    #[test]
    fn the_text_overlay_is_opaque_in_the_boxes_and_clear_outside() {
        let lines = ["abc", "a longer line"];
        let (words, (w, h)) = text_overlay(&lines, 1000).expect("draws");
        assert_eq!((w, h), (8 * 13 + 8 + 1, 4 + 18 + 17));
        assert_eq!(words.len(), (w * h) as usize);
        let at = |x: u32, y: u32| words[(y * w + x) as usize];
        let alpha = |x, y| at(x, y) >> 24;
        assert_eq!(alpha(0, 0), 0, "above the first box");
        assert_eq!(alpha(0, 2), 255, "the first box's top row");
        assert_eq!(alpha(8 * 3 + 8, 10), 255, "the first box's right edge");
        assert_eq!(alpha(8 * 3 + 9, 10), 0, "right of the first box");
        assert_eq!(alpha(8 * 3 + 9, 30), 255, "the second, longer box");
        // The box's dark and the text's white are both there.
        let colours: std::collections::HashSet<u32> = words.iter().copied().collect();
        assert!(
            colours.contains(&0xff0c_0a0a),
            "the box colour (10, 10, 12)"
        );
        assert!(colours.iter().any(|c| c & 0xff > 200), "white text");
        let (clipped, (cw, ch)) = text_overlay(&lines, 20).expect("draws");
        assert_eq!((cw, ch), (20, h));
        assert_eq!(clipped.len(), (20 * h) as usize);
        let (none, size) = text_overlay(&[], 100).expect("nothing");
        assert_eq!((none, size), (vec![0], (1, 1)));
    }

    #[test]
    fn halving_averages_two_by_two_blocks() {
        // 3 × 2: one 2 × 2 block (the odd column is dropped).
        let rgb = [
            0, 10, 255, 1, 20, 255, 99, 99, 99, //
            2, 30, 255, 4, 41, 254, 99, 99, 99,
        ];
        assert_eq!(half_size(&rgb, 3, 2), [2, 25, 255]);
        assert!(half_size(&rgb, 1, 1).is_empty());
    }

    #[test]
    fn few_colours_save_as_a_palette_and_many_as_rgb() {
        let dir = tempfile::tempdir().expect("tempdir");
        let few = dir.path().join("few.png");
        let rgb = [255, 0, 0, 0, 0, 255].repeat(8);
        save_png(&few, (4, 4), &rgb).expect("saves");
        let (info, buf) = decode(&few);
        assert_eq!(info.color_type, png::ColorType::Indexed);
        assert_eq!(buf.len(), 16);

        let many = dir.path().join("many.png");
        let rgb: Vec<u8> = (0..300u32)
            .flat_map(|i| [i as u8, (i >> 8) as u8, 7])
            .collect();
        save_png(&many, (30, 10), &rgb).expect("saves");
        let (info, buf) = decode(&many);
        assert_eq!(info.color_type, png::ColorType::Rgb);
        assert_eq!(buf, rgb);
        assert!(save_png(&dir.path().join("no/such/dir.png"), (30, 10), &rgb).is_err());
    }

    #[test]
    fn an_animation_has_one_frame_control_per_frame() {
        let dir = tempfile::tempdir().expect("tempdir");
        let path = dir.path().join("anim.png");
        let frames: Vec<Vec<u8>> = (0..3u8).map(|k| vec![k * 50; 2 * 2 * 3]).collect();
        save_apng(&path, (2, 2), 10, &frames).expect("saves");
        let bytes = std::fs::read(&path).expect("read");
        assert!(bytes.windows(4).any(|w| w == b"acTL"));
        assert_eq!(bytes.windows(4).filter(|w| *w == b"fcTL").count(), 3);
    }

    #[test]
    fn text_lines_darken_their_band_only() {
        let (w, h) = (200u32, 60u32);
        let mut rgb = vec![200u8; 3 * (w * h) as usize];
        draw_text_lines(&mut rgb, (w, h), &["HUD"]).expect("draws");
        let px = |x: u32, y: u32| rgb[3 * (y * w + x) as usize];
        assert!(px(1, 3) < 200, "the band is dark");
        assert_eq!(px(150, 50), 200, "outside the band untouched");
    }
}
