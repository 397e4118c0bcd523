//! Perceptual spatial imprecision (thesis 4.3.2): per facet, the
//! facet centre (eq 4.4), the saliency centre (eq 4.5, corrected), the discontinuity limit, and
//! the re-aim of the facet's rays at a new focal point, optionally as a size-keeping linear
//! facet (eq 4.6, alpha from eq 4.7).
//!
//! Positions are continuous pixel coordinates: pixel (x, y) covers [x, x+1) x [y, y+1), its
//! centre is (x + 0.5, y + 0.5), y grows downwards (row 0 at the top).
//!
//! The re-aim, generalised to every camera through each ray's focal point q (the rule for
//! converging cameras): the facet-centre ray is turned, about its origin on the camera surface,
//! towards P, the scene point seen at the saliency centre; its focal point moves by
//! delta = f_c (d_c' - d_c). Every ray of the facet is re-aimed at its own q + delta. With
//! one shared focal point (spherical, planar) that is the method's "every ray of the facet is
//! re-aimed at the new focal point"; the cylindrical camera's focal line shifts; parallel
//! rays (focus at infinity) take the limit: every direction turns by d_c' - d_c.
//!
//! `centres` decides where each facet is aimed (pixel positions), `rays` turns that into the
//! facet's rays; `aim_facets` runs both for every facet.

pub mod carried;
mod centres;
pub mod cues;
pub mod guard;
mod rays;
#[cfg(test)]
mod tests;
pub mod views;

use glam::{DVec2, DVec3};
use rayon::prelude::*;

use crate::camera::CameraRay;
use crate::facets::{FacetMap, FacetPixels};

pub use centres::{
    NEIGHBOURHOOD_BUDGET, check_neighbourhood, facet_centres, limit_discontinuity, neighbourhood_work, random_centre,
    saliency_centres, saliency_centres_with,
};
pub use rays::{AimContext, D_AI_SAMPLES, Linear, Reaim};
pub use views::Turn;

/// How each facet's view is re-aimed.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AimMode {
    /// Towards the facet's saliency centre (eq 4.5).
    Saliency,
    /// Towards a random point within the discontinuity radius (User Study I's baseline).
    Random,
    /// Not re-aimed.
    None,
}

/// The rays of a re-aimed facet.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FacetProjection {
    /// Keep converging on the facet's new focal point (discontinuity 0 = unfaceted).
    Converging,
    /// Size-keeping linear facets of eq 4.6 (orthographic at `facet_fov` 0).
    Linear,
}

/// What the imprecision stage needs besides the facets and the saliency map. Distances are
/// pixels at 1000 px, converted with `scale` (pixels of this image per such pixel).
#[derive(Clone, Debug, PartialEq)]
pub struct AimParams {
    pub mode: AimMode,
    pub projection: FacetProjection,
    /// Largest distance from facet centre to saliency centre.
    pub discontinuity: f64,
    /// Pixels outside a facet that still count for its saliency centre.
    pub neighborhood: f64,
    /// Field of view of linear facets, degrees (eq 4.7).
    pub facet_fov: f64,
    pub scale: f64,
    pub seed: u64,
    /// A facet is re-aimed only when at least this share of its pixels showed geometry in the
    /// pre-render; 0 = every facet (the thesis). See `guard`.
    pub min_coverage: f64,
    /// A re-aimed facet's view shift is kept within this share of its mean width; 0 = no
    /// limit but the discontinuity. See `guard`.
    pub width_share: f64,
    /// Degrees the subject's planes' views are turned by; 0 = not turned. See `views`.
    pub view_turn: f64,
}

impl AimParams {
    /// The neighbourhood in this image's pixels.
    pub fn neighbourhood_px(&self) -> f64 {
        self.neighborhood * self.scale
    }

    /// Whether re-aiming reads the saliency map: saliency imprecision with a discontinuity.
    pub fn reads_saliency(&self) -> bool {
        self.mode == AimMode::Saliency && self.discontinuity > 0.0
    }
}

/// What the imprecision stage decided for one facet.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FacetAim {
    /// Facet centre fc (eq 4.4); None for a facet with no pixel at this size.
    pub fc: Option<DVec2>,
    /// Saliency centre (eq 4.5 with the neighbourhood), before the discontinuity limit.
    pub sc_raw: Option<DVec2>,
    /// The point the facet is aimed at: sc after the discontinuity limit, or the random point.
    pub sc: Option<DVec2>,
    /// P, the scene point seen at `sc`, when the facet was re-aimed at one.
    pub target: Option<DVec3>,
    pub reaim: Option<Reaim>,
    pub linear: Option<Linear>,
    /// The facet's view turned to another side of the subject (`views`).
    pub turn: Option<Turn>,
}

