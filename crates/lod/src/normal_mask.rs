//! Normal masks (Luebke & Hallen 2001 §5.2 "Determining Silhouette Nodes",
//! after Zhang & Hoff, their ref. 30): the Gauss sphere mapped to a cube whose six
//! faces are tiled into 8×8 cells, 384 bits in all (the paper's 48 bytes).
//!
//! Layout (a Gap of the seed, decided here): face `f` = 2·axis + (0 for +,
//! 1 for −), axis 0 = x, 1 = y, 2 = z, chosen by the normal's largest
//! |component| (ties go to the lower axis). On a face, `s = n[(axis+1)%3] /
//! |n[axis]|` and `t = n[(axis+2)%3] / |n[axis]|`, both in [−1, 1]; cell
//! `i = ⌊(s+1)·4⌋`, `j = ⌊(t+1)·4⌋` (clamped to 0..=7); bit `j·8 + i` of word
//! `f`. Each cell's normals lie within a cap of angular radius ρ around the
//! cell's centre normal (ρ = the largest angle to the cell's four corners,
//! ≤ 19.5° on this layout), which is what the silhouette test uses.

use std::sync::OnceLock;

use glam::DVec3;

/// 384 bits: one per normal-cube cell.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub struct NormalMask(pub [u64; 6]);

impl NormalMask {
    /// The cell (`face`, `bit`) holding unit or non-unit `normal`; `None` for a
    /// zero or non-finite vector (a zero-area triangle has no normal).
    pub fn cell_of(normal: DVec3) -> Option<(usize, u32)> {
        if !normal.is_finite() {
            return None;
        }
        let abs = normal.abs();
        let axis = if abs.x >= abs.y && abs.x >= abs.z {
            0
        } else if abs.y >= abs.z {
            1
        } else {
            2
        };
        let major = normal[axis];
        if major == 0.0 {
            return None;
        }
        let face = 2 * axis + usize::from(major < 0.0);
        let s = normal[(axis + 1) % 3] / major.abs();
        let t = normal[(axis + 2) % 3] / major.abs();
        let cell = |x: f64| (((x + 1.0) * 4.0).floor() as i64).clamp(0, 7) as u32;
        Some((face, cell(t) * 8 + cell(s)))
    }

    /// Sets the cell of `normal` (no-op for a zero normal).
    pub fn insert(&mut self, normal: DVec3) {
        if let Some((face, bit)) = Self::cell_of(normal) {
            self.0[face] |= 1u64 << bit;
        }
    }

    /// Bitwise OR (how masks propagate up the tree).
    pub fn union_with(&mut self, other: &NormalMask) {
        for (a, b) in self.0.iter_mut().zip(other.0) {
            *a |= b;
        }
    }

    /// Every bit of `other` is set in `self`.
    pub fn contains(&self, other: &NormalMask) -> bool {
        self.0.iter().zip(other.0).all(|(a, b)| b & !a == 0)
    }

    /// Whether no bit is set (no normal direction).
    pub fn is_empty(&self) -> bool {
        self.0.iter().all(|w| *w == 0)
    }

    /// Number of cells set.
    pub fn count(&self) -> u32 {
        self.0.iter().map(|w| w.count_ones()).sum()
    }

