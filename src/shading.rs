//! Lights and materials to colour: Lambert plus a Blinn-Phong highlight from the scene's
//! lights (a camera-relative key, fill and rim when it has none), optional shadow rays.
//!
//! Light units differ wildly between files (lux, candela, Blender's watts), so the rig is
//! normalised once per render by the irradiance all lights deliver at the scene's centre:
//! any file looks correctly exposed, and the exposure never depends on the image (no
//! flicker between animation frames).

use glam::{Vec2, Vec3, Vec4};

use crate::accel::{Accel, Hit};
use crate::camera::CameraFrame;
use crate::scene::{LightKind, World};

/// Ambient term, so surfaces facing away from every light keep their colour's identity.
const AMBIENT: f32 = 0.14;
/// Shadow ray offset along the geometric normal, render units (the scene radius is ~1).
pub const SURFACE_EPSILON: f32 = 2e-4;

#[derive(Clone, Debug, PartialEq)]
pub enum RigLight {
    /// `to_light`: unit vector towards the light.
    Directional {
        to_light: Vec3,
        radiance: Vec3,
    },
    Point {
        position: Vec3,
        intensity: Vec3,
    },
    Spot {
        position: Vec3,
        direction: Vec3,
        cos_inner: f32,
        cos_outer: f32,
        intensity: Vec3,
    },
}

/// The lights of one render, exposure applied.
#[derive(Clone, Debug)]
pub struct LightRig {
    pub lights: Vec<RigLight>,
    pub ambient: f32,
    pub shadows: bool,
}

impl LightRig {
    /// The scene's lights, or a key/fill/rim rig around the camera when it has none.
    pub fn new(world: &World, view: &CameraFrame, shadows: bool, exposure: f32) -> LightRig {
        let mut lights: Vec<RigLight> = world
            .lights
            .iter()
            .map(|l| {
                let c = l.color * l.intensity;
                match l.kind {
                    LightKind::Directional => RigLight::Directional { to_light: -l.direction, radiance: c },
                    LightKind::Point => RigLight::Point { position: l.position, intensity: c },
                    LightKind::Spot { inner, outer } => RigLight::Spot {
                        position: l.position,
                        direction: l.direction,
                        cos_inner: inner.cos(),
                        cos_outer: outer.cos(),
                        intensity: c,
                    },
                }
            })
            .collect();
        if lights.is_empty() {
            let (f, u, r) = (view.forward.as_vec3(), view.up.as_vec3(), view.right.as_vec3());
            let dir = |v: Vec3| v.try_normalize().unwrap_or(Vec3::Y);
            lights = vec![
                RigLight::Directional {
                    to_light: dir(-0.55 * f + 0.7 * u - 0.45 * r),
                    radiance: Vec3::new(1.0, 0.96, 0.88),
                },
                RigLight::Directional {
                    to_light: dir(-0.5 * f + 0.1 * u + 0.85 * r),
                    radiance: Vec3::new(0.30, 0.32, 0.36),
                },
                RigLight::Directional { to_light: dir(0.75 * f + 0.55 * u + 0.2 * r), radiance: Vec3::splat(0.25) },
            ];
        }
        // Normalise by the total irradiance at the scene's centre (render-space origin),
        // each light taken at normal incidence; point lights no closer than 0.1 radius.
        let total: f32 = lights
            .iter()
            .map(|l| match l {
                RigLight::Directional { radiance, .. } => luminance(*radiance),
                RigLight::Point { position, intensity } | RigLight::Spot { position, intensity, .. } => {
                    luminance(*intensity) / position.length_squared().max(0.01)
                }
            })
            .sum();
        let scale = if total > 0.0 && total.is_finite() { 1.05 / total * exposure } else { 0.0 };
        for l in &mut lights {
            match l {
                RigLight::Directional { radiance, .. } => *radiance *= scale,
                RigLight::Point { intensity, .. } | RigLight::Spot { intensity, .. } => *intensity *= scale,
            }
        }
        LightRig { lights, ambient: AMBIENT * exposure.min(1.0), shadows }
    }
}

