//! A HID report descriptor parser (Device Class Definition for HID 1.11,
//! §6.2.2): every field of every report, with its usage, the collections
//! around it, its bit position and its logical range.
//!
//! Fields are located by usage, never by offset: implementations of the same
//! usage page lay their reports out differently (padding, field order, a
//! timestamp as one 64-bit field or as eight bytes). Main items flagged
//! *Constant* are kept as data when they carry a usage — the eye-tracker
//! reference descriptor declares its gaze fields Constant — and only
//! usage-less items are padding.

use std::collections::HashMap;

/// The three kinds of report.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum ReportKind {
    /// Input report: device to host, read as data.
    Input,
    /// Output report: host to device.
    Output,
    /// Feature report: read or written on request.
    Feature,
}

/// One field of a report.
#[derive(Debug, Clone, PartialEq)]
pub struct Field {
    /// The kind of report the field is in.
    pub kind: ReportKind,
    /// 0 when the descriptor declares no report IDs.
    pub report_id: u8,
    /// Bit position in the report data (after the report ID byte).
    pub bit_offset: u32,
    /// Size of the field, bits.
    pub bit_size: u32,
    /// Usage page of the field's usage.
    pub usage_page: u16,
    /// 0 for padding (a main item without usages).
    pub usage: u16,
    /// Enclosing collections, outermost first, as (usage page, usage).
    pub collections: Vec<(u16, u16)>,
    /// Logical minimum: the smallest valid value.
    pub logical_min: i64,
    /// Logical maximum: the largest valid value.
    pub logical_max: i64,
    /// Declared Constant (kept: see the module doc).
    pub constant: bool,
    /// Variable (a value) rather than Array (an index list).
    pub variable: bool,
}

impl Field {
    /// The innermost enclosing collection with a usage on `page`.
    pub fn innermost(&self, page: u16) -> Option<u16> {
        self.collections
            .iter()
            .rev()
            .find(|(p, u)| *p == page && *u != 0)
            .map(|(_, u)| *u)
    }

    /// The field's raw value in `data` (the report without its ID byte),
    /// sign-extended when the logical range is signed. `None` when the
    /// report is too short.
    pub fn read(&self, data: &[u8]) -> Option<i64> {
        let raw = read_bits(data, self.bit_offset, self.bit_size)?;
        Some(
            if self.logical_min < 0 && self.bit_size < 64 && self.bit_size > 0 {
                let shift = 64 - self.bit_size;
                ((raw << shift) as i64) >> shift
            } else {
                raw as i64
            },
        )
    }

    /// The declared logical range, when it bounds the field: `None` when
    /// the descriptor declares none (minimum ≥ maximum, as 64-bit fields
    /// do) and for fields wider than 32 bits, whose values a Logical
    /// Minimum/Maximum (at most 32-bit items) cannot describe — such a field
    /// may carry a range left over from the 32-bit fields before it.
    pub fn declared_range(&self) -> Option<(i64, i64)> {
        (self.logical_min < self.logical_max && self.bit_size <= 32)
            .then_some((self.logical_min, self.logical_max))
    }

    /// Whether `v` is inside the declared logical range (always, when
    /// [`declared_range`](Self::declared_range) is `None`).
    pub fn in_range(&self, v: i64) -> bool {
        self.declared_range()
            .is_none_or(|(lo, hi)| (lo..=hi).contains(&v))
    }
}

/// Reads `size` (≤ 64) bits at `offset`, little-endian, LSB first.
pub fn read_bits(data: &[u8], offset: u32, size: u32) -> Option<u64> {
    if size > 64 {
        return None;
    }
    let end = u64::from(offset) + u64::from(size);
    if end > 8 * data.len() as u64 {
        return None;
    }
    let mut v = 0u64;
    for k in 0..size {
        let bit = offset + k;
        let b = (data[(bit / 8) as usize] >> (bit % 8)) & 1;
        v |= u64::from(b) << k;
    }
    Some(v)
}

