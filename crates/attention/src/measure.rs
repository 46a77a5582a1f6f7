//! What one frame's pixels say about each object: the boundary between the
//! per-pixel and per-map part of the model (steps 1–6 of Lee Fig. 3.1: map,
//! features, pyramids, contrast, `S_p`, the item-buffer reductions) and the
//! per-object finishing steps (contexts, Kalman filter, ranking, threshold).
//!
//! The CPU passes of [`crate::AttentionTracker::update`] fill a
//! [`FrameMeasure`] and finish it; a GPU implementation (gazecast's
//! `pipeline::gpu_attention`) fills the same record from its own kernels
//! and hands it to [`crate::AttentionTracker::update_measured`], so the
//! finishing code exists once. This module also holds what both sides need
//! to agree on which pixel belongs to which object and map cell
//! ([`ObjectIndex`], [`CellAxis`]).

use crate::config::{MAX_MAP_SIZE, MIN_MAP_SIZE};
use crate::error::AttentionError;
use crate::frame::{ObjectInfo, BACKGROUND_ID, MAX_FRAME_PIXELS, MAX_FRAME_SIDE, MAX_OBJECTS};

/// One object's pixel statistics in one frame. Sums are exact integers
/// where they count pixels or add pixel indices; the two real sums may be
/// rounded by whoever measured them.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ObjectMeasure {
    /// `n(k)` of eq. 3.7: the object's pixels in the frame.
    pub pixel_count: u64,
    /// Sum of the eye distances (mm) of its pixels with a finite depth,
    /// negative ones counted as 0 (`x` of eq. 3.9 is this over
    /// `depth_count`).
    pub depth_sum_mm: f64,
    /// Its pixels with a finite depth.
    pub depth_count: u64,
    /// Sum of its pixels' column indices (0-based).
    pub sum_x: u64,
    /// Sum of its pixels' row indices (0-based, top row 0).
    pub sum_y: u64,
    /// Sum of `S_p` over its pixels, each pixel reading its map cell
    /// (decision 8 of the crate docs).
    pub saliency_sum: f64,
    /// The highest `S_p` of a cell holding one of its pixels; any value
    /// when `peak_count` is 0.
    pub peak_saliency: f32,
    /// That cell (row-major index in the map); of equal cells the lowest.
    pub peak_cell: u32,
    /// Its pixels in that cell (0: no peak, the centroid is used).
    pub peak_count: u64,
    /// Sum of the column indices of its pixels in that cell.
    pub peak_sum_x: u64,
    /// Sum of the row indices of its pixels in that cell.
    pub peak_sum_y: u64,
}

/// One frame's measured statistics, from either path.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FrameMeasure {
    /// Frame width, pixels.
    pub width: u32,
    /// Frame height, pixels.
    pub height: u32,
    /// One entry per entry of the object list the frame is finished with,
    /// in that list's order.
    pub objects: Vec<ObjectMeasure>,
    /// Pixels with [`BACKGROUND_ID`].
    pub background_pixels: u64,
    /// Pixels whose id is not in the object list.
    pub unlisted_pixels: u64,
    /// Whether `S_p` carried bottom-up information (decision 7 of the crate
    /// docs). When false the saliency sums and peaks are not read: every
    /// visible object's mean `S_p` is 1 and its peak its centroid.
    pub bottom_up_informative: bool,
}

impl FrameMeasure {
    /// Checks the record against the frame size and the object list before
    /// anything is derived from it: pixel counts that add up to the frame,
    /// sub-counts within counts, finite non-negative real sums, peak cells
    /// inside a `map_size`² map.
    pub fn validate(&self, objects: usize, map_size: u32) -> Result<(), AttentionError> {
        check_frame_size(self.width, self.height)?;
        let bad = |reason: String| Err(AttentionError::InvalidMeasure(reason));
        if self.objects.len() != objects {
            return bad(format!(
                "{} object records for {objects} listed objects",
                self.objects.len()
            ));
        }
        let pixels = u64::from(self.width) * u64::from(self.height);
        let mut total = u128::from(self.background_pixels) + u128::from(self.unlisted_pixels);
        let cells = u64::from(map_size) * u64::from(map_size);
        for (i, o) in self.objects.iter().enumerate() {
            total += u128::from(o.pixel_count);
            if o.depth_count > o.pixel_count || o.peak_count > o.pixel_count {
                return bad(format!("objects[{i}]: a sub-count exceeds its pixel count"));
            }
            let sane = |v: f64| v.is_finite() && v >= 0.0;
            if !(sane(o.depth_sum_mm) && sane(o.saliency_sum)) {
                return bad(format!(
                    "objects[{i}]: depth and saliency sums must be finite and >= 0"
                ));
            }
            if o.peak_count > 0 && u64::from(o.peak_cell) >= cells {
                return bad(format!(
                    "objects[{i}]: peak cell {} outside the {map_size}² map",
                    o.peak_cell
                ));
            }
        }
        if total != u128::from(pixels) {
            return bad(format!(
                "pixel counts add up to {total}, the {}x{} frame has {pixels}",
                self.width, self.height
            ));
        }
        Ok(())
    }
}