pub fn luminance(c: Vec3) -> f32 {
    c.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}

/// What shading needs to know about a hit, derived from the world once.
pub struct SurfacePoint {
    pub position: Vec3,
    /// Unit geometric normal facing the incoming ray.
    pub geometric: Vec3,
    /// Unit shading normal facing the incoming ray.
    pub normal: Vec3,
    pub albedo: Vec4,
    pub roughness: f32,
    pub unlit: bool,
}

/// Interpolates the hit's attributes and looks up its material and texture. Vertex data is
/// read in the geometry's base space; normals of a placed instance are carried to render
/// space by its normal matrix (an object its geometry is baked for reads them as they are).
pub fn surface(world: &World, hit: &Hit, origin: Vec3, dir: Vec3) -> SurfacePoint {
    let object = &world.objects[hit.object as usize];
    let g = &world.geometries[object.geometry];
    let local = hit.tri - object.first_triangle;
    let [i0, i1, i2] = g.triangles[local as usize].map(|i| i as usize);
    let w = Vec3::new(1.0 - hit.u - hit.v, hit.u, hit.v);
    let position = origin + dir * hit.t;
    let (geometric, normal) = normals(object, g, [i0, i1, i2], w, dir);
    let material = &world.materials[object.material];
    let mut albedo = material.base_color;
    if let Some(tex) = material.base_color_texture {
        let uv = match &g.uvs {
            Some(uv) => uv[i0] * w.x + uv[i1] * w.y + uv[i2] * w.z,
            None => Vec2::ZERO,
        };
        let m = tex.uv_transform;
        let uv = Vec2::new(m[0] * uv.x + m[1] * uv.y + m[2], m[3] * uv.x + m[4] * uv.y + m[5]);
        if let Some(t) = world.textures.get(tex.texture) {
            albedo *= t.sample(uv);
        }
    }
    if let Some(c) = &g.colors {
        // A backdrop run on past its edge (`trace::run_on`) has weights outside the
        // triangle: its colours are held at the triangle's (a texture runs on, by its wrap).
        let w = if w.min_element() < 0.0 {
            w.max(Vec3::ZERO) / w.max(Vec3::ZERO).element_sum().max(f32::MIN_POSITIVE)
        } else {
            w
        };
        albedo *= c[i0] * w.x + c[i1] * w.y + c[i2] * w.z;
    }
    SurfacePoint { position, geometric, normal, albedo, roughness: material.roughness, unlit: material.unlit }
}

/// A hit's unit shading normal facing the incoming ray, as `surface` gives it, without the
/// material: all a trace with no lights keeps of the surface.
pub fn shading_normal(world: &World, hit: &Hit, dir: Vec3) -> Vec3 {
    let object = &world.objects[hit.object as usize];
    let g = &world.geometries[object.geometry];
    let local = hit.tri - object.first_triangle;
    let corners = g.triangles[local as usize].map(|i| i as usize);
    normals(object, g, corners, Vec3::new(1.0 - hit.u - hit.v, hit.u, hit.v), dir).1
}

/// The unit geometric and shading normals at barycentric weights `w` of the triangle with
/// vertices `[i0, i1, i2]` of `g` as `object` places it, both facing the ray `dir`.
#[inline(always)]
fn normals(
    object: &crate::scene::world::WorldObject,
    g: &crate::scene::world::Geometry,
    [i0, i1, i2]: [usize; 3],
    w: Vec3,
    dir: Vec3,
) -> (Vec3, Vec3) {
    let (p0, p1, p2) = (g.positions[i0], g.positions[i1], g.positions[i2]);
    let mut geometric = object.normal((p1 - p0).cross(p2 - p0)).try_normalize().unwrap_or(-dir);
    if geometric.dot(dir) > 0.0 {
        geometric = -geometric;
    }
    let (n0, n1, n2) = (g.normals[i0], g.normals[i1], g.normals[i2]);
    let mut normal = object.normal(n0 * w.x + n1 * w.y + n2 * w.z).try_normalize().unwrap_or(geometric);
    if normal.dot(geometric) < 0.0 {
        normal = -normal;
    }
    (geometric, normal)
}

