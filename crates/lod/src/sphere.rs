//! Bounding spheres of a node's region of support (Luebke & Hallen 2001
//! §5.2 "Spatial Frequency: Estimating Extent").

use glam::{DVec3, Vec3};

/// A sphere in world millimetres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sphere {
    /// Centre, world millimetres.
    pub center: Vec3,
    /// Radius, world millimetres.
    pub radius: f32,
}

impl Sphere {
    /// Does the sphere hold `p`, allowing `slack` (relative to the sphere's
    /// size and position, for f32 rounding)?
    pub fn contains_point(&self, p: Vec3, slack: f32) -> bool {
        let tol = slack * (self.radius + self.center.abs().max_element() + p.abs().max_element());
        self.center.distance(p) <= self.radius + tol
    }

    /// Does the sphere hold all of `other`?
    pub fn contains_sphere(&self, other: &Sphere, slack: f32) -> bool {
        let tol = slack * (self.radius + self.center.abs().max_element());
        self.center.distance(other.center) + other.radius <= self.radius + tol
    }
}

/// An f64 sphere used while building.
#[derive(Debug, Clone, Copy)]
pub(crate) struct DSphere {
    pub(crate) c: DVec3,
    pub(crate) r: f64,
}

impl DSphere {
    /// The smallest sphere holding both.
    pub(crate) fn enclose(a: DSphere, b: DSphere) -> DSphere {
        let d = a.c.distance(b.c);
        if d + b.r <= a.r {
            return a;
        }
        if d + a.r <= b.r {
            return b;
        }
        let r = 0.5 * (d + a.r + b.r);
        let c = if d > 0.0 {
            a.c + (b.c - a.c) * ((r - a.r) / d)
        } else {
            a.c
        };
        DSphere { c, r }
    }

    /// Grows the radius (not the centre) to reach `p`.
    pub(crate) fn include(&mut self, p: DVec3) {
        self.r = self.r.max(self.c.distance(p));
    }

    /// Rounds to f32, growing the radius so the f32 sphere still contains the
    /// f64 one, plus a relative margin of 2⁻²⁰ so that containment between
    /// parent and child survives the f32 rounding of later computations.
    pub(crate) fn to_f32(self) -> Sphere {
        let center = self.c.as_vec3();
        let moved = self.c.distance(center.as_dvec3());
        let margin = (self.c.abs().max_element() + self.r) * (1.0 / (1u64 << 20) as f64);
        let r = self.r + moved + margin;
        let mut radius = r as f32;
        if f64::from(radius) < r {
            radius = f32::from_bits(radius.to_bits() + 1);
        }
        Sphere { center, radius }
    }

    pub(crate) fn from_f32(s: &Sphere) -> DSphere {
        DSphere {
            c: s.center.as_dvec3(),
            r: f64::from(s.radius),
        }
    }
}
