//! Blinn–Phong shading from an (interpolated) normal.

use glam::Vec3;

use crate::scene::{Light, Scene};

const AMBIENT: f32 = 0.08;

/// Linear colour of a surface point of `object` at `position` with normal
/// `normal`, seen from `eye`.
pub fn shade(scene: &Scene, object: u32, position: Vec3, normal: Vec3, eye: Vec3) -> Vec3 {
    let m = &scene.object_materials[object as usize];
    let diffuse = Vec3::new(m.diffuse.0, m.diffuse.1, m.diffuse.2);
    let specular = Vec3::new(m.specular.0, m.specular.1, m.specular.2);
    let v = (eye - position).try_normalize().unwrap_or(Vec3::Z);
    // Two-sided: light the side facing the eye.
    let n = if normal.dot(v) < 0.0 { -normal } else { normal };
    let mut c = diffuse * AMBIENT;
    for light in &scene.lights {
        let (l, intensity) = match *light {
            Light::Headlight { intensity } => (v, intensity),
            Light::Point {
                position_mm: p,
                intensity,
            } => (
                (Vec3::new(p.0, p.1, p.2) - position)
                    .try_normalize()
                    .unwrap_or(v),
                intensity,
            ),
            Light::Directional {
                direction: d,
                intensity,
            } => (
                (-Vec3::new(d.0, d.1, d.2)).try_normalize().unwrap_or(v),
                intensity,
            ),
        };
        let ndl = n.dot(l).max(0.0);
        if ndl > 0.0 {
            let h = (l + v).try_normalize().unwrap_or(n);
            c += intensity
                * (diffuse * ndl + specular * specular_power(n.dot(h).max(0.0), m.shininess));
        }
    }
    c
}

/// `x^shininess` for the specular lobe (`x` in [0, 1]): by repeated
/// multiplication (`powi`) for a whole exponent up to 1024 — every shipped
/// material's, and about four times cheaper per pixel than `powf`, within a
/// few ulps of it — else `powf`.
#[inline]
fn specular_power(x: f32, shininess: f32) -> f32 {
    if shininess == shininess.trunc() && (0.0..=1024.0).contains(&shininess) {
        x.powi(shininess as i32)
    } else {
        x.powf(shininess)
    }
}

/// Entries of the gamma table over linear [0, 1].
const GAMMA_STEPS: usize = 4096;

fn gamma_table() -> &'static [u8; GAMMA_STEPS + 1] {
    static TABLE: std::sync::OnceLock<[u8; GAMMA_STEPS + 1]> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        let mut t = [0u8; GAMMA_STEPS + 1];
        for (i, v) in t.iter_mut().enumerate() {
            *v = ((i as f32 / GAMMA_STEPS as f32).powf(1.0 / 2.2) * 255.0 + 0.5) as u8;
        }
        t
    })
}

/// Linear colour to 8-bit (gamma 2.2), clamped; a table lookup, not `powf`.
pub fn to_rgb8(c: Vec3) -> [u8; 3] {
    let t = gamma_table();
    let g = |x: f32| t[(x.clamp(0.0, 1.0) * GAMMA_STEPS as f32 + 0.5) as usize];
    [g(c.x), g(c.y), g(c.z)]
}

/// Linear colour seen along the ray from `origin` in direction `dir`
/// (world mm), shaded exactly as the CPU renderer shades a primary ray
/// whose eye is `origin`: the scene's background on a miss, else [`shade`]
/// at the closest hit (`t > 0`) with its interpolated normal, viewed from
/// `origin`. For distributed (thin-lens) references.
pub fn ray_colour(
    scene: &Scene,
    origin: [f32; 3],
    dir: [f32; 3],
    test: crate::ray::TriangleTest,
) -> [f32; 3] {
    let o = Vec3::from_array(origin);
    let ray = crate::ray::Ray::new(o, Vec3::from_array(dir));
    let c = match scene.intersect(&ray, 0.0, test) {
        None => scene.background,
        Some(h) => shade(scene, h.object, ray.at(h.t), h.normal, o),
    };
    c.to_array()
}

/// [`to_rgb8`] for a colour given as an array.
pub fn to_rgb8_array(c: [f32; 3]) -> [u8; 3] {
    to_rgb8(Vec3::from_array(c))
}
