//! Sweeps: one sheet bent about one axis, a studio's floor curving up into its wall (a
//! cyclorama, the "infinite backdrop" of product and character shots). Not flat, it failed
//! `backdrop`'s test and was framed with the subject: a cat a tenth of the canvas tall before a
//! wall of planes. It is a backdrop on its floor's plane, the flat part the subject stands
//! nearest: rays from below that floor pass the sweep, and the floor runs on past its edge. A
//! cylinder, a half-pipe or a hill is no sweep (their normals turn more than `MAX_SPAN`, or not
//! about one axis), nor a staircase (its treads lie on many planes), nor a roof, a tent or a
//! canopy (the subject does not stand inside their bend).

use glam::DVec3;

use super::World;

/// Triangles of an object read to decide whether it is a sweep (evenly spread over it).
const SAMPLE: usize = 4096;
/// The sheet bends at least this much: the cosine between its two most different normals
/// (as lines) at most this (60 deg).
const MIN_BEND_COS: f64 = 0.5;
/// A normal runs across the axis when its cosine with it is at most this (about 6 deg).
const ACROSS_COS: f64 = 0.1;
/// The share of the sheet's area whose normals may run along the axis (a thick sweep's ends).
const ALONG_SHARE: f64 = 0.03;
/// The normals turn at most this far about the axis, radians (110 deg: a floor into a wall).
const MAX_SPAN: f64 = 110.0 * std::f64::consts::PI / 180.0;
/// A flat part is within this angle of either end of the turn, radians (2 deg: the first
/// facet of a bevel turns further).
const PART_ANGLE: f64 = 2.0 * std::f64::consts::PI / 180.0;
/// Each flat part holds at least this share of the sheet's area.
const PART_SHARE: f64 = 0.1;
/// The subject stands on the floor: its box within this share of its extent of the floor's
/// plane.
const STAND_SHARE: f64 = 0.05;
/// Each flat part lies on one plane: its corners within this share of the sweep's extent of
/// it (a sheet 25 cm thick in a sweep 8 m across; not the treads of a staircase).
const PART_DEPTH: f64 = 0.03;

/// A sampled triangle: its corners, unit normal and area.
type Sampled = ([DVec3; 3], DVec3, f64);
/// A flat part of a sweep: its unit normal towards the subject, its plane's offset, how far the
/// subject's box stands in front of it (`backdrop::gap_to`), its triangles.
type Part<'a> = (DVec3, f64, f64, Vec<&'a Sampled>);

/// A sweep's floor and which way its triangles face.
pub(super) struct Sweep {
    /// The floor's unit normal towards the subject.
    pub normal: DVec3,
    /// The offset of the floor's plane `normal . p = offset` through its corner nearest the
    /// subject.
    pub offset: f64,
    /// Whether the triangles' winding faces the subject (true) or away (false), when all but
    /// `ALONG_SHARE` of the area agrees (a sheet modelled in one layer); None for a thick one.
    pub winding: Option<bool>,
}