/// Writes the low `size` bits of `value` at `offset` (the buffer must be
/// long enough; bits beyond it are ignored).
pub fn write_bits(data: &mut [u8], offset: u32, size: u32, value: u64) {
    for k in 0..size.min(64) {
        let bit = offset + k;
        let Some(byte) = data.get_mut((bit / 8) as usize) else {
            return;
        };
        let mask = 1u8 << (bit % 8);
        if (value >> k) & 1 == 1 {
            *byte |= mask;
        } else {
            *byte &= !mask;
        }
    }
}

/// What is wrong with a descriptor, with the byte offset of the item.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum DescriptorError {
    #[error("byte {offset}: item runs past the end of the descriptor")]
    /// An item runs past the end of the descriptor.
    Truncated {
        /// Byte offset of the item.
        offset: usize,
    },
    #[error("byte {offset}: End Collection without a Collection")]
    /// An End Collection without a Collection.
    UnbalancedCollection {
        /// Byte offset of the item.
        offset: usize,
    },
    #[error("byte {offset}: Pop without a Push")]
    /// A Pop without a Push.
    PopWithoutPush {
        /// Byte offset of the item.
        offset: usize,
    },
    #[error("byte {offset}: {what}")]
    /// The descriptor exceeds one of the parser's size limits.
    Limit {
        /// Byte offset of the item.
        offset: usize,
        /// Which limit.
        what: &'static str,
    },
    #[error("the descriptor ends inside {open} open collection(s)")]
    /// The descriptor ends inside open collections.
    Unclosed {
        /// Collections still open.
        open: usize,
    },
}

/// A parsed report descriptor.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ReportDescriptor {
    /// Every field of every report, in descriptor order.
    pub fields: Vec<Field>,
    /// Whether reports start with a report ID byte.
    pub uses_report_ids: bool,
    /// Top-level (application) collections, as (usage page, usage).
    pub applications: Vec<(u16, u16)>,
}

#[derive(Debug, Clone, Copy, Default)]
struct Globals {
    usage_page: u16,
    logical_min: i64,
    logical_max: i64,
    report_size: u32,
    report_id: u8,
    report_count: u32,
}

/// Largest report we accept (bits), and most fields: a bound on what a
/// corrupt descriptor can make us allocate.
const MAX_REPORT_BITS: u64 = 8 * 4096;
const MAX_FIELDS: usize = 1 << 16;

