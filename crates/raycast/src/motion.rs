//! Scenes that move: keyframed paths for objects (`objects[i].motion`) and
//! for the camera (`camera`), read from the scene file and sampled at a
//! time on the scene's clock (seconds).
//!
//! A path is a list of keys, each a time with a translation (mm) and a
//! rotation (degrees about x, then y, then z, as an object's own
//! `rotate_deg`). Between keys both are interpolated linearly, component by
//! component (the rotation's Euler angles too: exact for turns about one
//! axis, a smooth but not shortest path otherwise). Before the first key
//! the path holds the first key; after the last one `repeat` decides:
//! `Hold` keeps the last key, `Loop` starts again from the first (the last
//! key should equal the first for a seamless loop), `Bounce` plays the path
//! backwards and forwards. Non-finite times are read as the first key's
//! time, so no pose is ever undefined.
//!
//! An object's path is an offset from the object's own pose: at time `t`
//! the object is rotated by its `rotate_deg`, then by the path's rotation
//! (about the object's origin), and moved to `translate_mm` plus the
//! path's translation. The camera's path moves the viewer — eye and display
//! together — through the world: at time `t` the display's frame is the
//! world's frame turned by the path's rotation (about the screen centre)
//! and moved by its translation, so the world seen on the screen moves the
//! opposite way. Point and directional lights belong to the world and move
//! with it; the headlight stays at the eye.

use glam::{EulerRot, Mat3, Vec3};
use serde::{Deserialize, Serialize};

use crate::error::SceneError;

/// Most keys one path may have.
pub const MAX_KEYS: usize = 100_000;
/// Largest key time, seconds (|t_s|), and largest key translation, mm per
/// component: a day and a kilometre, far beyond a lab session and room.
pub const MAX_KEY_TIME_S: f64 = 86_400.0;
/// Largest key translation, mm per component (a kilometre).
pub const MAX_KEY_TRANSLATE_MM: f32 = 1e6;

/// What a path does after its last key.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub enum Repeat {
    /// Keep the last key's pose.
    #[default]
    Hold,
    /// Start again from the first key.
    Loop,
    /// Play backwards to the first key, then forwards again.
    Bounce,
}

/// One key of a path.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Key {
    /// Time on the scene's clock, seconds.
    pub t_s: f64,
    /// Translation, mm (display frame: x right, y up, z towards the viewer).
    #[serde(default)]
    pub translate_mm: (f32, f32, f32),
    /// Rotation in degrees about x, then y, then z.
    #[serde(default)]
    pub rotate_deg: (f32, f32, f32),
}

/// A keyframed path.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Motion {
    /// At least one key, times strictly increasing.
    pub keys: Vec<Key>,
    /// What the path does after its last key.
    #[serde(default)]
    pub repeat: Repeat,
}

/// A rigid pose: `p ↦ rotation · p + translation`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// Rotation part.
    pub rotation: Mat3,
    /// Translation part, mm.
    pub translation: Vec3,
}

impl Pose {
    /// The pose that moves nothing.
    pub const IDENTITY: Pose = Pose {
        rotation: Mat3::IDENTITY,
        translation: Vec3::ZERO,
    };

    /// The pose of a translation (mm) and Euler rotation (degrees, x then
    /// y then z), as an object's `translate_mm` and `rotate_deg`.
    pub fn from_parts(translate_mm: Vec3, rotate_deg: Vec3) -> Pose {
        Pose {
            rotation: euler_deg(rotate_deg),
            translation: translate_mm,
        }
    }

    /// `p` moved by this pose.
    pub fn apply(&self, p: Vec3) -> Vec3 {
        self.rotation * p + self.translation
    }

    /// The pose that undoes this one.
    pub fn inverse(&self) -> Pose {
        let r = self.rotation.transpose();
        Pose {
            rotation: r,
            translation: -(r * self.translation),
        }
    }

    /// This pose after `first`: `p ↦ self(first(p))`.
    pub fn after(&self, first: &Pose) -> Pose {
        Pose {
            rotation: self.rotation * first.rotation,
            translation: self.rotation * first.translation + self.translation,
        }
    }
}

