//! Murphy & Duchowski's empirical acuity degradation function (Murphy &
//! Duchowski 2001, §6.3, Table 1): for each viewing depth, the eccentricity
//! extent (degrees of visual angle) of each geometric resolution level.

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
    if eccentricity_deg.is_nan() || eccentricity_deg < 0.0 {
        return None;
    }
    let row = TABLE_1_DEG.get(depth)?;
    Some(
        LEVELS
            .iter()
            .zip(row)
            .find(|(_, &extent)| eccentricity_deg < extent)
            .map_or(1, |(&l, _)| l),
    )
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
}