/// Object `o` as a sweep before a subject whose box is `lo`..`hi` (render space); None when
/// `o` is not a sheet bent about one axis by `MIN_BEND_COS` to `MAX_SPAN` with a flat part at
/// both ends of its turn.
pub(super) fn sweep(world: &World, o: usize, (lo, hi): (DVec3, DVec3)) -> Option<Sweep> {
    let tris: Vec<Sampled> = super::backdrop::sampled(world, o, SAMPLE)
        .filter_map(|t| {
            let cross = (t[1] - t[0]).cross(t[2] - t[0]);
            let area = 0.5 * cross.length();
            (area > 0.0 && area.is_finite()).then(|| (t, cross / (2.0 * area), area))
        })
        .collect();
    let total: f64 = tris.iter().map(|t| t.2).sum();
    let first = tris.iter().max_by(|a, b| a.2.total_cmp(&b.2))?.1;
    let bent = tris.iter().map(|t| t.1).min_by(|a, b| a.dot(first).abs().total_cmp(&b.dot(first).abs()))?;
    if bent.dot(first).abs() > MIN_BEND_COS {
        return None;
    }
    let axis = first.cross(bent).try_normalize()?;
    let along: f64 = tris.iter().filter(|t| t.1.dot(axis).abs() > ACROSS_COS).map(|t| t.2).sum();
    if along > ALONG_SHARE * total {
        return None;
    }
    // Each normal's turn about the axis, as a line (modulo 180 deg, so either face of a layer
    // and either layer of a thick sheet agree), from the start of the least arc holding them
    // all: the arc after the widest gap between them.
    let side = axis.cross(first);
    let half = std::f64::consts::PI;
    let line = |n: DVec3| n.dot(side).atan2(n.dot(first)).rem_euclid(half);
    let across: Vec<(&Sampled, f64)> =
        tris.iter().filter(|t| t.1.dot(axis).abs() <= ACROSS_COS).map(|t| (t, line(t.1))).collect();
    let mut turns: Vec<f64> = across.iter().map(|t| t.1).collect();
    turns.sort_by(f64::total_cmp);
    let (&lowest, &highest) = (turns.first()?, turns.last()?);
    let (gap, start) = turns
        .windows(2)
        .map(|w| (w[1] - w[0], w[1]))
        .fold((lowest + half - highest, lowest), |best, g| if g.0 > best.0 { g } else { best });
    let span = half - gap;
    if span > MAX_SPAN {
        return None;
    }
    let across: Vec<_> = across.into_iter().map(|(t, a)| (t, (a - start).rem_euclid(half))).collect();
    let centre = (lo + hi) * 0.5;
    let (lo_o, hi_o, _) = world.objects[o].bounds?;
    let tolerance = PART_DEPTH * (hi_o - lo_o).as_dvec3().length();
    // A flat part at each end of the turn: its plane through its corner nearest the subject,
    // and how far the subject's box stands in front of it.
    let part = |end: f64| -> Option<Part> {
        let part: Vec<&Sampled> = across.iter().filter(|t| (t.1 - end).abs() <= PART_ANGLE).map(|t| t.0).collect();
        let area: f64 = part.iter().map(|t| t.2).sum();
        if area < PART_SHARE * total {
            return None;
        }
        let normal = part.iter().max_by(|a, b| a.2.total_cmp(&b.2))?.1;
        let point = part[0].0[0];
        let normal = if (centre - point).dot(normal) >= 0.0 { normal } else { -normal };
        let levels = || part.iter().flat_map(|t| t.0).map(|p| p.dot(normal));
        let offset = levels().fold(f64::NEG_INFINITY, f64::max);
        if offset - levels().fold(f64::INFINITY, f64::min) > tolerance {
            return None;
        }
        Some((normal, offset, super::backdrop::gap_to(lo, hi, normal, offset), part))
    };
    let (a, b) = (part(0.0)?, part(span)?);
    // Concave towards the subject: each part on the subject's side of the other's plane (a
    // ridge, a tent seen from outside are not).
    let before = |x: &Part, y: &Part| y.3.iter().flat_map(|t| t.0).all(|p| p.dot(x.0) >= x.1 - tolerance);
    if !(before(&a, &b) && before(&b, &a)) {
        return None;
    }
    // The floor: the part the subject stands on (a canopy or a tent over it is no sweep).
    let (normal, offset, gap, _) = if a.2.abs() <= b.2.abs() { a } else { b };
    if gap.abs() > STAND_SHARE * (hi - lo).length() {
        return None;
    }
    // The winding faces the subject where it turns towards the subject's centre.
    let facing: f64 = tris.iter().filter(|t| (centre - t.0[0]).dot(t.1) > 0.0).map(|t| t.2).sum();
    let winding = match facing / total {
        f if f >= 1.0 - ALONG_SHARE => Some(true),
        f if f <= ALONG_SHARE => Some(false),
        _ => None,
    };
    (normal.is_finite() && offset.is_finite()).then_some(Sweep { normal, offset, winding })
}

#[cfg(test)]
mod tests {
    use glam::{DVec3, Vec3};

    use super::*;
    use crate::accel::Accel;
    use crate::scene::default::ellipsoid;
    use crate::scene::{Mesh, sweep_profile, test_sweep};

    fn ball() -> (Mesh, DVec3) {
        (ellipsoid("ball", Vec3::splat(1.0), 12, 24, 0), DVec3::new(0.0, 1.0, 0.0))
    }

    fn scene(parts: Vec<(Mesh, DVec3)>) -> World {
        crate::scene::test_world(parts, None)
    }

    #[test]
    fn a_floor_curving_into_a_wall_is_a_backdrop_on_its_floor() {
        for (flipped, winding) in [(false, true), (true, false)] {
            let w = scene(vec![(test_sweep(&sweep_profile(0.0), 8.0, flipped), DVec3::ZERO), ball()]);
            assert_eq!(w.backdrops.len(), 1, "{:?}", w.backdrops);
            let b = w.backdrops[0];
            assert_eq!((b.object, b.winding), (0, Some(winding)));
            // Its plane is the floor's, facing the ball.
            let up = (w.to_render.point(DVec3::Y) - w.to_render.point(DVec3::ZERO)).normalize();
            assert!(b.normal.dot(up) > 0.999, "{b:?} {up}");
            assert!(!b.behind(w.to_render.point(DVec3::new(2.0, 0.01, 2.0))));
            assert!(b.behind(w.to_render.point(DVec3::new(2.0, -0.01, -2.0))));
            assert!(b.face.is_some());
        }
        // Modelled thick (two layers 5 cm apart, the lower facing down): still a sweep, on the
        // upper layer's plane, its one side by that plane.
        let mut thick = test_sweep(&sweep_profile(0.0), 8.0, false);
        let lower = test_sweep(&sweep_profile(-0.05), 8.0, true);
        let n = thick.positions.len() as u32;
        thick.positions.extend(lower.positions);
        thick.normals.extend(lower.normals);
        thick.triangles.extend(lower.triangles.iter().map(|t| t.map(|i| i + n)));
        let w = scene(vec![(thick, DVec3::ZERO), ball()]);
        assert_eq!(w.backdrops.len(), 1);
        assert_eq!(w.backdrops[0].winding, None);
        assert!(!w.backdrops[0].behind(w.to_render.point(DVec3::new(0.0, 0.01, 2.0))));
    }