impl FacetAim {
    /// Whether the facet's rays differ from the pre-render's (its pixels must be re-traced).
    pub fn moved(&self) -> bool {
        self.reaim.is_some() || self.linear.is_some() || self.turn.is_some()
    }

    /// The facet's version of a camera ray at pixel position `px`: re-aimed, made linear, then
    /// turned.
    pub fn apply(&self, ray: CameraRay, px: DVec2, clip_radius: f64) -> CameraRay {
        let r = self.reaim.map_or(ray, |a| a.apply(&ray, clip_radius));
        let r = self.linear.map_or(r, |l| l.apply(&r, px, clip_radius));
        self.turn.map_or(r, |t| t.apply(&r, clip_radius))
    }
}

/// Facet and saliency centres without any re-aim (the `facets` pass of a render whose
/// imprecision stage did not run). `neighbourhood` in this image's pixels.
pub fn centres_only(map: &FacetMap, saliency: Option<&[f32]>, neighbourhood: f64) -> Vec<FacetAim> {
    let fc = facet_centres(map);
    let sc = match saliency {
        Some(s) => saliency_centres(map, s, &fc, neighbourhood),
        None => fc.clone(),
    };
    fc.iter()
        .zip(&sc)
        .map(|(&fc, &sc_raw)| FacetAim { fc, sc_raw, sc: fc, target: None, reaim: None, linear: None, turn: None })
        .collect()
}

/// Whether the imprecision stage changes any ray: re-aiming needs a discontinuity and an
/// imprecision mode; linear facets and turned views (`view_turn`) change rays even at
/// discontinuity 0.
pub fn changes_rays(params: &AimParams) -> bool {
    params.projection == FacetProjection::Linear
        || (params.mode != AimMode::None && params.discontinuity > 0.0)
        || params.view_turn > 0.0
}

/// Decides every facet's aim: centres, the discontinuity limit (pixels at 1000 px, scaled to
/// this image), the re-aim and the linear facet. `saliency` None counts as zero saliency.
pub fn aim_facets(ctx: &AimContext, map: &FacetMap, saliency: Option<&[f32]>, params: &AimParams) -> Vec<FacetAim> {
    aim_facets_with(ctx, map, &map.facet_pixels(), saliency, params)
}

/// `aim_facets` with the facets' pixels (`FacetMap::facet_pixels`) made already: the
/// imprecision stage makes them once for the centres, the linear facets and the rules of
/// `guard::apply`.
pub fn aim_facets_with(
    ctx: &AimContext,
    map: &FacetMap,
    by_facet: &FacetPixels,
    saliency: Option<&[f32]>,
    params: &AimParams,
) -> Vec<FacetAim> {
    let scale = params.scale;
    let radius = params.discontinuity * scale;
    let fc = facet_centres(map);
    let sc_raw: Vec<Option<DVec2>> = match (params.mode, saliency) {
        (AimMode::Saliency, Some(s)) => saliency_centres_with(map, by_facet, s, &fc, params.neighborhood * scale),
        _ => fc.clone(),
    };
    let sc: Vec<Option<DVec2>> = match params.mode {
        _ if radius <= 0.0 => fc.clone(),
        AimMode::None => fc.clone(),
        AimMode::Saliency => {
            sc_raw.iter().zip(&fc).map(|(s, c)| Some(limit_discontinuity((*c)?, (*s)?, radius))).collect()
        }
        AimMode::Random => {
            fc.iter().enumerate().map(|(f, c)| c.map(|c| random_centre(c, radius, params.seed, f as u32))).collect()
        }
    };
    let linear = params.projection == FacetProjection::Linear;
    (0..map.facet_count as usize)
        .into_par_iter()
        .map(|f| {
            let mut aim = FacetAim {
                fc: fc[f],
                sc_raw: sc_raw[f],
                sc: sc[f],
                target: None,
                reaim: None,
                linear: None,
                turn: None,
            };
            let (Some(c), Some(s)) = (fc[f], sc[f]) else { return aim };
            if s != c
                && let Some((r, p)) = ctx.reaim(c, s)
            {
                if r.turn.length() > ctx.negligible_turn(c) {
                    aim.reaim = Some(r);
                }
                aim.target = p;
            }
            if linear {
                aim.linear = ctx.linear(c, aim.reaim.as_ref(), by_facet.of(f), params.facet_fov);
            }
            aim
        })
        .collect()
}