impl ReportDescriptor {
    /// Parses a descriptor. Long items are skipped; unknown items ignored.
    pub fn parse(bytes: &[u8]) -> Result<Self, DescriptorError> {
        let mut out = ReportDescriptor::default();
        let mut g = Globals::default();
        let mut stack: Vec<Globals> = Vec::new();
        let mut usages: Vec<(u16, u16)> = Vec::new();
        let mut usage_min: Option<(u16, u16)> = None;
        let mut usage_max: Option<(u16, u16)> = None;
        let mut collections: Vec<(u16, u16)> = Vec::new();
        let mut offsets: HashMap<(ReportKind, u8), u64> = HashMap::new();
        let mut i = 0;
        while i < bytes.len() {
            let at = i;
            let prefix = bytes[i];
            if prefix == 0xFE {
                // Long item: bDataSize, bLongItemTag, data.
                let size = *bytes
                    .get(i + 1)
                    .ok_or(DescriptorError::Truncated { offset: at })?;
                i += 3 + usize::from(size);
                if i > bytes.len() {
                    return Err(DescriptorError::Truncated { offset: at });
                }
                continue;
            }
            let size = [0, 1, 2, 4][usize::from(prefix & 3)];
            let kind = (prefix >> 2) & 3;
            let tag = prefix >> 4;
            let data = bytes
                .get(i + 1..i + 1 + size)
                .ok_or(DescriptorError::Truncated { offset: at })?;
            i += 1 + size;
            let unsigned = data
                .iter()
                .rev()
                .fold(0u32, |v, b| (v << 8) | u32::from(*b));
            let signed = match size {
                1 => i64::from(unsigned as u8 as i8),
                2 => i64::from(unsigned as u16 as i16),
                4 => i64::from(unsigned as i32),
                _ => 0,
            };
            match (kind, tag) {
                // Main items.
                (0, 8 | 9 | 0xB) => {
                    let rk = match tag {
                        8 => ReportKind::Input,
                        9 => ReportKind::Output,
                        _ => ReportKind::Feature,
                    };
                    let constant = unsigned & 1 == 1;
                    let variable = unsigned & 2 == 2;
                    let pos = offsets.entry((rk, g.report_id)).or_insert(0);
                    let bits = u64::from(g.report_size) * u64::from(g.report_count);
                    if *pos + bits > MAX_REPORT_BITS {
                        return Err(DescriptorError::Limit {
                            offset: at,
                            what: "report longer than 4096 bytes",
                        });
                    }
                    if out.fields.len() + g.report_count as usize > MAX_FIELDS {
                        return Err(DescriptorError::Limit {
                            offset: at,
                            what: "more than 65536 fields",
                        });
                    }
                    let (lmin, lmax) = (g.logical_min, g.logical_max);
                    for k in 0..g.report_count {
                        let (page, usage) = if !variable {
                            (g.usage_page, 0)
                        } else if let Some(u) =
                            usages.get(k as usize).or_else(|| usages.last()).copied()
                        {
                            u
                        } else if let (Some(lo), Some(hi)) = (usage_min, usage_max) {
                            let u = u32::from(lo.1) + k;
                            (lo.0, u.min(u32::from(hi.1)) as u16)
                        } else {
                            (g.usage_page, 0)
                        };
                        out.fields.push(Field {
                            kind: rk,
                            report_id: g.report_id,
                            bit_offset: (*pos + u64::from(k) * u64::from(g.report_size)) as u32,
                            bit_size: g.report_size,
                            usage_page: page,
                            usage,
                            collections: collections.clone(),
                            logical_min: lmin,
                            logical_max: lmax,
                            constant,
                            variable,
                        });
                    }
                    *pos += bits;
                    usages.clear();
                    (usage_min, usage_max) = (None, None);
                }
                (0, 0xA) => {
                    let u = usages.first().copied().unwrap_or((g.usage_page, 0));
                    if collections.is_empty() {
                        out.applications.push(u);
                    }
                    collections.push(u);
                    if collections.len() > 64 {
                        return Err(DescriptorError::Limit {
                            offset: at,
                            what: "collections nested deeper than 64",
                        });
                    }
                    usages.clear();
                    (usage_min, usage_max) = (None, None);
                }
                (0, 0xC) => {
                    if collections.pop().is_none() {
                        return Err(DescriptorError::UnbalancedCollection { offset: at });
                    }
                    usages.clear();
                }
                // Global items.
                (1, 0) => g.usage_page = unsigned as u16,
                (1, 1) => g.logical_min = signed,
                (1, 2) => {
                    // Signed unless that would put it below the minimum.
                    g.logical_max = if signed < g.logical_min {
                        i64::from(unsigned)
                    } else {
                        signed
                    }
                }
                (1, 7) => g.report_size = unsigned.min(64),
                (1, 8) => {
                    g.report_id = unsigned as u8;
                    out.uses_report_ids = true;
                }
                (1, 9) => g.report_count = unsigned,
                (1, 0xA) => {
                    if stack.len() >= 16 {
                        return Err(DescriptorError::Limit {
                            offset: at,
                            what: "Push nested deeper than 16",
                        });
                    }
                    stack.push(g);
                }
                (1, 0xB) => {
                    g = stack
                        .pop()
                        .ok_or(DescriptorError::PopWithoutPush { offset: at })?
                }
                // Local items.
                (2, 0..=2) => {
                    let u = if size == 4 {
                        ((unsigned >> 16) as u16, unsigned as u16)
                    } else {
                        (g.usage_page, unsigned as u16)
                    };
                    match tag {
                        0 => {
                            if usages.len() >= 1024 {
                                return Err(DescriptorError::Limit {
                                    offset: at,
                                    what: "more than 1024 usages before one main item",
                                });
                            }
                            usages.push(u);
                        }
                        1 => usage_min = Some(u),
                        _ => usage_max = Some(u),
                    }
                }
                _ => {}
            }
        }
        if !collections.is_empty() {
            return Err(DescriptorError::Unclosed {
                open: collections.len(),
            });
        }
        Ok(out)
    }

