//! Reading results back: copying the frame's outputs to mappable buffers,
//! mapping them, and unpacking the words into a [`Frame`].

use std::sync::mpsc;

use super::buffers::FrameBuffers;
use super::{GpuError, TrafficCounter};
use crate::frame::{Frame, Layer};

/// Copies a frame's output buffers (`pixels` pixels) into their readback
/// buffers.
pub(super) fn copy_out(
    encoder: &mut wgpu::CommandEncoder,
    out: &FrameBuffers,
    readback: &FrameBuffers,
    pixels: u32,
) {
    for ((src, per_pixel), (dst, _)) in out.each().into_iter().zip(readback.each()) {
        let bytes = per_pixel * u64::from(pixels);
        if bytes > 0 {
            encoder.copy_buffer_to_buffer(src, 0, dst, 0, bytes);
        }
    }
}

/// Maps the first `bytes` of each buffer (after the submission that fills
/// them), waiting once, and copies their words out.
fn read_all(
    device: &wgpu::Device,
    traffic: &TrafficCounter,
    buffers: &[(&wgpu::Buffer, u64)],
) -> Result<Vec<Vec<u32>>, GpuError> {
    let err = |e: &dyn std::fmt::Display| GpuError::Readback(e.to_string());
    let pending: Vec<_> = buffers
        .iter()
        .map(|&(buffer, bytes)| {
            let slice = buffer.slice(..bytes);
            let (tx, rx) = mpsc::channel();
            traffic.read(bytes);
            slice.map_async(wgpu::MapMode::Read, move |r| {
                let _ = tx.send(r);
            });
            (buffer, slice, rx)
        })
        .collect();
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| err(&e))?;
    // Every buffer is unmapped again, even after an error in another, so
    // that the next frame can copy into it.
    let mut out = Vec::with_capacity(pending.len());
    let mut first_error = None;
    for (buffer, slice, rx) in pending {
        let words = rx
            .recv()
            .map_err(|e| err(&e))
            .and_then(|r| r.map_err(|e| err(&e)))
            .and_then(|()| {
                let view = slice.get_mapped_range().map_err(|e| err(&e))?;
                Ok(bytemuck::cast_slice::<u8, u32>(&view).to_vec())
            });
        match words {
            Ok(w) => {
                buffer.unmap();
                out.push(w);
            }
            Err(e) => {
                first_error.get_or_insert(e);
            }
        }
    }
    match first_error {
        Some(e) => Err(e),
        None => Ok(out),
    }
}

/// Maps `buffer` (after the submission that fills it) and copies the words
/// of its first `bytes` out.
pub(super) fn read_back(
    device: &wgpu::Device,
    traffic: &TrafficCounter,
    buffer: &wgpu::Buffer,
    bytes: u64,
) -> Result<Vec<u32>, GpuError> {
    let mut all = read_all(device, traffic, &[(buffer, bytes)])?;
    all.pop()
        .ok_or_else(|| GpuError::Readback("nothing mapped".into()))
}

/// Reads a frame of `w` × `h` pixels from its readback buffers.
pub(super) fn read_frame(
    device: &wgpu::Device,
    traffic: &TrafficCounter,
    readback: &FrameBuffers,
    w: u32,
    h: u32,
    surface: bool,
) -> Result<Frame, GpuError> {
    let mut frame = Frame::blank(w, h, [0; 3], Layer::Full, surface);
    let n = frame.len() as u64;
    if n == 0 {
        return Ok(frame);
    }
    let buffers = readback.each().map(|(b, per_pixel)| (b, per_pixel * n));
    if !surface {
        let [(pixels, bytes), ..] = buffers;
        let words = read_back(device, traffic, pixels, bytes)?;
        unpack(&words, &mut frame);
        return Ok(frame);
    }
    let [words, depth, object, normal]: [Vec<u32>; 4] = read_all(device, traffic, &buffers)?
        .try_into()
        .map_err(|_| GpuError::Readback("a frame buffer was not mapped".into()))?;
    unpack(&words, &mut frame);
    unpack_surface(&depth, &object, &normal, &mut frame);
    Ok(frame)
}

/// Pixel words (`pack` in cast.wgsl) into a frame: RGB, hit, layer.
fn unpack(words: &[u32], frame: &mut Frame) {
    for (i, &p) in words.iter().enumerate().take(frame.len()) {
        frame.rgb[3 * i] = p as u8;
        frame.rgb[3 * i + 1] = (p >> 8) as u8;
        frame.rgb[3 * i + 2] = (p >> 16) as u8;
        frame.hit[i] = (p >> 24) & 1 == 1;
        frame.layer[i] = match (p >> 25) & 3 {
            1 => Layer::Fovea,
            2 => Layer::Interpolated,
            3 => Layer::Refined,
            _ => Layer::Full,
        };
    }
}

/// The G-buffer words (`put` in cast.wgsl) into a frame, for the pixels
/// whose hit flag is set; the others keep the background values of
/// [`Frame::blank`] (infinite depth, `NO_OBJECT`, zero normal).
fn unpack_surface(depth: &[u32], object: &[u32], normal: &[u32], frame: &mut Frame) {
    let surfaces = depth.iter().zip(object).zip(normal.chunks_exact(3));
    for (i, ((&d, &o), n)) in surfaces.enumerate().take(frame.len()) {
        if frame.hit[i] {
            frame.depth_mm[i] = f32::from_bits(d);
            frame.object[i] = o;
            frame.normal[i] = [n[0], n[1], n[2]].map(f32::from_bits);
        }
    }
}
