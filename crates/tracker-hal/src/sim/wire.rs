//! The simulated truth encoded in each driver's wire format, with the
//! samples a correct decoder must produce from it.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::{SimStream, TruthSample};
use crate::iscan::{encode_ascii, encode_binary, IscanConfig, IscanMode, IscanParam};
use crate::mouse::{CursorEvent, MouseConfig, MouseEmulator, RECORD_LEN};
use crate::recording::{Chunk, ChunkKind};
use crate::sample::{EyeSample, GazeSample};

/// Encodes the truth as an ISCAN would send it over a serial line, each
/// record split into 1–3 reads that arrive after their wire time plus up to
/// 0.8 ms of host latency.
pub fn simulate_iscan(config: &IscanConfig, truth: &[TruthSample], seed: u64) -> SimStream {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut chunks = Vec::new();
    let mut expected = Vec::new();
    let mut last_arrival = 0u64;
    let (fw, fh) = config.frame;
    for (k, s) in truth.iter().enumerate() {
        let values: Vec<Option<f64>> = config
            .parameters
            .iter()
            .map(|p| match p {
                IscanParam::LeftPorH => s.left.map(|p| p[0]),
                IscanParam::LeftPorV => s.left.map(|p| p[1]),
                IscanParam::RightPorH => s.right.map(|p| p[0]),
                IscanParam::RightPorV => s.right.map(|p| p[1]),
                IscanParam::LeftPupil => s.left.map(|_| 30.0),
                IscanParam::RightPupil => s.right.map(|_| 31.0),
                IscanParam::Other => Some(0.0),
            })
            .collect();
        let (record, quantised): (Vec<u8>, Vec<Option<f64>>) = match config.mode {
            IscanMode::Binary => (
                encode_binary(&values),
                values
                    .iter()
                    .map(|v| v.map(|v| ((v * 10.0).round() as u16) as f64 / 10.0))
                    .collect(),
            ),
            IscanMode::Ascii => (
                encode_ascii(&values),
                values
                    .iter()
                    .map(|v| v.and_then(|v| format!("{v:.1}").parse::<f64>().ok()))
                    .collect(),
            ),
        };
        // Split points and arrival times.
        let pieces = rng.random_range(1..=3usize).min(record.len());
        let mut cuts: Vec<usize> = (1..pieces)
            .map(|_| rng.random_range(1..record.len()))
            .collect();
        cuts.push(record.len());
        cuts.sort_unstable();
        cuts.dedup();
        let mut from = 0;
        for &to in &cuts {
            let arrival =
                (s.t_us + config.wire_time_us(to) + rng.random_range(0..800u64)).max(last_arrival);
            last_arrival = arrival;
            chunks.push(Chunk {
                kind: ChunkKind::DeviceToHost,
                time_us: arrival,
                payload: record[from..to].to_vec(),
            });
            from = to;
        }
        let eye = |h: IscanParam, v: IscanParam| {
            let get = |p: IscanParam| {
                config
                    .parameters
                    .iter()
                    .position(|q| *q == p)
                    .and_then(|i| quantised[i])
            };
            match (get(h), get(v)) {
                (Some(x), Some(y)) if (0.0..fw).contains(&x) && (0.0..fh).contains(&y) => {
                    EyeSample {
                        position: Some([x, y]),
                        pupil: None,
                    }
                }
                _ => EyeSample::MISSING,
            }
        };
        let mut left = eye(IscanParam::LeftPorH, IscanParam::LeftPorV);
        let mut right = eye(IscanParam::RightPorH, IscanParam::RightPorV);
        let pupil = |p: IscanParam| {
            config
                .parameters
                .iter()
                .position(|q| *q == p)
                .and_then(|i| quantised[i])
        };
        if left.valid() {
            left.pupil = pupil(IscanParam::LeftPupil);
        }
        if right.valid() {
            right.pupil = pupil(IscanParam::RightPupil);
        }
        expected.push(GazeSample {
            seq: k as u64,
            // The driver's record-counting clock (`iscan`): the true time
            // since the first record.
            device_time_us: Some(s.t_us - truth[0].t_us),
            host_time_us: last_arrival,
            mapped_time_us: last_arrival,
            time_order: crate::timing::TimeOrder::Unmapped,
            clock_segment: 0,
            left,
            right,
            combined: None,
            eye_position_um: [None, None],
        });
    }
    SimStream::one_record_per_read(chunks, expected)
}

/// Drives the mouse emulator with the truth's left eye (scaled by
/// `px_per_unit`) as the cursor, a blink while both eyes are closed, one
/// record per truth sample arriving 50–400 µs after its tick.
pub fn simulate_mouse(
    config: &MouseConfig,
    truth: &[TruthSample],
    px_per_unit: f64,
    seed: u64,
) -> SimStream {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let mut emulator = MouseEmulator::new(config.clone());
    let mut cursor = [0.0, 0.0];
    let mut chunks = Vec::with_capacity(truth.len());
    let mut expected = Vec::with_capacity(truth.len());
    for (k, s) in truth.iter().enumerate() {
        if let Some(p) = s.left {
            cursor = [p[0] * px_per_unit, p[1] * px_per_unit];
        }
        let blink = s.left.is_none() && s.right.is_none();
        emulator.cursor(CursorEvent {
            t_us: s.t_us,
            position_px: cursor,
            blink,
        });
        let record: [u8; RECORD_LEN] = emulator.tick(s.t_us);
        let arrival = s.t_us + rng.random_range(50..400u64);
        chunks.push(Chunk {
            kind: ChunkKind::DeviceToHost,
            time_us: arrival,
            payload: record.to_vec(),
        });
        // What the record says, read field by field from the documented layout.
        let f = |o: usize| {
            f64::from(f32::from_le_bytes([
                record[o],
                record[o + 1],
                record[o + 2],
                record[o + 3],
            ]))
        };
        let eye = if record[10] == 1 {
            EyeSample {
                position: Some([f(11), f(15)]),
                pupil: None,
            }
        } else {
            EyeSample::MISSING
        };
        expected.push(GazeSample {
            seq: k as u64,
            device_time_us: Some(s.t_us),
            host_time_us: arrival,
            mapped_time_us: arrival,
            time_order: crate::timing::TimeOrder::Unmapped,
            clock_segment: 0,
            left: eye,
            right: eye,
            combined: None,
            eye_position_um: [None, None],
        });
    }
    SimStream::one_record_per_read(chunks, expected)
}
