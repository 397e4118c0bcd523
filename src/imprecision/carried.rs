//! Aims carried with the scene (`--facet-motion follow`): a key frame's facet
//! aims anchored to the surface points they show, and carried to any later frame in one step,
//! so a facet that follows the subject keeps its view instead of being re-aimed from the pixels
//! it covers in each frame (which shifts its view as its outline changes: flicker).

use glam::{DVec2, DVec3, Vec3};
use rayon::prelude::*;

use super::{AimContext, AimParams, FacetAim, FacetProjection};
use crate::facets::FacetMap;

/// A point of the scene's surface named by its triangle and barycentrics: the same point of
/// the subject in every pose (its position follows the triangle's corners).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Anchor {
    pub tri: u32,
    pub u: f32,
    pub v: f32,
}

impl Anchor {
    /// The point the ray at pixel position `px` of `ctx`'s camera hits, if any.
    pub fn seen_at(ctx: &AimContext, px: DVec2) -> Option<Anchor> {
        let r = ctx.ray_at(px);
        ctx.accel.closest(r.origin, r.dir, 0.0, f32::INFINITY).map(|h| Anchor { tri: h.tri, u: h.u, v: h.v })
    }

    /// Where the point is when its triangle's corners are `corners`.
    pub fn at(&self, corners: &[Vec3; 3]) -> DVec3 {
        (corners[0] * (1.0 - self.u - self.v) + corners[1] * self.u + corners[2] * self.v).as_dvec3()
    }
}

/// One facet's aim at the key frame, anchored to the surface: the points its facet centre and
/// its aim point showed there (None: the backdrop, or no aim).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KeyAim {
    pub aim: FacetAim,
    pub centre: Option<Anchor>,
    pub target: Option<Anchor>,
}

/// The key frame's aims (decided from the key frame's picture), anchored to the
/// points they show (`ctx`: the key frame's camera and scene).
pub fn anchor_aims(ctx: &AimContext, aims: &[FacetAim]) -> Vec<KeyAim> {
    aims.par_iter()
        .map(|aim| KeyAim {
            aim: *aim,
            centre: aim.fc.and_then(|c| Anchor::seen_at(ctx, c)),
            target: aim.sc.filter(|_| aim.moved()).and_then(|s| Anchor::seen_at(ctx, s)),
        })
        .collect()
}

