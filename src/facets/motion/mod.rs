//! Facets that move with the scene (`--facet-motion follow`), the thesis's future work ("a
//! cubist animation system which takes the time dimension into account and animates facets").
//!
//! A facet layout is made at a key frame (the layout frame). Every surface point keeps, in
//! every later frame, the facet it had there: the point a pixel of frame N shows (its triangle
//! and barycentrics, from frame N's pre-pass) is put back where it was at the key frame (the
//! same triangle of the key frame's geometry, at the same barycentrics), projected through
//! the key frame's camera (`Camera::project`, the exact inverse of its rays), and takes the
//! facet of the key picture there. The motion is the scene's own (its animation, the camera's
//! orbit), not an estimate from the pictures (optical flow), and frame N needs only the key
//! frame, never frames between: a render farm's chunks agree.
//!
//! A point may have had no facet at the key frame: it was hidden there (behind another
//! surface, or turned away) or out of the picture. Such pixels, and background pixels where the
//! key frame showed a surface, take the facet of the nearest pixel that has one (breadth-first,
//! so facets grow over what the motion reveals); background pixels where the key frame showed
//! background keep their facet (the backdrop does not move). `Carried::revealed` says how much
//! of the picture had to be filled so: when it grows, the view has changed too much for one
//! key frame, and a new one is made (`pipeline::frames`).

pub mod file;

use std::collections::VecDeque;

use glam::{DVec2, DVec3, Vec3};
use rayon::prelude::*;

use super::FacetMap;
use crate::camera::Camera;
use crate::film::{Film, NO_HIT};
use crate::imprecision::{self, AimContext, AimParams, FacetAim, FacetProjection};
use crate::util::grid::Grid;

/// How facets move over the frames of an animation.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FacetMotion {
    /// Fixed on the image, as the thesis animates (SPEC "Animation").
    Static,
    /// Carried with the surfaces they show.
    Follow,
}

/// Depth agreement, render units (the scene's radius is 1), under which a point counts as the
/// surface the key frame saw at its pixel: 0.5% of the scene, looser than the depth change
/// across a pixel of any but grazing surfaces, tighter than the gap to the surface behind.
pub const DEPTH_TOLERANCE: f32 = 5e-3;

/// What carrying needs of the key frame: its picture's facets and, per pixel of it, the
/// triangle and depth (from the camera surface) its centre ray hit, its geometry and camera.
pub struct Key<'a> {
    pub map: &'a FacetMap,
    /// World triangle id of each pixel's centre ray, `NO_HIT` on the background.
    pub tri: &'a [u32],
    /// Distance along each pixel's centre ray from the camera surface (infinite on background).
    pub depth: &'a [f32],
    /// Triangle corners at the key frame, render space (`World::positions`).
    pub positions: &'a [[Vec3; 3]],
    pub camera: &'a dyn Camera,
}

/// A frame's facets carried from a key frame.
pub struct Carried {
    pub map: FacetMap,
    /// Fraction of the frame's surface pixels whose point the key frame did not see (hidden,
    /// turned away or out of its picture): their facets were grown from their neighbours'.
    pub revealed: f64,
}

/// Per-pixel triangle and depth from the camera surface, read off a pre-pass film (one sample
/// per pixel: the pixel's hit is its centre ray's).
pub fn key_buffers(film: &Film, skipped: impl Fn(usize) -> f32) -> (Vec<u32>, Vec<f32>) {
    film.hits
        .iter()
        .enumerate()
        .map(|(i, h)| if h.is_hit() { (h.tri, h.t + skipped(i)) } else { (NO_HIT, f32::INFINITY) })
        .unzip()
}

/// The key frame's pixel a point of the key geometry falls on, if the key frame saw it there.
fn seen_at_key(key: &Key, tri: u32, u: f32, v: f32) -> Option<usize> {
    let corners = key.positions.get(tri as usize)?;
    let p = corners[0] * (1.0 - u - v) + corners[1] * u + corners[2] * v;
    let seen = key.camera.project(p.as_dvec3())?;
    if !seen.in_view() {
        return None;
    }
    let (w, h) = (key.map.width as usize, key.map.height as usize);
    let px = DVec2::new((seen.screen.x + 0.5) * w as f64, (0.5 - seen.screen.y) * h as f64);
    let (x, y) = ((px.x.floor() as usize).min(w - 1), (px.y.floor() as usize).min(h - 1));
    let i = y * w + x;
    if key.tri[i] == tri {
        return Some(i);
    }
    // A neighbouring triangle, or the pixel's centre ray landing elsewhere on the same surface:
    // the same surface if some pixel around agrees in depth.
    let depth = seen.depth as f32;
    let near = (y.saturating_sub(1)..=(y + 1).min(h - 1))
        .flat_map(|yy| (x.saturating_sub(1)..=(x + 1).min(w - 1)).map(move |xx| yy * w + xx))
        .any(|j| key.tri[j] == tri || (key.depth[j] - depth).abs() <= DEPTH_TOLERANCE);
    near.then_some(i)
}

