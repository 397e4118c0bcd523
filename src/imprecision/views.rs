//! Several views at once: the subject's planes show their part of it seen from
//! another side, the camera turned about the point the plane is centred on.
//!
//! The painters set a frontal eye beside a profile nose (Collomosse and Hall 2003 compose
//! salient features from several photographs). A re-aim only shifts a plane's view; a turn
//! rotates it: every ray of the plane is rotated about the vertical axis (the camera's up)
//! through the scene point its centre ray hits, so the plane keeps showing the same part of
//! the subject, in place, from a side. Each of the subject's planes is turned towards its own
//! side of the subject (a plane right of the subject's centre shows more of the subject's
//! right), but a plane that holds a cue (an eye, a muzzle: the most salient pixels) keeps its
//! view, so the cue is drawn whole, and a plane whose turned view would show the backdrop is
//! not turned (no ghost copies, the figure is not holed).

use glam::{DQuat, DVec2, DVec3};
use rayon::prelude::*;

use super::carried::Anchor;
use super::{AimContext, AimParams, FacetAim};
use crate::camera::{CameraRay, finish_ray};
use crate::facets::FacetPixels;
use crate::film::Film;

/// A plane is the subject's when at least this share of its pixels hit it in the pre-render.
pub const SUBJECT_COVERAGE: f64 = 0.6;
/// A turn is kept only when at least this share of the plane's sampled rays still hit the
/// subject once turned.
pub const TURNED_COVERAGE: f64 = 0.85;
/// A plane holds a cue when more than this share of its pixels are among the most salient
/// (`guard::cue_threshold`).
pub const CUE_PLANE_SHARE: f64 = 0.1;
/// Pixels of a plane traced to check its turned view.
const SAMPLES: usize = 64;

/// The turn of a plane's view: a rotation of its rays by `angle` radians about `axis` through
/// `pivot` (render space), the point of the surface `anchor` names (facets that follow carry
/// the turn with it: `carried`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Turn {
    pub pivot: DVec3,
    pub anchor: Anchor,
    pub axis: DVec3,
    pub angle: f64,
}

impl Turn {
    /// The ray rotated about the turn's axis, from its origin on the camera surface.
    pub fn apply(&self, ray: &CameraRay, clip_radius: f64) -> CameraRay {
        let q = DQuat::from_axis_angle(self.axis, self.angle);
        let o = self.pivot + q * (ray.surface_origin() - self.pivot);
        let d = q * ray.dir.as_dvec3();
        finish_ray(o, d, ray.surface_focus(), clip_radius)
    }
}