    #[test]
    fn tubes_roofs_canopies_stairs_small_sheets_and_flat_bends_are_no_sweeps() {
        let arc = |from: f32, to: f32, r: f32| -> Vec<(f32, f32)> {
            (0..=24).map(|k| from + (to - from) * k as f32 / 24.0).map(|a| (r * a.cos(), r + r * a.sin())).collect()
        };
        let tau = std::f32::consts::TAU;
        // Ten steps 40 cm deep and 25 cm high rising away from the ball: treads and risers.
        let stairs: Vec<(f32, f32)> = (0..10)
            .map(|k| (2.0 - 0.4 * k as f32, 0.25 * k as f32))
            .flat_map(|(z, y)| [(z, y), (z - 0.4, y)])
            .collect();
        // A sweep turned upside down: a ceiling 3 m above the ball curving down into a wall.
        let canopy: Vec<(f32, f32)> = sweep_profile(0.0).iter().map(|&(z, y)| (z, 3.0 - y)).collect();
        for (what, mesh) in [
            ("a tube around the ball", test_sweep(&arc(0.0, tau, 4.0), 8.0, false)),
            ("a half-pipe", test_sweep(&arc(0.5 * tau, tau, 4.0), 8.0, false)),
            (
                "a sweep the ball's size",
                test_sweep(
                    &sweep_profile(0.0).iter().map(|&(z, y)| (0.3 * z, 0.3 * y)).collect::<Vec<_>>(),
                    2.4,
                    false,
                ),
            ),
            ("a floor bent 30 degrees", test_sweep(&[(3.0, 0.0), (-3.0, 0.0), (-8.0, 2.9)], 8.0, false)),
            ("a staircase", test_sweep(&stairs, 8.0, false)),
            ("a tent over the ball", test_sweep(&[(4.0, 0.0), (0.0, 4.0), (-4.0, 0.0)], 8.0, false)),
            ("a ridge under the ball", test_sweep(&[(4.0, -4.0), (0.0, 0.0), (-4.0, -4.0)], 8.0, false)),
            ("a canopy over the ball", test_sweep(&canopy, 8.0, false)),
        ] {
            let w = scene(vec![(mesh, DVec3::ZERO), ball()]);
            assert!(w.backdrops.is_empty(), "{what}: {:?}", w.backdrops);
        }
    }

    /// Rays from below the floor pass it and meet the wall, or the ball from below; from in
    /// front they land on the floor; from behind the wall they pass it; its wall casts shadows.
    #[test]
    fn rays_meet_a_sweep_from_the_subjects_side_only() {
        for flipped in [false, true] {
            let w = scene(vec![(test_sweep(&sweep_profile(0.0), 8.0, flipped), DVec3::ZERO), ball()]);
            let accel = Accel::new(&w);
            let at = |x: f64, y: f64, z: f64| w.to_render.point(DVec3::new(x, y, z));
            let towards = |a: Vec3, b: Vec3| (b - a).normalize();
            let seen = |from: Vec3, to: Vec3| {
                accel.closest(from, towards(from, to), 0.0, f32::INFINITY).map(|h| w.object_of(h.tri))
            };
            assert_eq!(seen(at(2.0, -1.0, 2.0), at(2.0, 2.0, -4.0)), Some(0), "the wall, from below");
            assert_eq!(seen(at(0.0, -1.0, 0.0), at(0.0, 1.0, 0.0)), Some(1), "the ball, from below");
            assert_eq!(seen(at(2.0, 2.0, 2.0), at(2.0, -1.0, 2.0)), Some(0), "the floor, from above");
            assert_eq!(seen(at(2.0, 3.0, -5.0), at(2.0, 3.0, 5.0)), None, "behind the wall");
            // It casts shadows: a light behind the wall does not reach the floor before it.
            let (from, to) = (at(2.0, 0.01, 1.0), at(2.0, 3.0, -6.0));
            assert!(accel.occluded(from, towards(from, to), 0.0, f32::INFINITY), "the wall's shadow");
        }
    }
}
