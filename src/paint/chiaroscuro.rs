//! Chiaroscuro (thesis Ch. 2: "in order to increase the effect of disharmony between different
//! view projections, chiaroscuro - use of light and shadow - is also manipulated"): every facet
//! is relit as if the lights had been turned and dimmed or brightened for it alone.
//!
//! The turn matches the per-plane light (`plane_light`, "Each plane has its own
//! light"): each facet's lights turn about the view axis until the key light comes from the
//! side its plane is lit from (`planes::Plane::light_side`; the key seen from the camera
//! comes from `planes::KEY`), by `amount` of that turn, so the relit shading and the ramp
//! across the plane tell the same story. The gain varies within 1 +- `amount` x 0.4.
//!
//! Ratio relighting: a pixel's colour is albedo x (ambient + sum of radiance x max(0, n.l))
//! times its shadowing; the pixel's foreground colour is multiplied, per channel, by
//! (ambient + g_f sum radiance max(0, n.R_f l)) / (ambient + sum radiance max(0, n.l)),
//! n being the pixel's shading normal. The albedo cancels, so textures, anti-aliasing and the
//! shadows already rendered survive (the shadow factor is kept, not recast), and no ray is
//! traced. Highlights scale with the diffuse term. Unlit materials keep their colour.

use glam::{Quat, Vec2, Vec3};
use rayon::prelude::*;

use super::planes::{KEY, Plane};
use super::{Canvas, Effect, EffectParams, PaintContext};
use crate::error::{Error, Result};
use crate::shading::RigLight;
use crate::util::rng::{splitmix64, sub_seed, unit_f64};

/// Chiaroscuro's parameters: the per-facet variation of light direction and intensity, in
/// [0, 1] (0 = off).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ChiaroscuroParams {
    pub amount: f64,
    pub seed: u64,
}

impl EffectParams for ChiaroscuroParams {
    fn is_on(&self) -> bool {
        self.amount > 0.0
    }

    fn build(&self) -> Result<Box<dyn Effect>> {
        Ok(Box::new(Chiaroscuro::new(self.amount as f32, self.seed)))
    }
}

const SALT: u64 = 0x6368_6961_726f_7363; // "chiarosc"
/// Largest relative change of a facet's light intensity at amount 1.
pub const MAX_GAIN: f32 = 0.4;

/// The camera's axes in world space: the picture's right and up, and the view direction.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ViewAxes {
    pub right: Vec3,
    pub up: Vec3,
    pub forward: Vec3,
}

impl ViewAxes {
    /// The world direction of image direction `d` (x right, y down) in the picture plane.
    pub fn world(&self, d: Vec2) -> Vec3 {
        self.right * d.x - self.up * d.y
    }
}

/// Per-facet relighting.
pub struct Chiaroscuro {
    /// In [0, 1].
    pub amount: f32,
    /// The planes' seed (the render's): the same planes as the per-plane light.
    pub seed: u64,
}

impl Chiaroscuro {
    pub fn new(amount: f32, seed: u64) -> Chiaroscuro {
        Chiaroscuro { amount, seed }
    }

    /// The rotation and gain of facet `f`'s lights: about the view axis, `amount` of the
    /// turn taking the key's side (`KEY`) to the plane's light side; a gain in
    /// 1 +- amount x MAX_GAIN.
    pub fn facet_light(&self, plane: &Plane, f: u32, view: &ViewAxes) -> (Quat, f32) {
        let (from, to) = (view.world(KEY).normalize_or_zero(), view.world(plane.light_side()).normalize_or_zero());
        // About the view axis (both directions lie in the picture plane), by `amount` of the
        // angle between them.
        let turn = if from == Vec3::ZERO || to == Vec3::ZERO {
            Quat::IDENTITY
        } else {
            let axis = from.cross(to).try_normalize().unwrap_or(view.forward.normalize_or(Vec3::Z));
            Quat::from_axis_angle(axis, self.amount * from.angle_between(to))
        };
        let h = splitmix64(sub_seed(self.seed, SALT) ^ splitmix64(f as u64));
        let gain = 1.0 + self.amount * MAX_GAIN * (2.0 * unit_f64(h) as f32 - 1.0);
        (turn, gain)
    }
}