/// Turns the views of the subject's planes (`aims`, whose pixels are `by_facet`, over the
/// pre-render `film`) by `params.view_turn` degrees about the camera's up, each towards its
/// side of the subject. Returns how many planes were turned.
pub fn turn_views(
    aims: &mut [FacetAim],
    ctx: &AimContext,
    by_facet: &FacetPixels,
    film: &Film,
    params: &AimParams,
) -> usize {
    if params.view_turn <= 0.0 {
        return 0;
    }
    let Some(axis) = ctx.up.try_normalize() else { return 0 };
    let w = film.width as usize;
    let coverage = super::guard::facet_coverage(by_facet, |i| film.color[i].w);
    // The subject's centre on the canvas: the mean of its pixels.
    let (mut sum, mut n) = (0.0, 0.0);
    for (i, c) in film.color.iter().enumerate() {
        sum += c.w as f64 * (i % w) as f64;
        n += c.w as f64;
    }
    if n <= 0.0 {
        return 0;
    }
    let centre_x = sum / n + 0.5;
    // The planes that hold a cue keep their view: a cue is drawn whole, not turned. Only when
    // re-aiming reads the saliency map (`reads_saliency`), as the guard's cue rules: whether the
    // map exists otherwise depends on the passes asked for, which must not change the picture.
    let cue =
        film.saliency.as_deref().filter(|s| s.len() == film.color.len() && params.reads_saliency()).and_then(|s| {
            let t = super::guard::cue_threshold(s)?;
            Some(move |f: usize| {
                let own = by_facet.of(f);
                let salient = own.iter().filter(|&&i| s[i as usize] >= t).count();
                salient as f64 > CUE_PLANE_SHARE * own.len() as f64
            })
        });
    let turns: Vec<Option<Turn>> = (0..aims.len())
        .into_par_iter()
        .map(|f| {
            let aim = &aims[f];
            let fc = aim.fc?;
            if coverage[f] < SUBJECT_COVERAGE || cue.as_ref().is_some_and(|is_cue| is_cue(f)) {
                return None;
            }
            let side = if fc.x >= centre_x { 1.0 } else { -1.0 };
            let turn = pivoted(aim, ctx, axis, side * params.view_turn.to_radians())?;
            let own = by_facet.of(f);
            let m = own.len().min(SAMPLES);
            let hits = (0..m)
                .filter(|&k| {
                    let i = own[k * own.len() / m] as usize;
                    let px = DVec2::new((i % w) as f64 + 0.5, (i / w) as f64 + 0.5);
                    let r = turn.apply(&aim.apply(ctx.ray_at(px), px, ctx.clip_radius), ctx.clip_radius);
                    ctx.accel.closest(r.origin, r.dir, 0.0, f32::INFINITY).is_some()
                })
                .count();
            (m > 0 && hits as f64 >= TURNED_COVERAGE * m as f64).then_some(turn)
        })
        .collect();
    set_turns(aims, turns)
}

/// Gives each aim its turn where it has one; returns how many it gave.
fn set_turns(aims: &mut [FacetAim], turns: Vec<Option<Turn>>) -> usize {
    let mut turned = 0;
    for (aim, t) in aims.iter_mut().zip(turns) {
        if t.is_some() {
            aim.turn = t;
            turned += 1;
        }
    }
    turned
}

/// The turn of `aim`'s view by `angle` about `axis` through the point its centre ray hits now;
/// None where it hits nothing.
fn pivoted(aim: &FacetAim, ctx: &AimContext, axis: DVec3, angle: f64) -> Option<Turn> {
    let fc = aim.fc?;
    let centre = aim.apply(ctx.ray_at(fc), fc, ctx.clip_radius);
    let hit = ctx.accel.closest(centre.origin, centre.dir, 0.0, f32::INFINITY)?;
    let pivot = centre.origin.as_dvec3() + centre.dir.as_dvec3() * hit.t as f64;
    Some(Turn { pivot, anchor: Anchor { tri: hit.tri, u: hit.u, v: hit.v }, axis, angle })
}