/// Rotation of Euler angles in degrees about x, then y, then z (the scene
/// file's `rotate_deg`).
pub fn euler_deg(r: Vec3) -> Mat3 {
    Mat3::from_euler(
        EulerRot::ZYX,
        r.z.to_radians(),
        r.y.to_radians(),
        r.x.to_radians(),
    )
}

fn v3(t: (f32, f32, f32)) -> Vec3 {
    Vec3::new(t.0, t.1, t.2)
}

impl Motion {
    /// Checks the keys; errors name `field.keys[i].…`.
    pub fn validate(&self, field: &str) -> Result<(), SceneError> {
        if self.keys.is_empty() || self.keys.len() > MAX_KEYS {
            return Err(SceneError::field(
                format!("{field}.keys"),
                format!("must have 1 to {MAX_KEYS} keys, found {}", self.keys.len()),
            ));
        }
        let mut last = f64::NEG_INFINITY;
        for (i, k) in self.keys.iter().enumerate() {
            let f = |name: &str| format!("{field}.keys[{i}].{name}");
            if !(k.t_s.is_finite() && k.t_s.abs() <= MAX_KEY_TIME_S) {
                return Err(SceneError::field(
                    f("t_s"),
                    format!(
                        "must be finite, at most {MAX_KEY_TIME_S} s in size, found {}",
                        k.t_s
                    ),
                ));
            }
            if k.t_s <= last {
                return Err(SceneError::field(
                    f("t_s"),
                    format!(
                        "times must increase from key to key: {} follows {last}",
                        k.t_s
                    ),
                ));
            }
            last = k.t_s;
            let t = k.translate_mm;
            if ![t.0, t.1, t.2]
                .iter()
                .all(|v| v.is_finite() && v.abs() <= MAX_KEY_TRANSLATE_MM)
            {
                return Err(SceneError::field(
                    f("translate_mm"),
                    format!(
                        "({}, {}, {}): components must be finite, at most {MAX_KEY_TRANSLATE_MM} mm in size",
                        t.0, t.1, t.2
                    ),
                ));
            }
            let r = k.rotate_deg;
            if ![r.0, r.1, r.2]
                .iter()
                .all(|v| v.is_finite() && v.abs() <= 1e6)
            {
                return Err(SceneError::field(
                    f("rotate_deg"),
                    format!(
                        "({}, {}, {}): components must be finite, at most 1e6° in size",
                        r.0, r.1, r.2
                    ),
                ));
            }
        }
        Ok(())
    }

    /// The path's time for scene time `t_s`, after `repeat`, within the
    /// keys' span. Non-finite times read as the first key's.
    fn local_time(&self, t_s: f64) -> f64 {
        let (first, last) = match (self.keys.first(), self.keys.last()) {
            (Some(a), Some(b)) => (a.t_s, b.t_s),
            _ => return 0.0,
        };
        if !t_s.is_finite() || t_s <= first {
            return first;
        }
        let span = last - first;
        if t_s <= last || span <= 0.0 {
            return t_s.min(last);
        }
        let since = t_s - first;
        match self.repeat {
            Repeat::Hold => last,
            Repeat::Loop => first + since.rem_euclid(span),
            Repeat::Bounce => {
                let phase = since.rem_euclid(2.0 * span);
                first
                    + if phase <= span {
                        phase
                    } else {
                        2.0 * span - phase
                    }
            }
        }
    }

    /// Translation (mm) and rotation (degrees) at scene time `t_s`.
    pub fn sample(&self, t_s: f64) -> (Vec3, Vec3) {
        let t = self.local_time(t_s);
        let i = self.keys.partition_point(|k| k.t_s <= t);
        let (a, b) = match (
            i.checked_sub(1).and_then(|j| self.keys.get(j)),
            self.keys.get(i),
        ) {
            (Some(a), Some(b)) => (a, b),
            (Some(a), None) => return (v3(a.translate_mm), v3(a.rotate_deg)),
            (None, Some(b)) => return (v3(b.translate_mm), v3(b.rotate_deg)),
            (None, None) => return (Vec3::ZERO, Vec3::ZERO),
        };
        let u = ((t - a.t_s) / (b.t_s - a.t_s)).clamp(0.0, 1.0) as f32;
        (
            v3(a.translate_mm).lerp(v3(b.translate_mm), u),
            v3(a.rotate_deg).lerp(v3(b.rotate_deg), u),
        )
    }

