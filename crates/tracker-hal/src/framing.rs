//! Byte-stream bookkeeping shared by the decoders: the pending bytes, the
//! statistics, and the rule that one run of skipped bytes is one resync.

use crate::sample::DecodeStats;

#[derive(Debug, Clone)]
pub(crate) struct Framing {
    /// Bytes received and not yet consumed.
    pub buf: Vec<u8>,
    pub stats: DecodeStats,
    /// False after bytes were dropped, until the next good record.
    synced: bool,
    /// Records the dropped bytes held, for decoders that count lost
    /// records: each run of dropped bytes is a piece of at least one
    /// record and counts ⌈run ÷ `record_len`⌉ records — or, for line
    /// records (`line_records`, where a run is one whole bad line of
    /// varying length), max(1, round(run ÷ `record_len`)).
    pub lost_records: u64,
    /// The typical record length the decoder expects (bytes; ≥ 1).
    pub record_len: usize,
    pub line_records: bool,
}

impl Framing {
    pub fn new() -> Self {
        Self {
            buf: Vec::with_capacity(256),
            stats: DecodeStats::default(),
            synced: true,
            lost_records: 0,
            record_len: 1,
            line_records: false,
        }
    }

    /// Takes in bytes from the transport.
    pub fn accept(&mut self, bytes: &[u8]) {
        self.stats.bytes += bytes.len() as u64;
        self.buf.extend_from_slice(bytes);
    }

    /// Counts `n` skipped bytes (one resync per run of garbage).
    pub fn drop_bytes(&mut self, n: usize) {
        self.stats.dropped_bytes += n as u64;
        if n > 0 {
            let len = self.record_len.max(1);
            self.lost_records += if self.line_records {
                ((n as f64 / len as f64).round() as u64).max(1)
            } else {
                n.div_ceil(len) as u64
            };
        }
        if self.synced && n > 0 {
            self.stats.resyncs += 1;
            self.synced = false;
        }
    }

    /// Counts one decoded record and returns its sequence number.
    pub fn record(&mut self) -> u64 {
        let seq = self.stats.records;
        self.stats.records += 1;
        self.synced = true;
        seq
    }

    /// Advances `*start` to the next `header` (dropping and counting what
    /// precedes it) and reports whether a whole `len`-byte record candidate
    /// starts there; `false` means more bytes are needed.
    pub fn seek_record(&mut self, start: &mut usize, header: [u8; 2], len: usize) -> bool {
        loop {
            let avail = &self.buf[*start..];
            if avail.len() < 2 {
                return false;
            }
            if avail[..2] != header {
                let skip = bytes_before_header(avail, header);
                self.drop_bytes(skip);
                *start += skip;
                continue;
            }
            return avail.len() >= len;
        }
    }

    /// The stream ended: whatever is pending is dropped.
    pub fn finish(&mut self) {
        let n = self.buf.len();
        self.drop_bytes(n);
        self.buf.clear();
    }
}

/// How many bytes of `avail` come before the next two-byte `header`. With no
/// header, everything but a trailing first header byte (which may start one).
fn bytes_before_header(avail: &[u8], header: [u8; 2]) -> usize {
    avail
        .windows(2)
        .position(|w| w == header)
        .unwrap_or(avail.len() - usize::from(avail.last() == Some(&header[0])))
}