    /// Could this node support both front- and back-facing triangles when
    /// seen from anywhere inside the cone of view directions with unit axis
    /// `axis` (eye → sphere centre) and half-angle α (`sin_alpha`,
    /// `cos_alpha`)? A triangle with normal n is front-facing along view
    /// direction u iff n·u < 0. Over a cone and a cell cap (centre c, radius
    /// ρ), with β the angle between c and the axis: front is possible iff
    /// β + α + ρ > 90°, back iff β − α − ρ < 90°, i.e. `cos β < sin(α+ρ)`
    /// and `cos β > −sin(α+ρ)` (both certain once α + ρ ≥ 90°). This is
    /// L&H's "might-be-front / might-be-back" pair of masks evaluated for
    /// the node's own view cone, so perspective is handled (the seed gives
    /// no rule for it).
    pub fn is_silhouette(&self, axis: DVec3, sin_alpha: f64, cos_alpha: f64) -> bool {
        let cells = cells();
        let (mut front, mut back) = (false, false);
        for (face, &word) in self.0.iter().enumerate() {
            let mut w = word;
            while w != 0 {
                let bit = w.trailing_zeros() as usize;
                w &= w - 1;
                let cell = &cells[face * 64 + bit];
                // cos(α+ρ) ≤ 0: the widened cone reaches 90°, both are possible.
                let cos_sum = cos_alpha * cell.cos_rho - sin_alpha * cell.sin_rho;
                if cos_sum <= 0.0 {
                    return true;
                }
                let sin_sum = sin_alpha * cell.cos_rho + cos_alpha * cell.sin_rho;
                let cos_beta = cell.centre.dot(axis);
                front |= cos_beta < sin_sum;
                back |= cos_beta > -sin_sum;
                if front && back {
                    return true;
                }
            }
        }
        false
    }
}

/// A cone of normals holding every cell cap of a mask: a quick, exact
/// pre-test for [`NormalMask::is_silhouette`] (if the cone is all front- or
/// all back-facing, so is the mask). Not the paper's normal cone test
/// (which it rejected as over-conservative): the answer is always the
/// mask's; the cone only skips the bit loop where it cannot change it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct NormalCone {
    axis: glam::Vec3,
    sin_half: f32,
    cos_half: f32,
}

impl NormalCone {
    /// The cone that always answers "maybe" (empty masks, wide spreads).
    const ANY: NormalCone = NormalCone {
        axis: glam::Vec3::Z,
        sin_half: 0.0,
        cos_half: -1.0,
    };

    pub(crate) fn of(mask: &NormalMask) -> NormalCone {
        let cells = cells();
        let mut sum = DVec3::ZERO;
        for_each_bit(mask, |i| sum += cells[i].centre);
        let len = sum.length();
        if mask.is_empty() || len < 1e-9 {
            return Self::ANY;
        }
        let axis = sum / len;
        let mut half: f64 = 0.0;
        for_each_bit(mask, |i| {
            let c = &cells[i];
            let rho = c.sin_rho.atan2(c.cos_rho);
            half = half.max(c.centre.dot(axis).clamp(-1.0, 1.0).acos() + rho);
        });
        // Margin for the f32 storage of the axis and the angles.
        let half = half + 1e-4;
        if half >= std::f64::consts::FRAC_PI_2 {
            return Self::ANY;
        }
        NormalCone {
            axis: axis.as_vec3(),
            sin_half: half.sin() as f32,
            cos_half: half.cos() as f32,
        }
    }

    /// `false` when the cone proves the node is not a silhouette from a
    /// view cone with unit `axis` and half-angle α; `true` means "ask the
    /// mask". Same inequalities as [`NormalMask::is_silhouette`].
    pub(crate) fn may_be_silhouette(&self, axis: DVec3, sin_alpha: f64, cos_alpha: f64) -> bool {
        if self.cos_half < 0.0 {
            return true;
        }
        let (s, c) = (f64::from(self.sin_half), f64::from(self.cos_half));
        if cos_alpha * c - sin_alpha * s <= 0.0 {
            return true;
        }
        let sin_sum = sin_alpha * c + cos_alpha * s;
        let cos_beta = self.axis.as_dvec3().dot(axis);
        cos_beta < sin_sum && cos_beta > -sin_sum
    }
}

fn for_each_bit(mask: &NormalMask, mut f: impl FnMut(usize)) {
    for (face, &word) in mask.0.iter().enumerate() {
        let mut w = word;
        while w != 0 {
            let bit = w.trailing_zeros() as usize;
            w &= w - 1;
            f(face * 64 + bit);
        }
    }
}

/// Centre normal and cap radius of one cell.
pub(crate) struct Cell {
    pub(crate) centre: DVec3,
    pub(crate) sin_rho: f64,
    pub(crate) cos_rho: f64,
}

fn face_point(face: usize, s: f64, t: f64) -> DVec3 {
    let axis = face / 2;
    let sign = if face & 1 == 0 { 1.0 } else { -1.0 };
    let mut v = DVec3::ZERO;
    v[axis] = sign;
    v[(axis + 1) % 3] = s;
    v[(axis + 2) % 3] = t;
    v.normalize()
}