/// Sides within the crate's limits (see [`crate::FrameView`]).
pub fn check_frame_size(width: u32, height: u32) -> Result<u64, AttentionError> {
    if width == 0 || height == 0 {
        return Err(AttentionError::EmptyFrame { width, height });
    }
    let pixels = u64::from(width) * u64::from(height);
    if width > MAX_FRAME_SIDE || height > MAX_FRAME_SIDE || pixels > MAX_FRAME_PIXELS {
        return Err(AttentionError::FrameTooLarge {
            width,
            height,
            max_side: MAX_FRAME_SIDE,
            max_pixels: MAX_FRAME_PIXELS,
        });
    }
    Ok(pixels)
}

/// The object list sorted by id: dense index `d` is the object of rank `d`
/// in id order, which is the order in which the tracker (and a GPU
/// implementation) keeps per-object accumulators; with the id → dense
/// index lookup both use ([`ObjectIndex::dense_of`],
/// [`ObjectIndex::direct_table`]).
#[derive(Clone, Debug, Default)]
pub struct ObjectIndex {
    sorted_ids: Vec<u32>,
    source: Vec<usize>,
    /// `direct[id]` is the dense index of `id` (or [`ObjectIndex::UNLISTED`])
    /// when every id is below [`ObjectIndex::DIRECT_LOOKUP_IDS`]; empty and
    /// unused otherwise.
    direct: Vec<u32>,
    use_direct: bool,
}

impl ObjectIndex {
    /// Ids below this (all of them) get a direct lookup table, at most
    /// 2^16 words; a list with a larger id is binary-searched.
    pub const DIRECT_LOOKUP_IDS: u32 = 1 << 16;
    /// The dense index of an id the list does not have (and of
    /// [`BACKGROUND_ID`]).
    pub const UNLISTED: u32 = u32::MAX;

    /// An index of `objects`; refuses more than `MAX_OBJECTS`, the
    /// background id and duplicate ids.
    pub fn new(objects: &[ObjectInfo]) -> Result<Self, AttentionError> {
        let mut index = Self::default();
        index.rebuild(objects)?;
        Ok(index)
    }

    /// Re-indexes, reusing the buffers. On error the index is empty.
    pub fn rebuild(&mut self, objects: &[ObjectInfo]) -> Result<(), AttentionError> {
        self.sorted_ids.clear();
        self.source.clear();
        self.direct.clear();
        self.use_direct = false;
        if objects.len() > MAX_OBJECTS {
            return Err(AttentionError::TooManyObjects {
                count: objects.len(),
                max: MAX_OBJECTS,
            });
        }
        self.source.extend(0..objects.len());
        self.source.sort_unstable_by_key(|&i| objects[i].id);
        self.sorted_ids
            .extend(self.source.iter().map(|&i| objects[i].id));
        let error = if self.sorted_ids.last() == Some(&BACKGROUND_ID) {
            Some(AttentionError::ReservedObjectId)
        } else {
            self.sorted_ids
                .windows(2)
                .find(|p| p[0] == p[1])
                .map(|pair| AttentionError::DuplicateObjectId(pair[0]))
        };
        if let Some(e) = error {
            self.sorted_ids.clear();
            self.source.clear();
            return Err(e);
        }
        // The direct table: ids are sorted, so the last is the largest.
        let len = self.sorted_ids.last().map_or(0, |&max| max as usize + 1);
        self.use_direct = len <= Self::DIRECT_LOOKUP_IDS as usize;
        if self.use_direct {
            self.direct.resize(len, Self::UNLISTED);
            for (d, &id) in self.sorted_ids.iter().enumerate() {
                self.direct[id as usize] = d as u32;
            }
        }
        Ok(())
    }

    /// The ids, ascending.
    pub fn sorted_ids(&self) -> &[u32] {
        &self.sorted_ids
    }

    /// List positions in dense order.
    pub fn sources(&self) -> &[usize] {
        &self.source
    }

