//! Garland–Heckbert error quadrics (Garland & Heckbert 1997, cited by
//! Luebke & Hallen 2001 §5 via their ref. 11): the squared distance to a set of
//! planes, `Q(x) = xᵀAx + 2bᵀx + c`, summed when vertices merge.

use glam::DVec3;

/// A symmetric 4×4 quadric stored as A (6 entries), b (3) and c, in f64.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub(crate) struct Quadric {
    a: [f64; 6], // xx, xy, xz, yy, yz, zz
    b: [f64; 3],
    c: f64,
}

impl Quadric {
    /// The plane `n·x + d = 0` (n unit) with `weight`.
    pub(crate) fn plane(n: DVec3, d: f64, weight: f64) -> Self {
        let w = weight;
        Self {
            a: [
                w * n.x * n.x,
                w * n.x * n.y,
                w * n.x * n.z,
                w * n.y * n.y,
                w * n.y * n.z,
                w * n.z * n.z,
            ],
            b: [w * d * n.x, w * d * n.y, w * d * n.z],
            c: w * d * d,
        }
    }

    pub(crate) fn add(&mut self, o: &Quadric) {
        for i in 0..6 {
            self.a[i] += o.a[i];
        }
        for i in 0..3 {
            self.b[i] += o.b[i];
        }
        self.c += o.c;
    }

    pub(crate) fn sum(p: &Quadric, q: &Quadric) -> Quadric {
        let mut s = *p;
        s.add(q);
        s
    }

    fn mul_a(&self, v: DVec3) -> DVec3 {
        let a = &self.a;
        DVec3::new(
            a[0] * v.x + a[1] * v.y + a[2] * v.z,
            a[1] * v.x + a[3] * v.y + a[4] * v.z,
            a[2] * v.x + a[4] * v.y + a[5] * v.z,
        )
    }

    fn b(&self) -> DVec3 {
        DVec3::new(self.b[0], self.b[1], self.b[2])
    }

    /// The error at `x`, clamped at 0 (rounding can make it slightly negative).
    pub(crate) fn error(&self, x: DVec3) -> f64 {
        (x.dot(self.mul_a(x)) + 2.0 * self.b().dot(x) + self.c).max(0.0)
    }

    /// The minimiser of Q (solving `A x = −b`), or `None` when A is
    /// singular or ill-conditioned (flat or linear regions, isolated points).
    pub(crate) fn optimum(&self) -> Option<DVec3> {
        let a = &self.a;
        let (m00, m01, m02, m11, m12, m22) = (a[0], a[1], a[2], a[3], a[4], a[5]);
        let c00 = m11 * m22 - m12 * m12;
        let c01 = m02 * m12 - m01 * m22;
        let c02 = m01 * m12 - m02 * m11;
        let det = m00 * c00 + m01 * c01 + m02 * c02;
        let trace = m00 + m11 + m22;
        // Relative conditioning test: det is the product of the eigenvalues,
        // trace³/27 that of three equal ones.
        if trace.is_nan() || trace <= 0.0 || det.abs() <= 1e-9 * (trace * trace * trace / 27.0) {
            return None;
        }
        let c11 = m00 * m22 - m02 * m02;
        let c12 = m01 * m02 - m00 * m12;
        let c22 = m00 * m11 - m01 * m01;
        let rhs = -self.b();
        let x = DVec3::new(
            c00 * rhs.x + c01 * rhs.y + c02 * rhs.z,
            c01 * rhs.x + c11 * rhs.y + c12 * rhs.z,
            c02 * rhs.x + c12 * rhs.y + c22 * rhs.z,
        ) / det;
        x.is_finite().then_some(x)
    }

    /// The minimiser on the segment `p`–`q` (Garland–Heckbert's fallback for
    /// a singular quadric): `Q(p + t(q−p))` is a parabola in t; its minimum
    /// clamped to [0, 1], or the midpoint when it is flat.
    pub(crate) fn segment_optimum(&self, p: DVec3, q: DVec3) -> DVec3 {
        let d = q - p;
        let quad = d.dot(self.mul_a(d));
        let lin = d.dot(self.mul_a(p) + self.b());
        let scale = self.a[0] + self.a[3] + self.a[5];
        if quad > 1e-12 * scale * d.length_squared() && quad > 0.0 {
            let t = (-lin / quad).clamp(0.0, 1.0);
            p + d * t
        } else {
            (p + q) * 0.5
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn three_orthogonal_planes_meet_at_their_corner() {
        let mut q = Quadric::plane(DVec3::X, -1.0, 1.0);
        q.add(&Quadric::plane(DVec3::Y, -2.0, 1.0));
        q.add(&Quadric::plane(DVec3::Z, -3.0, 1.0));
        let x = q.optimum().unwrap();
        assert!((x - DVec3::new(1.0, 2.0, 3.0)).length() < 1e-12);
        assert!(q.error(x) < 1e-12);
    }

    #[test]
    fn one_plane_is_singular_and_falls_back_to_the_segment() {
        let q = Quadric::plane(DVec3::Z, 0.0, 1.0);
        assert!(q.optimum().is_none());
        let m = q.segment_optimum(DVec3::new(0.0, 0.0, 1.0), DVec3::new(0.0, 0.0, -3.0));
        assert!(m.z.abs() < 1e-12, "{m}");
        let flat = q.segment_optimum(DVec3::ZERO, DVec3::X);
        assert!((flat - DVec3::new(0.5, 0.0, 0.0)).length() < 1e-12);
    }
}