/// Turns the planes another frame decided to turn (`angles`, radians per facet, 0 = kept; a
/// sequence's layout frame under static facets), each by its angle about the point its centre
/// ray hits in this frame, while it still shows the subject (`SUBJECT_COVERAGE` of its pixels in
/// `film`): which planes turn and to which side is that frame's decision, so a plane does not
/// flip sides as the subject moves under it. Returns how many planes were turned.
pub fn turn_held(
    aims: &mut [FacetAim],
    ctx: &AimContext,
    by_facet: &FacetPixels,
    film: &Film,
    angles: &[f64],
) -> usize {
    let Some(axis) = ctx.up.try_normalize() else { return 0 };
    let coverage = super::guard::facet_coverage(by_facet, |i| film.color[i].w);
    let turns: Vec<Option<Turn>> = (0..aims.len())
        .into_par_iter()
        .map(|f| {
            let angle = angles.get(f).copied().unwrap_or(0.0);
            if angle == 0.0 || coverage[f] < SUBJECT_COVERAGE {
                return None;
            }
            pivoted(&aims[f], ctx, axis, angle)
        })
        .collect();
    set_turns(aims, turns)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::imprecision::tests::Grid;
    use crate::imprecision::{AimMode, aim_facets};
    use crate::pipeline::Shading;

    fn ray(origin: DVec3, dir: DVec3) -> CameraRay {
        finish_ray(origin, dir, 3.0, 100.0)
    }

    #[test]
    fn a_turn_rotates_the_ray_about_its_pivot() {
        let anchor = Anchor { tri: 0, u: 0.0, v: 0.0 };
        let turn = Turn { pivot: DVec3::new(0.0, 0.0, -1.0), anchor, axis: DVec3::Y, angle: 90f64.to_radians() };
        // The ray through the pivot still passes through it, now from the side.
        let r = turn.apply(&ray(DVec3::new(0.0, 0.0, 2.0), -DVec3::Z), 100.0);
        assert!((r.surface_origin() - DVec3::new(3.0, 0.0, -1.0)).length() < 1e-5, "{r:?}");
        assert!((r.dir.as_dvec3() - -DVec3::X).length() < 1e-6, "{r:?}");
        assert!((r.surface_focus() - 3.0).abs() < 1e-5);
        // A ray beside it keeps its offset along the axis and turns with it.
        let r = turn.apply(&ray(DVec3::new(0.0, 0.5, 2.0), -DVec3::Z), 100.0);
        assert!((r.surface_origin() - DVec3::new(3.0, 0.5, -1.0)).length() < 1e-5, "{r:?}");
        // No angle: the same ray.
        let still = Turn { angle: 0.0, ..turn };
        let a = ray(DVec3::new(0.2, 0.1, 2.0), DVec3::new(0.1, 0.0, -1.0));
        let b = still.apply(&a, 100.0);
        assert!((a.origin - b.origin).length() < 1e-6 && (a.dir - b.dir).length() < 1e-6);
    }

    /// The still life's grid of 48 facets, not re-aimed: the subject's facets turn, each
    /// about the point its centre shows, towards its side; the backdrop's and the cue's keep
    /// their view; the same facets turn on every run.
    #[test]
    fn the_subjects_planes_turn_but_the_cues_and_the_backdrop() {
        let grid = Grid::new(Shading::HitsOnly);
        let ctx = grid.ctx();
        let by_facet = grid.map.facet_pixels();
        let film = &grid.pre.film;
        // Saliency imprecision (its cue rules apply) with no map to aim by: no facet re-aimed.
        let params =
            AimParams { view_turn: 45.0, mode: AimMode::Saliency, discontinuity: 30.0, ..grid.random_aims(0.0) };
        let still = aim_facets(&ctx, &grid.map, None, &params);
        let coverage = super::super::guard::facet_coverage(&by_facet, |i| film.color[i].w);

        let mut aims = still.clone();
        let turned = turn_views(&mut aims, &ctx, &by_facet, film, &params);
        assert!(turned >= 4, "only {turned} of the still life's facets turned");
        for (f, aim) in aims.iter().enumerate() {
            let Some(t) = aim.turn else { continue };
            assert!(coverage[f] >= SUBJECT_COVERAGE, "facet {f} of the backdrop turned");
            assert!((t.angle.abs() - 45f64.to_radians()).abs() < 1e-12);
            // The pivot lies on the facet's centre ray, which the turn leaves through it.
            let fc = aim.fc.unwrap();
            let r = FacetAim { turn: None, ..*aim }.apply(ctx.ray_at(fc), fc, ctx.clip_radius);
            let to_pivot = (t.pivot - r.surface_origin()).normalize();
            assert!(to_pivot.dot(r.dir.as_dvec3()) > 1.0 - 1e-6, "facet {f}: pivot off its centre ray");
            // Turned towards its side: a facet right of the subject's centre is seen from
            // further right (its rays start further along the camera's right), and the other way.
            let right = fc.x > WIDTH_HALF;
            assert!(right == (t.angle > 0.0) || (fc.x - WIDTH_HALF).abs() < 20.0, "facet {f} turned the wrong way");
            let moved = t.apply(&r, ctx.clip_radius).surface_origin() - r.surface_origin();
            let towards = moved.dot(grid.pre.view.framed.frame.right);
            assert!((towards > 0.0) == (t.angle > 0.0), "facet {f}: seen from {towards} along the right");
        }
        let mut again = still.clone();
        turn_views(&mut again, &ctx, &by_facet, film, &params);
        assert_eq!(aims, again);

        // Off: nothing turns.
        let mut off = still.clone();
        assert_eq!(turn_views(&mut off, &ctx, &by_facet, film, &AimParams { view_turn: 0.0, ..params.clone() }), 0);

        // A facet holding the most salient pixels keeps its view.
        let f = aims.iter().position(|a| a.turn.is_some()).unwrap();
        let mut salient = film.clone();
        let mut map = vec![0.0f32; film.color.len()];
        for &i in by_facet.of(f) {
            map[i as usize] = 1.0;
        }
        salient.saliency = Some(map);
        let mut cued = still.clone();
        turn_views(&mut cued, &ctx, &by_facet, &salient, &params);
        assert!(cued[f].turn.is_none(), "the cue's facet {f} turned");
        assert_eq!(cued.iter().filter(|a| a.turn.is_some()).count(), turned - 1);
        // Unless re-aiming does not read the map: then a map made for another reason (a
        // saliency pass) changes nothing.
        let random = AimParams { view_turn: 45.0, ..grid.random_aims(0.0) };
        let mut unread = still.clone();
        turn_views(&mut unread, &ctx, &by_facet, &salient, &random);
        assert_eq!(unread, aims);
    }

    /// Turns held from another frame: the same planes turn to the sides given, each about the
    /// point its centre ray hits in this frame, however this frame would have decided; a plane
    /// off the subject here is not turned.
    #[test]
    fn held_turns_keep_their_sides_and_pivot_on_this_frame() {
        let grid = Grid::new(Shading::HitsOnly);
        let ctx = grid.ctx();
        let by_facet = grid.map.facet_pixels();
        let film = &grid.pre.film;
        let params = AimParams { view_turn: 45.0, ..grid.random_aims(0.0) };
        let still = aim_facets(&ctx, &grid.map, None, &params);
        let mut decided = still.clone();
        let turned = turn_views(&mut decided, &ctx, &by_facet, film, &params);
        assert!(turned >= 4, "only {turned} facets turned");
        let angles: Vec<f64> = decided.iter().map(|a| a.turn.map_or(0.0, |t| t.angle)).collect();

        // The same frame: the same turns.
        let mut held = still.clone();
        assert_eq!(turn_held(&mut held, &ctx, &by_facet, film, &angles), turned);
        assert_eq!(held, decided);

        // Sides given the other way round are kept so, about the same pivots.
        let flipped: Vec<f64> = angles.iter().map(|a| -a).collect();
        let mut other = still.clone();
        assert_eq!(turn_held(&mut other, &ctx, &by_facet, film, &flipped), turned);
        for (a, b) in other.iter().zip(&decided) {
            match (a.turn, b.turn) {
                (Some(x), Some(y)) => assert!(x.angle == -y.angle && x.pivot == y.pivot && x.anchor == y.anchor),
                (None, None) => {}
                _ => panic!("a plane turned in one and not the other"),
            }
        }

        // A plane asked to turn that does not show the subject here is not turned, and no angle
        // turns nothing.
        let coverage = super::super::guard::facet_coverage(&by_facet, |i| film.color[i].w);
        let off = coverage.iter().position(|&c| c < SUBJECT_COVERAGE).expect("a facet on the backdrop");
        let all = vec![0.3; still.len()];
        let mut any = still.clone();
        turn_held(&mut any, &ctx, &by_facet, film, &all);
        assert!(any[off].turn.is_none(), "facet {off} of the backdrop turned");
        let mut none = still.clone();
        assert_eq!(turn_held(&mut none, &ctx, &by_facet, film, &vec![0.0; still.len()]), 0);
        assert_eq!(none, still);
    }

    /// Half the grid's width: the subject of the still life is about the canvas's centre.
    const WIDTH_HALF: f64 = crate::imprecision::tests::WIDTH as f64 / 2.0;
}