    /// The direct lookup table (`table[id]` is the dense index of `id`, or
    /// [`ObjectIndex::UNLISTED`]; ids at or past its end are unlisted), or
    /// `None` when an id reaches [`ObjectIndex::DIRECT_LOOKUP_IDS`] and
    /// lookups search [`ObjectIndex::sorted_ids`]. Empty for an empty list.
    pub fn direct_table(&self) -> Option<&[u32]> {
        self.use_direct.then_some(self.direct.as_slice())
    }

    /// The dense index of `id`, or [`ObjectIndex::UNLISTED`] (also for
    /// [`BACKGROUND_ID`], which no list holds).
    #[inline]
    pub fn dense_of(&self, id: u32) -> u32 {
        if self.use_direct {
            self.direct
                .get(id as usize)
                .copied()
                .unwrap_or(Self::UNLISTED)
        } else {
            match self.sorted_ids.binary_search(&id) {
                Ok(d) => d as u32,
                Err(_) => Self::UNLISTED,
            }
        }
    }

    /// Objects indexed.
    pub fn len(&self) -> usize {
        self.sorted_ids.len()
    }

    /// No objects.
    pub fn is_empty(&self) -> bool {
        self.sorted_ids.is_empty()
    }
}

/// Frame ↔ map along one axis (step 1 of the crate docs): map cell `c`
/// averages frame pixels `lo[c]..hi[c]` (at least one; a frame shorter than
/// the map repeats pixels), and frame pixel `p` belongs to cell
/// `cell_of[p]` for eq. 3.7 (the cell whose footprint holds it when the
/// footprints partition the frame, else the nearest cell centre).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct CellAxis {
    /// First frame pixel of each cell's footprint.
    pub lo: Vec<u32>,
    /// One past the last frame pixel of each cell's footprint.
    pub hi: Vec<u32>,
    /// Each frame pixel's cell.
    pub cell_of: Vec<u32>,
}

impl CellAxis {
    /// The axis of a `frame_len`-pixel frame side on a `map_len`-cell map
    /// side. Both are checked before anything is allocated: the frame side
    /// as [`check_frame_size`] checks it (1 to `MAX_FRAME_SIDE`), the map
    /// side as the configuration does (`MIN_MAP_SIZE..=MAX_MAP_SIZE`).
    pub fn new(frame_len: u32, map_len: u32) -> Result<Self, AttentionError> {
        check_frame_size(frame_len, 1)?;
        if !(MIN_MAP_SIZE..=MAX_MAP_SIZE).contains(&map_len) {
            return Err(AttentionError::MapSizeOutOfRange {
                size: map_len,
                min: MIN_MAP_SIZE,
                max: MAX_MAP_SIZE,
            });
        }
        let mut axis = Self::default();
        footprints(
            frame_len,
            map_len,
            &mut axis.lo,
            &mut axis.hi,
            &mut axis.cell_of,
        );
        Ok(axis)
    }

    /// For each cell, the frame pixels `[first, end)` whose cell it is
    /// (`cell_of`, which is monotone): the footprint when the frame is at
    /// least as long as the map; one pixel or none otherwise.
    pub fn owned(&self) -> Vec<[u32; 2]> {
        let mut out = vec![[0u32, 0u32]; self.lo.len()];
        let mut p = 0usize;
        for (c, range) in out.iter_mut().enumerate() {
            while p < self.cell_of.len() && (self.cell_of[p] as usize) < c {
                p += 1;
            }
            let first = p;
            while p < self.cell_of.len() && self.cell_of[p] as usize == c {
                p += 1;
            }
            *range = [first as u32, p as u32];
        }
        out
    }
}

