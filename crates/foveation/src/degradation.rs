//! Murphy & Duchowski's empirical acuity degradation function (Murphy &
//! Duchowski 2001, §6.3, Table 1): for each viewing depth, the eccentricity
//! extent (degrees of visual angle) of each geometric resolution level.
//!
//! [`DegradationTable`] is a table of the same shape from a file (RON): a
//! participant's, measured by `gazecast thresholds degradation`, which
//! [`level_in`] reads as [`level_for`] reads Table 1.

use serde::{Deserialize, Serialize};

/// Levels from finest (5) to coarsest (1), as in the table's columns.
pub const LEVELS: [u8; 5] = [5, 4, 3, 2, 1];

/// Table 1, rows = depth 0..=4, columns = level 5 (fine) … level 1 (coarse).
/// Reproduced as published, including the anomaly the authors point out
/// (depth 4: level 2 reaches farther than level 1).
pub const TABLE_1_DEG: [[f64; 5]; 5] = [
    [2.5, 6.0, 9.8, 14.5, 15.5],
    [1.0, 6.3, 8.5, 14.0, 14.5],
    [0.0, 4.3, 9.5, 11.8, 13.3],
    [1.0, 5.0, 9.5, 10.8, 11.8],
    [0.0, 3.5, 8.3, 13.5, 11.8],
];

/// Extent (degrees) of `level` (1..=5) at `depth` (0..=4); `None` outside the table.
pub fn extent_deg(level: u8, depth: usize) -> Option<f64> {
    let column = LEVELS.iter().position(|&l| l == level)?;
    TABLE_1_DEG.get(depth).map(|row| row[column])
}

/// The finest resolution level whose extent contains `eccentricity_deg` at
/// `depth` (strictly inside: an extent of 0° holds nothing). Beyond every
/// extent the coarsest level (1) applies, as in the paper's recursive
/// subdivision, which never refines past the furthest range. `None` for a
/// depth outside the table or a NaN or negative eccentricity.
pub fn level_for(eccentricity_deg: f64, depth: usize) -> Option<u8> {
    level_in(&TABLE_1_DEG, eccentricity_deg, depth)
}

/// [`level_for`] in another table of Table 1's shape (rows = depths 0..=4,
/// columns = levels 5 … 1): the finest level whose extent strictly
/// contains `eccentricity_deg` at `depth`, level 1 beyond every extent.
/// `None` for a depth outside the table or a NaN or negative eccentricity.
pub fn level_in(extents_deg: &[[f64; 5]; 5], eccentricity_deg: f64, depth: usize) -> Option<u8> {
    if eccentricity_deg.is_nan() || eccentricity_deg < 0.0 {
        return None;
    }
    let row = extents_deg.get(depth)?;
    Some(
        LEVELS
            .iter()
            .zip(row)
            .find(|(_, &extent)| eccentricity_deg < extent)
            .map_or(1, |(&l, _)| l),
    )
}

/// The angles (degrees) Murphy & Duchowski's object subtended at depths
/// 0–4 (§6.2).
pub const DEPTH_SUBTENDED_DEG: [f64; 5] = [26.0, 24.0, 22.0, 20.0, 18.0];

/// A degradation table of Table 1's shape, as a file holds it (RON): for
/// each depth (the object subtending `depth_subtended_deg[d]`), the
/// eccentricity (degrees) up to which each level 5 (fine) … 1 (coarse) is
/// shown. Read by [`level_in`]; beyond every extent level 1 is drawn.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DegradationTable {
    /// Where the table came from (a participant, a session, "Table 1").
    pub source: String,
    /// True when a simulated observer, not a person, produced it.
    #[serde(default)]
    pub synthetic: bool,
    /// The object's angular size (degrees) at each depth row 0..=4.
    pub depth_subtended_deg: [f64; 5],
    /// Rows = depths 0..=4; columns = levels 5, 4, 3, 2, 1: the
    /// eccentricity extent (degrees, finite, ≥ 0) of each level.
    pub extents_deg: [[f64; 5]; 5],
}