/// Frame N's facets from the key frame: `hits` are frame N's pixel hits (triangle ids of the
/// same geometry as the key's, posed at frame N), at the key map's size.
pub fn carry(key: &Key, film: &Film) -> Carried {
    let (w, h) = (key.map.width, key.map.height);
    debug_assert_eq!((film.width, film.height), (w, h));
    const UNSET: u32 = u32::MAX;
    let n = film.hits.len();
    let mut ids = vec![UNSET; n];
    let (mut surface, mut revealed) = (0usize, 0usize);
    for (i, hit) in film.hits.iter().enumerate() {
        if hit.is_hit() {
            surface += 1;
            match seen_at_key(key, hit.tri, hit.u, hit.v) {
                Some(k) => ids[i] = key.map.ids[k],
                None => revealed += 1,
            }
        } else if key.tri[i] == NO_HIT {
            ids[i] = key.map.ids[i];
        }
    }
    grow(&mut ids, w, h, key.map.ids[0]);
    Carried {
        map: FacetMap { width: w, height: h, ids, facet_count: key.map.facet_count },
        revealed: if surface == 0 { 0.0 } else { revealed as f64 / surface as f64 },
    }
}

/// Gives every unset pixel the facet of the nearest set one (breadth-first over 4-neighbours
/// in a fixed order: deterministic); all unset: `fallback`.
fn grow(ids: &mut [u32], width: u32, height: u32, fallback: u32) {
    const UNSET: u32 = u32::MAX;
    let grid = Grid::new(width, height);
    let mut queue: VecDeque<usize> = (0..ids.len()).filter(|&i| ids[i] != UNSET).collect();
    if queue.is_empty() {
        ids.fill(fallback);
        return;
    }
    while let Some(i) = queue.pop_front() {
        for j in grid.neighbours4(i) {
            if ids[j] == UNSET {
                ids[j] = ids[i];
                queue.push_back(j);
            }
        }
    }
}

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

/// The key frame's aims (`imprecision`, decided from the key frame's picture), anchored to the
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

/// Facets that follow keep their view (issue 15 item 4): each facet of frame N takes the key
/// frame's aim carried with the scene, instead of one decided again from the pixels it covers
/// now (which shifts its view as its outline changes: flicker). Its centre is where the surface
/// point its key-frame centre showed is now (`ctx.camera.project` of the anchor posed by
/// `corners`), and it is re-aimed at where its key-frame aim point is now: the same scene point
/// at the centre of its view in every frame. What the key frame did not anchor (a centre or aim
/// point on the backdrop, or out of view now) falls back to the facet's centre in `map` and the
/// key frame's aim offset in pixels. The discontinuity limit (`params`) holds in every frame; a
/// facet the key frame did not re-aim (held on the backdrop, or not moved) is not re-aimed.
/// Frame N's aims are a function of the key frame's and frame N's scene alone: farm chunks agree.
pub fn carry_aims(
    ctx: &AimContext,
    key: &[KeyAim],
    map: &FacetMap,
    corners: &(dyn Fn(u32) -> Option<[Vec3; 3]> + Sync),
    params: &AimParams,
) -> Vec<FacetAim> {
    let fc_now = imprecision::facet_centres(map);
    let radius = params.discontinuity * params.scale;
    let linear = params.projection == FacetProjection::Linear;
    let (offsets, pixels) = if linear { map.pixels_by_facet() } else { (Vec::new(), Vec::new()) };
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
            let mut aim =
                FacetAim { fc: fc_now[f], sc_raw: fc_now[f], sc: fc_now[f], target: None, reaim: None, linear: None };
            let (Some(k), Some(fallback)) = (key.get(f), fc_now[f]) else { return aim };
            let c = now(k.centre).map_or(fallback, |(c, _)| c.clamp(DVec2::ZERO, DVec2::new(w, h)));
            (aim.fc, aim.sc_raw, aim.sc) = (Some(c), Some(c), Some(c));
            if let (Some(_), Some(kc), Some(ks)) = (k.aim.reaim, k.aim.fc, k.aim.sc) {
                let target = now(k.target);
                let s = target.map_or(c + (ks - kc), |(s, _)| s);
                let limited = imprecision::limit_discontinuity(c, s, radius);
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
                let own = &pixels[offsets[f] as usize..offsets[f + 1] as usize];
                aim.linear = ctx.linear(c, aim.reaim.as_ref(), own, params.facet_fov);
            }
            aim
        })
        .collect()
}