/// Facets that follow keep their view: each facet of frame N takes the key
/// frame's aim carried with the scene, instead of one decided again from the pixels it covers
/// now (which shifts its view as its outline changes: flicker). Its centre is where the surface
/// point its key-frame centre showed is now (`ctx.camera.project` of the anchor posed by
/// `corners`), and it is re-aimed at where its key-frame aim point is now: the same scene point
/// at the centre of its view in every frame. What the key frame did not anchor (a centre or aim
/// point on the backdrop, or out of view now) falls back to the facet's centre in `map` and the
/// key frame's aim offset in pixels. The discontinuity limit (`params`) holds in every frame; a
/// facet the key frame did not re-aim (held on the backdrop, or not moved) is not re-aimed. A
/// facet the key frame turned (`views`) turns by the same angle about the same surface point.
/// Frame N's aims are a function of the key frame's and frame N's scene alone: farm chunks agree.
pub fn carry_aims(
    ctx: &AimContext,
    key: &[KeyAim],
    map: &FacetMap,
    corners: &(dyn Fn(u32) -> Option<[Vec3; 3]> + Sync),
    params: &AimParams,
) -> Vec<FacetAim> {
    let fc_now = super::facet_centres(map);
    let radius = params.discontinuity * params.scale;
    let linear = params.projection == FacetProjection::Linear;
    let by_facet = if linear { map.facet_pixels() } else { Default::default() };
    let (w, h) = (ctx.width as f64, ctx.height as f64);
    let now = |a: Option<Anchor>| -> Option<(DVec2, DVec3)> {
        let a = a?;
        let p = a.at(&corners(a.tri)?);
        let seen = ctx.camera.project(p)?;
        seen.in_view().then(|| (ctx.pixel_pos(seen.screen), p))
    };
    (0..map.facet_count as usize)
        .into_par_iter()
        .map(|f| {
            let mut aim = FacetAim {
                fc: fc_now[f],
                sc_raw: fc_now[f],
                sc: fc_now[f],
                target: None,
                reaim: None,
                linear: None,
                turn: None,
            };
            let (Some(k), Some(fallback)) = (key.get(f), fc_now[f]) else { return aim };
            let c = now(k.centre).map_or(fallback, |(c, _)| c.clamp(DVec2::ZERO, DVec2::new(w, h)));
            (aim.fc, aim.sc_raw, aim.sc) = (Some(c), Some(c), Some(c));
            if let (Some(_), Some(kc), Some(ks)) = (k.aim.reaim, k.aim.fc, k.aim.sc) {
                let target = now(k.target);
                let s = target.map_or(c + (ks - kc), |(s, _)| s);
                let limited = super::limit_discontinuity(c, s, radius);
                (aim.sc_raw, aim.sc) = (Some(s), Some(limited));
                let turned = match target {
                    // Aimed at the very point the key frame's facet showed at its aim point.
                    Some((_, p)) if limited == s => ctx.reaim_towards(c, p).map(|r| (r, Some(p))),
                    // Aimed at the point seen there now (as `imprecision::aim_facets`).
                    _ => ctx.reaim(c, limited),
                };
                if let Some((r, p)) = turned {
                    if r.turn.length() > ctx.negligible_turn(c) {
                        aim.reaim = Some(r);
                    }
                    aim.target = p;
                }
            }
            if linear && k.aim.linear.is_some() {
                aim.linear = ctx.linear(c, aim.reaim.as_ref(), by_facet.of(f), params.facet_fov);
            }
            // Turned about the same point of the subject, by the same angle, about this frame's up
            // (the key frame's decision, not checked again: the facet keeps its view).
            if let Some(t) = k.aim.turn
                && let Some(at) = corners(t.anchor.tri)
                && let Some(axis) = ctx.up.try_normalize()
            {
                aim.turn = Some(super::Turn { pivot: t.anchor.at(&at), axis, ..t });
            }
            aim
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use glam::DQuat;

    use super::*;
    use crate::camera::{Camera, Moved};
    use crate::imprecision::aim_facets;
    use crate::imprecision::tests::Grid;
    use crate::pipeline::Shading;

    /// The default still life's aims on a grid of 48 facets (random aim points within 30
    /// pixels: no saliency map needed), anchored, then carried to the same camera (the key
    /// frame's aims again) and to the camera turned by 4 degrees about the vertical axis (a
    /// turntable step: each facet keeps aiming at the scene point it aimed at).
    #[test]
    fn carried_aims_keep_the_key_frames_view() {
        let grid = Grid::new(Shading::HitsOnly);
        let (prep, pre, map, clip_radius) = (&grid.prep, &grid.pre, &grid.map, grid.clip_radius);
        let camera = pre.view.framed.camera.as_ref();
        let key_ctx = grid.ctx();
        let aim = grid.random_aims(30.0);
        let key = aim_facets(&key_ctx, map, None, &aim);
        let anchors = anchor_aims(&key_ctx, &key);
        let corners = |t: u32| Some(prep.world.triangle(t));
        let anchored = anchors.iter().filter(|k| k.aim.moved() && k.centre.is_some() && k.target.is_some()).count();
        assert!(anchored >= 4, "only {anchored} facets re-aimed at the still life");

        // At the key frame itself: the key frame's aims, to rounding.
        let same = carry_aims(&key_ctx, &anchors, map, &corners, &aim);
        for (k, c) in anchors.iter().zip(&same) {
            if !(k.aim.moved() && k.centre.is_some() && k.target.is_some()) {
                continue;
            }
            assert!((c.fc.unwrap() - k.aim.fc.unwrap()).length() < 1e-3, "{c:?} against {k:?}");
            assert!((c.sc.unwrap() - k.aim.sc.unwrap()).length() < 1e-3, "{c:?} against {k:?}");
            let (a, b) = (c.reaim.unwrap().turn, k.aim.reaim.unwrap().turn);
            assert!((a - b).length() < 1e-4 * b.length().max(1e-3), "{a} against {b}");
        }

        // A turntable step: each anchored facet is centred where its key centre point went,
        // and its centre ray passes through its key aim point (the scene does not move).
        let up = pre.view.framed.frame.up;
        let turned = Moved {
            inner: camera,
            rotation: DQuat::from_axis_angle(up, 4f64.to_radians()),
            translation: DVec3::ZERO,
            clip_radius,
        };
        let ctx = AimContext { camera: &turned, ..key_ctx };
        let carried = carry_aims(&ctx, &anchors, map, &corners, &aim);
        let mut checked = 0;
        for (k, c) in anchors.iter().zip(&carried) {
            let (Some(centre), Some(target)) = (k.centre, k.target) else { continue };
            if !k.aim.moved() {
                continue;
            }
            let p = target.at(&prep.world.triangle(target.tri));
            let Some(seen) = turned.project(centre.at(&prep.world.triangle(centre.tri))) else { continue };
            if !seen.in_view() || c.target != Some(p) {
                continue;
            }
            assert!((c.fc.unwrap() - ctx.pixel_pos(seen.screen)).length() < 1e-6);
            let ray = c.reaim.unwrap().apply(&ctx.ray_at(c.fc.unwrap()), clip_radius);
            let to_p = (p - ray.surface_origin()).normalize();
            assert!(to_p.dot(ray.dir.as_dvec3()) > 1.0 - 1e-6, "facet centre ray misses its aim point: {c:?}");
            checked += 1;
        }
        assert!(checked >= 4, "only {checked} facets kept their aim point in view");
        // The view changed: carried centres moved with the subject.
        assert!(
            anchors
                .iter()
                .zip(&carried)
                .any(|(k, c)| k.centre.is_some() && (c.fc.unwrap() - k.aim.fc.unwrap()).length() > 1.0)
        );
    }

    /// A facet the key frame turned (`views`) turns by the same angle about the same surface
    /// point in every frame, about that frame's up.
    #[test]
    fn carried_turns_keep_their_pivot_and_angle() {
        let grid = Grid::new(Shading::HitsOnly);
        let (prep, pre, map) = (&grid.prep, &grid.pre, &grid.map);
        let key_ctx = grid.ctx();
        let params = AimParams { view_turn: 40.0, ..grid.random_aims(0.0) };
        let mut key = aim_facets(&key_ctx, map, None, &params);
        let turned = super::super::views::turn_views(&mut key, &key_ctx, &map.facet_pixels(), &pre.film, &params);
        assert!(turned >= 4, "only {turned} facets turned");
        let anchors = anchor_aims(&key_ctx, &key);
        let corners = |t: u32| Some(prep.world.triangle(t));

        let same = carry_aims(&key_ctx, &anchors, map, &corners, &params);
        for (k, c) in key.iter().zip(&same) {
            assert_eq!(k.turn.is_some(), c.turn.is_some());
            if let (Some(a), Some(b)) = (k.turn, c.turn) {
                assert!((a.pivot - b.pivot).length() < 1e-4, "{a:?} against {b:?}");
                assert_eq!((a.angle, a.axis), (b.angle, b.axis));
            }
        }

        // A turntable step: the pivots stay on the (still) subject, the axis follows the camera.
        let up = pre.view.framed.frame.up;
        let rotation = DQuat::from_axis_angle(DVec3::X, 5f64.to_radians());
        let moved = Moved {
            inner: pre.view.framed.camera.as_ref(),
            rotation,
            translation: DVec3::ZERO,
            clip_radius: grid.clip_radius,
        };
        let ctx = AimContext { camera: &moved, up: rotation * up, ..key_ctx };
        let carried = carry_aims(&ctx, &anchors, map, &corners, &params);
        for (k, c) in key.iter().zip(&carried) {
            if let (Some(a), Some(b)) = (k.turn, c.turn) {
                assert!((a.pivot - b.pivot).length() < 1e-4);
                assert!((b.axis - rotation * up).length() < 1e-12 && a.angle == b.angle);
            }
        }
        assert!(carried.iter().filter(|c| c.turn.is_some()).count() == turned);
    }
}