/// Radiance towards the viewer (linear RGB).
pub fn shade(accel: &Accel, rig: &LightRig, s: &SurfacePoint, view_dir: Vec3) -> Vec3 {
    shade_with(accel, rig, s, view_dir, Occlusion::TRACE).0
}

/// What a shading already knows about the lights' occlusion, one bit per light (the first
/// `Occlusion::LIGHTS`): the lights whose shadow ray need not be cast (`known`) and, of
/// those, the ones that are blocked (`blocked`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Occlusion {
    pub known: u8,
    pub blocked: u8,
}

impl Occlusion {
    /// Lights that have a bit; shadow rays to any further light are always cast.
    pub const LIGHTS: usize = 8;
    /// Nothing known: every shadow ray is cast.
    pub const TRACE: Occlusion = Occlusion { known: 0, blocked: 0 };
}

/// `shade`, skipping the shadow rays `occlusion` already answers (the adaptive sampler knows a
/// light is wholly visible or wholly blocked across a pixel whose neighbours agree). Also
/// returns which of the first `Occlusion::LIGHTS` lights were blocked (known or traced; a
/// light facing away counts as not blocked).
pub fn shade_with(accel: &Accel, rig: &LightRig, s: &SurfacePoint, view_dir: Vec3, occlusion: Occlusion) -> (Vec3, u8) {
    let albedo = s.albedo.truncate();
    let mut blocked_bits = 0u8;
    if s.unlit {
        return (albedo, 0);
    }
    let to_eye = -view_dir;
    let shininess = 2.0 / (s.roughness * s.roughness).max(1e-3) - 2.0;
    let spec_weight = 0.25 * (1.0 - s.roughness);
    let origin = s.position + s.geometric * SURFACE_EPSILON;
    let mut c = albedo * rig.ambient;
    for (index, l) in rig.lights.iter().enumerate() {
        let (to_light, dist, radiance) = match *l {
            RigLight::Directional { to_light, radiance } => (to_light, f32::INFINITY, radiance),
            RigLight::Point { position, intensity } => {
                let d = position - s.position;
                let len2 = d.length_squared().max(1e-8);
                (d / len2.sqrt(), len2.sqrt(), intensity / len2)
            }
            RigLight::Spot { position, direction, cos_inner, cos_outer, intensity } => {
                let d = position - s.position;
                let len2 = d.length_squared().max(1e-8);
                let l = d / len2.sqrt();
                let cd = (-l).dot(direction);
                let fall = ((cd - cos_outer) / (cos_inner - cos_outer).max(1e-6)).clamp(0.0, 1.0);
                (l, len2.sqrt(), intensity * (fall * fall) / len2)
            }
        };
        let ndl = s.normal.dot(to_light);
        if ndl <= 0.0 || s.geometric.dot(to_light) <= 0.0 {
            continue;
        }
        if rig.shadows {
            let bit = if index < Occlusion::LIGHTS { 1u8 << index } else { 0 };
            let blocked = if occlusion.known & bit != 0 {
                occlusion.blocked & bit != 0
            } else {
                accel.occluded(origin, to_light, 0.0, dist * (1.0 - 1e-4))
            };
            if blocked {
                blocked_bits |= bit;
                continue;
            }
        }
        let h = (to_light + to_eye).try_normalize().unwrap_or(s.normal);
        let spec = spec_weight * s.normal.dot(h).max(0.0).powf(shininess) * (shininess + 8.0) / 8.0;
        c += radiance * (albedo * ndl + Vec3::splat(spec * ndl));
    }
    (if c.is_finite() { c } else { Vec3::ZERO }, blocked_bits)
}
