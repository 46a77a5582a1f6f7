//! Decode throughput. Goal (issue 3): ≥ 50 MB/s for ISCAN binary on one core.

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use tracker_hal::iscan::{encode_ascii, encode_binary, IscanConfig, IscanDecoder, IscanMode};
use tracker_hal::mouse::{encode_record, MouseDecoder};
use tracker_hal::Decoder;

fn stream(mode: IscanMode, records: usize) -> Vec<u8> {
    let mut out = Vec::new();
    for k in 0..records {
        let v = (k % 500) as f64 + 0.3;
        let values = [Some(v), Some(511.0 - v), Some(v + 2.5), None];
        out.extend(match mode {
            IscanMode::Binary => encode_binary(&values),
            IscanMode::Ascii => encode_ascii(&values),
        });
    }
    out
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("decode");
    for (name, mode) in [
        ("iscan_binary", IscanMode::Binary),
        ("iscan_ascii", IscanMode::Ascii),
    ] {
        let bytes = stream(mode, 100_000);
        g.throughput(Throughput::Bytes(bytes.len() as u64));
        g.bench_function(name, |b| {
            let mut out = std::collections::VecDeque::with_capacity(100_000);
            b.iter(|| {
                let mut d = IscanDecoder::new(IscanConfig::binocular(mode));
                // 4 KiB reads, as from a transport.
                for (i, chunk) in bytes.chunks(4096).enumerate() {
                    d.push(chunk, i as u64, &mut out);
                    out.clear();
                }
                d.stats().records
            })
        });
    }
    let mouse: Vec<u8> = (0..100_000u64)
        .flat_map(|k| encode_record(k, Some([k as f32, 3.0])))
        .collect();
    g.throughput(Throughput::Bytes(mouse.len() as u64));
    g.bench_function("mouse", |b| {
        let mut out = std::collections::VecDeque::with_capacity(100_000);
        b.iter(|| {
            let mut d = MouseDecoder::new();
            for (i, chunk) in mouse.chunks(4096).enumerate() {
                d.push(chunk, i as u64, &mut out);
                out.clear();
            }
            d.stats().records
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