    /// Length in bytes of a report's data (without the ID byte).
    pub fn report_len(&self, kind: ReportKind, report_id: u8) -> usize {
        let bits = self
            .fields
            .iter()
            .filter(|f| f.kind == kind && f.report_id == report_id)
            .map(|f| u64::from(f.bit_offset) + u64::from(f.bit_size))
            .max()
            .unwrap_or(0);
        bits.div_ceil(8) as usize
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn a_mouse_descriptor_parses() {
        // The boot mouse example of HID 1.11 Appendix E.10.
        let d = [
            0x05, 0x01, 0x09, 0x02, 0xA1, 0x01, 0x09, 0x01, 0xA1, 0x00, 0x05, 0x09, 0x19, 0x01,
            0x29, 0x03, 0x15, 0x00, 0x25, 0x01, 0x95, 0x03, 0x75, 0x01, 0x81, 0x02, 0x95, 0x01,
            0x75, 0x05, 0x81, 0x01, 0x05, 0x01, 0x09, 0x30, 0x09, 0x31, 0x15, 0x81, 0x25, 0x7F,
            0x75, 0x08, 0x95, 0x02, 0x81, 0x06, 0xC0, 0xC0,
        ];
        let r = ReportDescriptor::parse(&d).expect("valid");
        assert_eq!(r.applications, vec![(1, 2)]);
        assert!(!r.uses_report_ids);
        let buttons: Vec<u16> = r
            .fields
            .iter()
            .filter(|f| f.usage_page == 9 && f.usage != 0)
            .map(|f| f.usage)
            .collect();
        assert_eq!(buttons, [1, 2, 3]);
        let pad = r.fields.iter().find(|f| f.usage == 0).expect("padding");
        assert_eq!((pad.bit_offset, pad.bit_size, pad.constant), (3, 5, true));
        let x = r.fields.iter().find(|f| f.usage == 0x30).expect("X");
        assert_eq!((x.bit_offset, x.bit_size), (8, 8));
        assert_eq!(x.read(&[0, 0xFF, 0]), Some(-1), "signed range sign-extends");
        assert_eq!(r.report_len(ReportKind::Input, 0), 3);
    }

    #[test]
    fn broken_descriptors_are_errors() {
        assert!(matches!(
            ReportDescriptor::parse(&[0x05]),
            Err(DescriptorError::Truncated { offset: 0 })
        ));
        assert!(matches!(
            ReportDescriptor::parse(&[0xC0]),
            Err(DescriptorError::UnbalancedCollection { .. })
        ));
        assert!(matches!(
            ReportDescriptor::parse(&[0xB4]),
            Err(DescriptorError::PopWithoutPush { .. })
        ));
        assert!(matches!(
            ReportDescriptor::parse(&[0xA1, 0x01]),
            Err(DescriptorError::Unclosed { open: 1 })
        ));
        // 255 × 0xFFFF bits: refused before anything is allocated.
        assert!(matches!(
            ReportDescriptor::parse(&[0x75, 0xFF, 0x96, 0xFF, 0xFF, 0x81, 0x02]),
            Err(DescriptorError::Limit { .. })
        ));
    }

    #[test]
    fn bits_round_trip() {
        let mut b = [0u8; 6];
        write_bits(&mut b, 3, 29, 0x1234_5678);
        assert_eq!(read_bits(&b, 3, 29), Some(0x1234_5678 & ((1 << 29) - 1)));
        assert_eq!(read_bits(&b, 40, 9), None);
        write_bits(&mut b, 44, 16, 0xFFFF); // past the end: ignored, no panic
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(fixtures::proptest_cases(20_000)))]
        #[test]
        fn parsing_random_bytes_never_panics(bytes in prop::collection::vec(any::<u8>(), 0..200)) {
            if let Ok(d) = ReportDescriptor::parse(&bytes) {
                for f in &d.fields {
                    prop_assert!(f.bit_size <= 64);
                    let _ = f.read(&[0xA5; 16]);
                }
            }
        }
    }
}