/// The 384 cells, computed once.
pub(crate) fn cells() -> &'static [Cell] {
    static CELLS: OnceLock<Vec<Cell>> = OnceLock::new();
    CELLS.get_or_init(|| {
        let mut v = Vec::with_capacity(384);
        for face in 0..6 {
            for bit in 0..64 {
                let (i, j) = ((bit % 8) as f64, (bit / 8) as f64);
                let edge = |k: f64| -1.0 + k / 4.0;
                let centre = face_point(face, edge(i + 0.5), edge(j + 0.5));
                let mut rho: f64 = 0.0;
                for (di, dj) in [(0.0, 0.0), (1.0, 0.0), (0.0, 1.0), (1.0, 1.0)] {
                    let corner = face_point(face, edge(i + di), edge(j + dj));
                    rho = rho.max(corner.dot(centre).clamp(-1.0, 1.0).acos());
                }
                // A hair of margin for rounding at cell borders.
                rho += 1e-9;
                v.push(Cell {
                    centre,
                    sin_rho: rho.sin(),
                    cos_rho: rho.cos(),
                });
            }
        }
        v
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_normal_falls_within_its_cells_cap() {
        let cells = cells();
        let mut k = 0u32;
        for a in 0..40 {
            for b in 0..80 {
                let theta = std::f64::consts::PI * (a as f64 + 0.5) / 40.0;
                let phi = std::f64::consts::TAU * b as f64 / 80.0;
                let n = DVec3::new(
                    theta.sin() * phi.cos(),
                    theta.sin() * phi.sin(),
                    theta.cos(),
                );
                let (face, bit) = NormalMask::cell_of(n).unwrap();
                let c = &cells[face * 64 + bit as usize];
                let rho = c.sin_rho.atan2(c.cos_rho);
                assert!(n.dot(c.centre).clamp(-1.0, 1.0).acos() <= rho + 1e-12);
                k += 1;
            }
        }
        assert_eq!(k, 3200);
        assert!(NormalMask::cell_of(DVec3::ZERO).is_none());
    }

    #[test]
    fn a_sphere_of_normals_is_a_silhouette_and_a_plane_seen_head_on_is_not() {
        let mut plane = NormalMask::default();
        plane.insert(DVec3::Z);
        // Looking down −z at a +z-facing patch, narrow cone: front only.
        let (s, c) = (0.01f64.sin(), 0.01f64.cos());
        assert!(!plane.is_silhouette(-DVec3::Z, s, c));
        // Seen edge-on it may be both.
        assert!(plane.is_silhouette(DVec3::X, s, c));
        let mut all = NormalMask::default();
        all.insert(DVec3::Z);
        all.insert(-DVec3::Z);
        assert!(all.is_silhouette(-DVec3::Z, s, c));
    }

    #[test]
    fn the_cone_pre_test_never_contradicts_the_mask() {
        // A small deterministic generator (no dev-dependency needed here).
        let mut seed = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let unit = |next: &mut dyn FnMut() -> f64| {
            let z = 2.0 * next() - 1.0;
            let phi = std::f64::consts::TAU * next();
            let r = (1.0 - z * z).sqrt();
            DVec3::new(r * phi.cos(), r * phi.sin(), z)
        };
        let (mut skipped, mut total) = (0, 0);
        for _ in 0..300 {
            let centre = unit(&mut next);
            let mut mask = NormalMask::default();
            for _ in 0..6 {
                mask.insert((centre + unit(&mut next) * 0.3).normalize());
            }
            let cone = NormalCone::of(&mask);
            for _ in 0..20 {
                let axis = unit(&mut next);
                let alpha = 0.3 * (next() * next());
                let (s, c) = (alpha.sin(), alpha.cos());
                total += 1;
                if !cone.may_be_silhouette(axis, s, c) {
                    skipped += 1;
                    assert!(!mask.is_silhouette(axis, s, c));
                }
            }
        }
        assert!(skipped > total / 4, "{skipped} of {total}");
    }
}