impl DegradationTable {
    /// Murphy & Duchowski's Table 1.
    pub fn murphy_duchowski() -> Self {
        Self {
            source: "Murphy & Duchowski 2001, Table 1".into(),
            synthetic: false,
            depth_subtended_deg: DEPTH_SUBTENDED_DEG,
            extents_deg: TABLE_1_DEG,
        }
    }

    /// Checks every value: the dotted path of the first bad field
    /// (`extents_deg.2`, `depth_subtended_deg`) and what is wrong.
    pub fn check(&self) -> Result<(), (String, String)> {
        for (d, &a) in self.depth_subtended_deg.iter().enumerate() {
            if !(a.is_finite() && a > 0.0 && a < 180.0) {
                return Err((
                    "depth_subtended_deg".into(),
                    format!("depth {d}: {a} must be finite and in (0, 180) degrees"),
                ));
            }
        }
        for (d, row) in self.extents_deg.iter().enumerate() {
            for (k, &e) in row.iter().enumerate() {
                if !(e.is_finite() && e >= 0.0) {
                    return Err((
                        format!("extents_deg.{d}"),
                        format!(
                            "level {}: {e} must be a finite eccentricity ≥ 0 degrees",
                            LEVELS[k]
                        ),
                    ));
                }
            }
        }
        Ok(())
    }

    /// The depth row whose angle is nearest `subtended_deg` (ties to the
    /// nearer row); `None` for a NaN angle.
    pub fn row_for(&self, subtended_deg: f64) -> Option<usize> {
        if subtended_deg.is_nan() {
            return None;
        }
        (0..5).min_by(|&a, &b| {
            (self.depth_subtended_deg[a] - subtended_deg)
                .abs()
                .total_cmp(&(self.depth_subtended_deg[b] - subtended_deg).abs())
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_values_match_the_paper() {
        assert_eq!(extent_deg(5, 0), Some(2.5));
        assert_eq!(extent_deg(1, 4), Some(11.8));
        assert_eq!(extent_deg(2, 4), Some(13.5));
        assert_eq!(extent_deg(6, 0), None);
        assert_eq!(extent_deg(3, 5), None);
    }

    #[test]
    fn lookup_picks_the_finest_containing_level() {
        assert_eq!(level_for(0.0, 0), Some(5));
        assert_eq!(level_for(2.5, 0), Some(4));
        assert_eq!(level_for(0.0, 2), Some(4)); // level 5 has zero extent at depth 2
        assert_eq!(level_for(15.0, 0), Some(1));
        assert_eq!(level_for(40.0, 0), Some(1));
        assert_eq!(level_for(12.0, 4), Some(2)); // the published anomaly
        assert_eq!(level_for(f64::NAN, 0), None);
        assert_eq!(level_for(1.0, 9), None);
    }

    #[test]
    fn a_table_from_a_file_is_checked_and_read_like_table_1() {
        let t = DegradationTable::murphy_duchowski();
        assert!(t.check().is_ok());
        for e in [0.0, 1.0, 2.5, 9.9, 14.6, 30.0] {
            for d in 0..5 {
                assert_eq!(level_in(&t.extents_deg, e, d), level_for(e, d));
            }
        }
        let mut bad = t.clone();
        bad.extents_deg[2][3] = f64::NAN;
        assert_eq!(bad.check().unwrap_err().0, "extents_deg.2");
        bad.extents_deg[2][3] = -1.0;
        assert!(bad.check().unwrap_err().1.contains("level 2"));
        let mut bad = t.clone();
        bad.depth_subtended_deg[0] = 0.0;
        assert_eq!(bad.check().unwrap_err().0, "depth_subtended_deg");
        assert_eq!(t.row_for(25.2), Some(0));
        assert_eq!(t.row_for(19.0), Some(3));
        assert_eq!(t.row_for(3.0), Some(4));
        assert_eq!(t.row_for(f64::NAN), None);
    }
}
