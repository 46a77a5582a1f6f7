//! Fuzzes every tracker decoder with arbitrary bytes split at arbitrary points.
//! Run with `cargo fuzz run decoders` (needs cargo-fuzz and a nightly toolchain,
//! or RUSTC_BOOTSTRAP=1 on stable).
#![no_main]

use libfuzzer_sys::fuzz_target;
use tracker_hal::iscan::{IscanConfig, IscanDecoder, IscanMode};
use tracker_hal::mouse::MouseDecoder;
use tracker_hal::Decoder;

fuzz_target!(|data: &[u8]| {
    let Some((&split, bytes)) = data.split_first() else { return };
    let split = usize::from(split.max(1));
    let decoders: [Box<dyn Decoder>; 3] = [
        Box::new(IscanDecoder::new(IscanConfig::binocular(IscanMode::Binary))),
        Box::new(IscanDecoder::new(IscanConfig::binocular(IscanMode::Ascii))),
        Box::new(MouseDecoder::new()),
    ];
    for mut d in decoders {
        let mut out = std::collections::VecDeque::new();
        for (i, c) in bytes.chunks(split).enumerate() {
            d.push(c, i as u64, &mut out);
        }
        d.finish();
        let st = d.stats();
        assert_eq!(st.bytes, bytes.len() as u64);
        assert_eq!(st.records, out.len() as u64);
        assert!(st.dropped_bytes <= st.bytes);
    }
});