    /// The path's pose at scene time `t_s`.
    pub fn pose(&self, t_s: f64) -> Pose {
        let (t, r) = self.sample(t_s);
        Pose::from_parts(t, r)
    }

    /// Largest translation component of any key, mm (bounds every pose's).
    pub fn max_translation_mm(&self) -> f32 {
        self.keys
            .iter()
            .map(|k| v3(k.translate_mm).abs().max_element())
            .fold(0.0, f32::max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn path(keys: &[(f64, f32)], repeat: Repeat) -> Motion {
        Motion {
            keys: keys
                .iter()
                .map(|&(t_s, x)| Key {
                    t_s,
                    translate_mm: (x, 0.0, 0.0),
                    rotate_deg: (0.0, 0.0, 0.0),
                })
                .collect(),
            repeat,
        }
    }

    #[test]
    fn interpolates_holds_loops_and_bounces() {
        let keys = [(1.0, 0.0), (2.0, 10.0), (3.0, 0.0)];
        let x = |m: &Motion, t: f64| m.sample(t).0.x;
        let hold = path(&keys, Repeat::Hold);
        assert_eq!(x(&hold, 0.0), 0.0);
        assert_eq!(x(&hold, 1.5), 5.0);
        assert_eq!(x(&hold, 2.0), 10.0);
        assert_eq!(x(&hold, 2.75), 2.5);
        assert_eq!(x(&hold, 99.0), 0.0);
        let keys = [(0.0, 0.0), (2.0, 10.0)];
        let looped = path(&keys, Repeat::Loop);
        assert_eq!(x(&looped, 3.0), 5.0);
        assert_eq!(x(&looped, 4.0), 0.0);
        let bounce = path(&keys, Repeat::Bounce);
        assert_eq!(x(&bounce, 3.0), 5.0);
        assert_eq!(x(&bounce, 4.0), 0.0);
        assert_eq!(x(&bounce, 5.0), 5.0);
        for m in [&hold, &looped, &bounce] {
            assert_eq!(x(m, f64::NAN), x(m, f64::NEG_INFINITY));
            assert!(x(m, f64::INFINITY).is_finite());
        }
    }

    #[test]
    fn one_key_is_a_fixed_pose() {
        for repeat in [Repeat::Hold, Repeat::Loop, Repeat::Bounce] {
            let m = path(&[(5.0, 3.0)], repeat);
            for t in [-1e9, 0.0, 5.0, 7.0, 1e9] {
                assert_eq!(m.sample(t).0.x, 3.0);
            }
        }
    }

    #[test]
    fn validation_names_the_key_and_field() {
        let err = |m: Motion| m.validate("camera").unwrap_err().to_string();
        assert!(err(path(&[], Repeat::Hold)).contains("camera.keys"));
        assert!(err(path(&[(0.0, 0.0), (0.0, 1.0)], Repeat::Hold)).contains("camera.keys[1].t_s"));
        assert!(
            err(path(&[(0.0, 0.0), (f64::NAN, 1.0)], Repeat::Hold)).contains("camera.keys[1].t_s")
        );
        assert!(err(path(&[(0.0, f32::INFINITY)], Repeat::Hold))
            .contains("camera.keys[0].translate_mm"));
        assert!(err(path(&[(0.0, 2e6)], Repeat::Hold)).contains("keys[0].translate_mm"));
    }

    #[test]
    fn pose_inverse_and_composition() {
        let p = Pose::from_parts(Vec3::new(1.0, 2.0, 3.0), Vec3::new(10.0, 20.0, 30.0));
        let q = Pose::from_parts(Vec3::new(-4.0, 0.5, 9.0), Vec3::new(0.0, 90.0, 0.0));
        let x = Vec3::new(0.3, -7.0, 2.0);
        assert!((p.inverse().apply(p.apply(x)) - x).length() < 1e-5);
        assert!((p.after(&q).apply(x) - p.apply(q.apply(x))).length() < 1e-4);
    }
}