/// Direction to the light and the radiance arriving at `position`, as `shading::shade` uses.
fn incident(light: &RigLight, position: Vec3) -> (Vec3, Vec3) {
    match *light {
        RigLight::Directional { to_light, radiance } => (to_light, radiance),
        RigLight::Point { position: lp, intensity } => {
            let d = lp - position;
            let len2 = d.length_squared().max(1e-8);
            (d / len2.sqrt(), intensity / len2)
        }
        RigLight::Spot { position: lp, direction, cos_inner, cos_outer, intensity } => {
            let d = lp - position;
            let len2 = d.length_squared().max(1e-8);
            let l = d / len2.sqrt();
            let fall = (((-l).dot(direction) - cos_outer) / (cos_inner - cos_outer).max(1e-6)).clamp(0.0, 1.0);
            (l, intensity * (fall * fall) / len2)
        }
    }
}

/// Largest factor a pixel may be brightened by.
const MAX_RATIO: f32 = 4.0;

impl Effect for Chiaroscuro {
    fn name(&self) -> &'static str {
        "chiaroscuro"
    }

    fn reads_hits(&self) -> bool {
        true
    }

    fn apply(&self, canvas: &mut Canvas<'_>, ctx: &PaintContext) -> Result<()> {
        let Some(lighting) = ctx.lighting else {
            return Err(Error::Internal("chiaroscuro: relighting needs the scene's lights; none were given".into()));
        };
        let (world, rig) = (lighting.world, lighting.rig);
        // The planes the per-plane light ramps (one plane without a facet map).
        let planes = ctx.planes(canvas.width, canvas.pixel_count(), self.seed);
        // Per facet: the rotation, the gain and the rotated directions of directional lights
        // (the other lights' directions depend on the pixel).
        let facets: Vec<(Quat, f32, Vec<Vec3>)> = (0..ctx.facet_count() as u32)
            .map(|f| {
                let (q, gain) = self.facet_light(&planes[f as usize], f, &lighting.view);
                let dirs = rig
                    .lights
                    .iter()
                    .map(|l| match l {
                        RigLight::Directional { to_light, .. } => q * *to_light,
                        _ => Vec3::ZERO,
                    })
                    .collect();
                (q, gain, dirs)
            })
            .collect();
        let unlit: Vec<bool> = world.objects.iter().map(|o| world.materials[o.material].unlit).collect();
        let (bg, transparent) = (canvas.background, canvas.transparent);
        let ambient = Vec3::splat(rig.ambient);
        let (coverage, px) = canvas.coverage_and_pixels();
        px.par_iter_mut().enumerate().for_each(|(i, p)| {
            let hit = &ctx.hits[i];
            let c = coverage.of(i, p);
            if !hit.is_hit() || c <= 0.0 || unlit[hit.object as usize] {
                return;
            }
            let (rotation, gain, dirs) = &facets[ctx.facet(i) as usize];
            let n = hit.normal;
            let (mut before, mut after) = (ambient, Vec3::ZERO);
            for (l, rotated) in rig.lights.iter().zip(dirs) {
                match l {
                    RigLight::Directional { to_light, radiance } => {
                        before += *radiance * n.dot(*to_light).max(0.0);
                        after += *radiance * n.dot(*rotated).max(0.0);
                    }
                    _ => {
                        let position = world.point_at(hit.tri, hit.u, hit.v);
                        let (to_light, radiance) = incident(l, position);
                        before += radiance * n.dot(to_light).max(0.0);
                        after += radiance * n.dot(*rotation * to_light).max(0.0);
                    }
                }
            }
            let after = ambient + after * *gain;
            let ratio =
                Vec3::select(before.cmpgt(Vec3::splat(1e-6)), after / before, Vec3::ONE).min(Vec3::splat(MAX_RATIO));
            if transparent {
                *p = (p.truncate() * ratio).extend(p.w);
            } else {
                let back = bg * (1.0 - c);
                *p = (((p.truncate() - back).max(Vec3::ZERO) * ratio) + back).extend(p.w);
            }
        });
        Ok(())
    }
}