/// Footprints and the pixel → cell map along one axis.
pub(crate) fn footprints(
    frame_len: u32,
    map_len: u32,
    lo: &mut Vec<u32>,
    hi: &mut Vec<u32>,
    cell_of: &mut Vec<u32>,
) {
    let (n, m) = (u64::from(frame_len), u64::from(map_len));
    lo.clear();
    hi.clear();
    for c in 0..m {
        let a = (c * n / m).min(n - 1);
        let b = ((c + 1) * n / m).max(a + 1).min(n);
        lo.push(a as u32);
        hi.push(b as u32);
    }
    cell_of.clear();
    if n >= m {
        // Footprints partition the frame.
        cell_of.resize(frame_len as usize, 0);
        for c in 0..map_len as usize {
            for p in lo[c]..hi[c] {
                cell_of[p as usize] = c as u32;
            }
        }
    } else {
        cell_of.extend((0..n).map(|p| (((2 * p + 1) * m) / (2 * n)).min(m - 1) as u32));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn owned_ranges_invert_cell_of() {
        for (n, m) in [
            (640u32, 64u32),
            (333, 100),
            (64, 64),
            (50, 64),
            (1, 512),
            (7, 64),
        ] {
            let axis = CellAxis::new(n, m).expect("valid sizes");
            let owned = axis.owned();
            assert_eq!(owned.len(), m as usize);
            let mut seen = vec![0u32; n as usize];
            for (c, &[a, b]) in owned.iter().enumerate() {
                for p in a..b {
                    assert_eq!(axis.cell_of[p as usize], c as u32, "{n} {m}");
                    seen[p as usize] += 1;
                }
                if n >= m {
                    assert_eq!([a, b], [axis.lo[c], axis.hi[c]]);
                }
            }
            assert!(seen.iter().all(|&s| s == 1), "{n} {m}: every pixel once");
        }
    }

    #[test]
    fn index_refuses_duplicates_and_the_background_id() {
        let a = ObjectInfo::still(3, 1.0);
        assert_eq!(
            ObjectIndex::new(&[a, a]).err(),
            Some(AttentionError::DuplicateObjectId(3))
        );
        assert_eq!(
            ObjectIndex::new(&[ObjectInfo::still(BACKGROUND_ID, 1.0)]).err(),
            Some(AttentionError::ReservedObjectId)
        );
        let index = ObjectIndex::new(&[ObjectInfo::still(9, 1.0), a]).expect("valid");
        assert_eq!(index.sorted_ids(), &[3, 9]);
        assert_eq!(index.sources(), &[1, 0]);
    }

    #[test]
    fn lookups_find_listed_ids_through_the_table_and_the_search() {
        let u = ObjectIndex::UNLISTED;
        let small = ObjectIndex::new(&[
            ObjectInfo::still(7, 1.0),
            ObjectInfo::still(2, 1.0),
            ObjectInfo::still(4, 1.0),
        ])
        .expect("valid");
        let table = small.direct_table().expect("small ids: a table");
        assert_eq!(table, &[u, u, 0, u, 1, u, u, 2]);
        let large_id = ObjectIndex::DIRECT_LOOKUP_IDS;
        let large =
            ObjectIndex::new(&[ObjectInfo::still(large_id, 1.0), ObjectInfo::still(2, 1.0)])
                .expect("valid");
        assert_eq!(large.direct_table(), None, "an id past the table");
        let just_fits = ObjectIndex::new(&[ObjectInfo::still(large_id - 1, 1.0)]).expect("valid");
        assert_eq!(
            just_fits.direct_table().map(<[u32]>::len),
            Some(large_id as usize)
        );
        let empty = ObjectIndex::new(&[]).expect("valid");
        assert_eq!(empty.direct_table(), Some(&[][..]));
        for (index, listed) in [
            (&small, &[(2, 0), (4, 1), (7, 2)][..]),
            (&large, &[(2, 0), (large_id, 1)][..]),
            (&just_fits, &[(large_id - 1, 0)][..]),
            (&empty, &[][..]),
        ] {
            for &(id, d) in listed {
                assert_eq!(index.dense_of(id), d, "{id}");
            }
            for id in [0, 3, 5, 8, 1000, large_id + 1, BACKGROUND_ID] {
                if listed.iter().all(|&(l, _)| l != id) {
                    assert_eq!(index.dense_of(id), u, "{id}");
                }
            }
        }
        // A refused list leaves no table behind.
        let mut index = small.clone();
        assert!(index
            .rebuild(&[ObjectInfo::still(BACKGROUND_ID, 1.0)])
            .is_err());
        assert_eq!((index.len(), index.dense_of(2)), (0, u));
    }

    #[test]
    fn axes_refuse_sizes_out_of_range_before_allocating() {
        for (n, m) in [
            (0, 64),
            (MAX_FRAME_SIDE + 1, 64),
            (u32::MAX, 64),
            (640, MIN_MAP_SIZE - 1),
            (640, MAX_MAP_SIZE + 1),
            (640, 0),
            (u32::MAX, u32::MAX),
        ] {
            assert!(CellAxis::new(n, m).is_err(), "{n} {m}");
        }
        let widest = CellAxis::new(MAX_FRAME_SIDE, MIN_MAP_SIZE).expect("the largest side");
        assert_eq!(widest.cell_of.len(), MAX_FRAME_SIDE as usize);
        assert_eq!(CellAxis::new(1, MAX_MAP_SIZE).map(|a| a.lo.len()), Ok(512));
    }
}