/// What a frame's picture shows, for measuring coherence between frames: its key data (per
/// pixel triangle and depth, the frame's geometry and camera) and each pixel's barycentrics.
pub struct Surface {
    pub key: file::KeyData,
    /// Barycentrics (u, v) of each pixel's centre-ray hit (meaningless where `key.tri` is `NO_HIT`).
    pub uv: Vec<(f32, f32)>,
}

impl Surface {
    /// From a pre-pass film and its key data.
    pub fn new(key: file::KeyData, film: &Film) -> Surface {
        Surface { key, uv: film.hits.iter().map(|h| (h.u, h.v)).collect() }
    }
}

/// How coherent two consecutive frames are, over the surface points both show.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Coherence {
    /// Surface points seen in both frames (pixels of the later frame whose point the earlier
    /// frame saw).
    pub points: usize,
    /// Share of those points whose facet id is the same in both frames.
    pub stickiness: f64,
    /// Mean absolute colour change of those points, RGB in [0, 1] averaged over channels.
    pub flicker: f64,
}

/// Stickiness and flicker from frame `a` to frame `b` (issue 15 item 4): each pixel of `b`
/// showing a surface point is matched, through the scene's exact motion, to the pixel of `a`
/// showing the same point (as facets follow: `a`'s geometry and camera, `Camera::project`).
/// `image_*` are RGBA8 pictures at the frames' size.
pub fn coherence(
    a: &Surface,
    map_a: &FacetMap,
    image_a: &[u8],
    b: &Surface,
    map_b: &FacetMap,
    image_b: &[u8],
) -> Coherence {
    let key = a.key.key(map_a);
    let (mut points, mut same, mut change) = (0usize, 0usize, 0.0f64);
    for (i, &tri) in b.key.tri.iter().enumerate() {
        if tri == NO_HIT {
            continue;
        }
        let (u, v) = b.uv[i];
        let Some(k) = seen_at_key(&key, tri, u, v) else { continue };
        points += 1;
        same += (map_a.ids[k] == map_b.ids[i]) as usize;
        change +=
            (0..3).map(|c| (image_a[4 * k + c] as f64 - image_b[4 * i + c] as f64).abs()).sum::<f64>() / (3.0 * 255.0);
    }
    let n = points.max(1) as f64;
    Coherence { points, stickiness: same as f64 / n, flicker: change / n }
}

#[cfg(test)]
mod tests {
    use glam::DQuat;

    use super::*;
    use crate::camera::Moved;
    use crate::imprecision::{AimMode, aim_facets};
    use crate::pipeline::{Prepared, Shading, StageParams, Timings, prerender};
    use crate::progress::Progress;
    use crate::settings::Settings;

    /// The default still life's aims on a grid of 48 facets (random aim points within 30
    /// pixels: no saliency map needed), anchored, then carried to the same camera (the key
    /// frame's aims again) and to the camera turned by 4 degrees about the vertical axis (a
    /// turntable step: each facet keeps aiming at the scene point it aimed at).
    #[test]
    fn carried_aims_keep_the_key_frames_view() {
        let prep = Prepared::load(None).unwrap();
        let (w, h) = (160u32, 120u32);
        let s = Settings { width: w, height: h, ..Settings::default() };
        let params = StageParams::new(&s);
        let pre = prerender(
            &prep,
            &params.framing,
            &params.trace,
            Shading::HitsOnly,
            &Progress::silent(),
            &mut Timings::default(),
        )
        .unwrap();
        let ids = (0..w * h).map(|i| (i % w) / 20 + 8 * ((i / w) / 20)).collect();
        let map = FacetMap { width: w, height: h, ids, facet_count: 48 };
        let clip_radius = prep.world.radius as f64 * 1.001;
        let camera = pre.view.framed.camera.as_ref();
        let key_ctx = AimContext { camera, accel: &prep.accel, width: w, height: h, clip_radius };
        let aim = AimParams {
            mode: AimMode::Random,
            discontinuity: 30.0,
            scale: 1.0,
            min_coverage: 0.0,
            ..params.aim.clone()
        };
        let key = aim_facets(&key_ctx, &map, None, &aim);
        let anchors = anchor_aims(&key_ctx, &key);
        let corners = |t: u32| Some(prep.world.triangle(t));
        let anchored = anchors.iter().filter(|k| k.aim.moved() && k.centre.is_some() && k.target.is_some()).count();
        assert!(anchored >= 4, "only {anchored} facets re-aimed at the still life");

        // At the key frame itself: the key frame's aims, to rounding.
        let same = carry_aims(&key_ctx, &anchors, &map, &corners, &aim);
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
        let carried = carry_aims(&ctx, &anchors, &map, &corners, &aim);
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
}
