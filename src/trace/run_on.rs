//! Backdrops run on past their edges: a ray that misses everything but meets a backdrop's
//! plane ahead of it, from the subject's side, shows that backdrop there. A converging camera
//! framed on the furniture of a room looks past the floor's near edge in its lowest rows,
//! which stayed black; the floor now continues under them.

use glam::{DVec3, Vec3};

use crate::accel::Hit;
use crate::scene::World;

/// How far from the scene's centre a backdrop runs on, in scene radii: far enough for a floor
/// under the canvas's lowest rows, not to the horizon (whose distances would flatten a depth
/// pass).
const REACH_RADII: f32 = 4.0;

/// A hit this far behind its backdrop's plane, in scene radii, is on the backdrop's edge.
const EDGE_DEPTH: f32 = 1e-3;

/// `hit`, or where the ray from `origin` along `dir` misses everything (or meets only a
/// backdrop's own edge behind its plane) and meets a backdrop's plane ahead of it from the
/// subject's side, outside the backdrop's box (a hole in a wall stays open) and within
/// `REACH_RADII`: a hit on the backdrop's face triangle, its barycentrics outside it, so its
/// material, normal and texture run on.
#[inline]
pub(crate) fn run_on(world: &World, origin: Vec3, dir: Vec3, hit: Option<Hit>) -> Option<Hit> {
    if world.backdrops.is_empty() {
        return hit;
    }
    // A hit stands unless it is a backdrop's own side face, behind its plane (by more than the
    // rounding of a hit on the face itself).
    let mut nearest: Option<(f32, u32, usize)> = None;
    if let Some(h) = hit {
        let at = origin + dir * h.t;
        let below = |b: &crate::scene::backdrop::Backdrop| b.normal.dot(at) < b.offset - EDGE_DEPTH * world.radius;
        let edge = world.backdrops.iter().any(|b| b.object == h.object as usize && b.face.is_some() && below(b));
        if !edge {
            return hit;
        }
    }
    let reach = REACH_RADII * world.radius.max(f32::MIN_POSITIVE);
    for b in &world.backdrops {
        let Some(face) = b.face else { continue };
        let (towards, above) = (b.normal.dot(dir), b.normal.dot(origin) - b.offset);
        if towards >= 0.0 || above < 0.0 {
            continue;
        }
        let t = -above / towards;
        let at = origin + dir * t;
        let outside = world.objects[b.object].bounds.is_none_or(|(lo, hi, _)| {
            let pad = (hi - lo).length() * 1e-4;
            at.cmplt(lo - pad).any() || at.cmpgt(hi + pad).any()
        });
        if t.is_finite() && outside && at.length() <= reach && nearest.is_none_or(|(best, ..)| t < best) {
            nearest = Some((t, face, b.object));
        }
    }
    let Some((t, face, object)) = nearest else { return hit };
    if hit.is_some_and(|h| h.t <= t) {
        return hit;
    }
    let (u, v) = barycentrics(world.triangle(face).map(Vec3::as_dvec3), (origin + dir * t).as_dvec3())?;
    Some(Hit { tri: face, object: object as u32, t, u: u as f32, v: v as f32 })
}

/// The barycentrics (u, v) of `q` on the plane of triangle `[a, b, c]`: q = a + u (b - a) +
/// v (c - a), as `Hit` has them; None for a degenerate triangle.
fn barycentrics([a, b, c]: [DVec3; 3], q: DVec3) -> Option<(f64, f64)> {
    let (e1, e2, d) = (b - a, c - a, q - a);
    let (d00, d01, d11) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
    let (d20, d21) = (d.dot(e1), d.dot(e2));
    let det = d00 * d11 - d01 * d01;
    let (u, v) = ((d11 * d20 - d01 * d21) / det, (d00 * d21 - d01 * d20) / det);
    (det > 0.0 && u.is_finite() && v.is_finite()).then_some((u, v))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::Accel;
    use crate::scene::default::{cuboid, ellipsoid};

    /// A slab floor 20 m square and 10 cm thick, its top at y = 0, and a ball on it.
    fn floor_and_ball() -> World {
        let floor = (cuboid("floor", glam::Vec3::new(20.0, 0.1, 20.0), 0), DVec3::new(0.0, -0.05, 0.0));
        let ball = (ellipsoid("ball", glam::Vec3::splat(1.0), 12, 24, 0), DVec3::new(0.0, 1.0, 0.0));
        crate::scene::test_world(vec![floor, ball], None)
    }

    /// A ray in scene units from `from` towards `to`, in render space.
    fn ray(w: &World, from: DVec3, to: DVec3) -> (Vec3, Vec3) {
        let (a, b) = (w.to_render.point(from), w.to_render.point(to));
        (a, (b - a).normalize())
    }

    #[test]
    fn a_ray_past_the_floors_edge_runs_on_to_its_plane() {
        let w = floor_and_ball();
        let accel = Accel::new(&w);
        assert_eq!(w.backdrops.len(), 1);
        // From 1 m up beyond the floor's edge, down to y = 0 further out: a miss, then the
        // floor's top face where the ray crosses its plane, 30 m out.
        let (o, d) = ray(&w, DVec3::new(0.0, 1.0, 15.0), DVec3::new(0.0, 0.0, 30.0));
        assert!(accel.closest(o, d, 0.0, f32::INFINITY).is_none());
        let hit = run_on(&w, o, d, None).expect("runs on");
        assert_eq!(hit.object, 0);
        let at = w.to_render.inverse_point(w.point_at(hit.tri, hit.u, hit.v));
        assert!((at - DVec3::new(0.0, 0.0, 30.0)).length() < 1e-3, "{at}");
        assert!((w.to_render.inverse_point(o + d * hit.t) - at).length() < 1e-3);
        // Its surface is the floor's: facing up, the floor's material.
        let sp = crate::shading::surface(&w, &hit, o, d);
        assert!(sp.normal.dot(w.backdrops[0].normal) > 0.999);
    }

    #[test]
    fn a_floors_vertex_colours_hold_at_its_edge_where_it_runs_on() {
        // The floor's colour grey at its far side (z < 0), white at its near side: run on 20 m
        // past the far edge, the colours' weights would reach -1 and the albedo -0.6.
        let (mut floor, at) = (cuboid("floor", glam::Vec3::new(20.0, 0.1, 20.0), 0), DVec3::new(0.0, -0.05, 0.0));
        floor.colors = Some(
            floor
                .positions
                .iter()
                .map(|p| if p.z < 0.0 { glam::Vec4::new(0.2, 0.2, 0.2, 1.0) } else { glam::Vec4::ONE })
                .collect(),
        );
        let ball = (ellipsoid("ball", glam::Vec3::splat(1.0), 12, 24, 0), DVec3::new(0.0, 1.0, 0.0));
        let w = crate::scene::test_world(vec![(floor, at), ball], None);
        let (o, d) = ray(&w, DVec3::new(0.0, 1.0, -15.0), DVec3::new(0.0, 0.0, -30.0));
        let hit = run_on(&w, o, d, None).expect("runs on");
        let albedo = crate::shading::surface(&w, &hit, o, d).albedo;
        let base = w.materials[w.objects[0].material].base_color;
        for k in 0..3 {
            let c = albedo[k] / base[k];
            assert!((0.2 - 1e-5..=1.0 + 1e-5).contains(&c), "channel {k}: {c}");
        }
    }

    #[test]
    fn rays_away_from_below_or_hitting_something_do_not_run_on() {
        let w = floor_and_ball();
        let accel = Accel::new(&w);
        // Rising beyond the edge; level; from below the floor; a hit stays the hit.
        for (from, to) in [
            (DVec3::new(0.0, 1.0, 15.0), DVec3::new(0.0, 2.0, 30.0)),
            (DVec3::new(0.0, 1.0, 15.0), DVec3::new(0.0, 1.0, 30.0)),
            (DVec3::new(0.0, -1.0, 15.0), DVec3::new(0.0, -2.0, 30.0)),
        ] {
            let (o, d) = ray(&w, from, to);
            assert!(run_on(&w, o, d, None).is_none(), "{from} -> {to}");
        }
        let (o, d) = ray(&w, DVec3::new(0.0, 1.0, 5.0), DVec3::new(0.0, 1.0, 0.0));
        let hit = accel.closest(o, d, 0.0, f32::INFINITY).unwrap();
        assert_eq!(run_on(&w, o, d, Some(hit)), Some(hit));
        // Past the reach: a floor is not run on to the horizon.
        let (o, d) = ray(&w, DVec3::new(0.0, 1.0, 15.0), DVec3::new(0.0, 0.0, 1000.0));
        assert!(run_on(&w, o, d, None).is_none());
        // Without backdrops nothing runs on.
        let ball = (ellipsoid("ball", glam::Vec3::splat(1.0), 12, 24, 0), DVec3::ZERO);
        let w = crate::scene::test_world(vec![ball], None);
        let (o, d) = ray(&w, DVec3::new(0.0, 3.0, 5.0), DVec3::new(0.0, -3.0, 10.0));
        assert!(run_on(&w, o, d, None).is_none());
    }

    #[test]
    fn barycentrics_inside_and_beyond_a_triangle() {
        let tri = [DVec3::ZERO, DVec3::X, DVec3::Y];
        let (u, v) = barycentrics(tri, DVec3::new(0.25, 0.5, 0.0)).unwrap();
        assert!((u - 0.25).abs() < 1e-12 && (v - 0.5).abs() < 1e-12);
        let (u, v) = barycentrics(tri, DVec3::new(-3.0, 7.0, 0.0)).unwrap();
        assert!((u + 3.0).abs() < 1e-12 && (v - 7.0).abs() < 1e-12);
        assert!(barycentrics([DVec3::ZERO, DVec3::X, DVec3::X * 2.0], DVec3::Y).is_none());
    }

    /// A ray past the floor slab's edge that meets its side face below the floor's plane is
    /// given the floor's plane where it crossed it (no strip of the slab's edge); a ray through
    /// a hole in a floor stays a miss; a wall the subject does not touch does not run on.
    #[test]
    fn edges_holes_and_walls_apart() {
        let slab = (cuboid("floor", glam::Vec3::new(20.0, 0.2, 20.0), 0), DVec3::new(0.0, -0.1, 0.0));
        let ball = (ellipsoid("ball", glam::Vec3::splat(1.0), 12, 24, 0), DVec3::new(0.0, 1.0, 0.0));
        let w = crate::scene::test_world(vec![slab, ball.clone()], None);
        let accel = Accel::new(&w);
        let (o, d) = ray(&w, DVec3::new(0.0, 1.0, 10.22), DVec3::new(0.0, -1.0, 9.82));
        let side = accel.closest(o, d, 0.0, f32::INFINITY).expect("the slab's side face");
        let hit = run_on(&w, o, d, Some(side)).unwrap();
        assert!(hit.t < side.t);
        let at = w.to_render.inverse_point(o + d * hit.t);
        assert!((at - DVec3::new(0.0, 0.0, 10.02)).length() < 1e-3, "{at}");
        // Two strips of floor, a metre apart: through the gap, nothing.
        let mut strips = cuboid("strip", glam::Vec3::new(20.0, 0.1, 9.5), 0);
        let other = cuboid("strip", glam::Vec3::new(20.0, 0.1, 9.5), 0);
        let n = strips.positions.len() as u32;
        strips.positions.iter_mut().for_each(|p| p.z -= 5.25);
        strips.positions.extend(other.positions.iter().map(|p| *p + glam::Vec3::Z * 5.25));
        strips.normals.extend(other.normals);
        strips.triangles.extend(other.triangles.iter().map(|t| t.map(|i| i + n)));
        let w = crate::scene::test_world(vec![(strips, DVec3::new(0.0, -0.05, 0.0)), ball.clone()], None);
        assert_eq!(w.backdrops.len(), 1);
        let (o, d) = ray(&w, DVec3::new(3.0, 1.0, 1.0), DVec3::new(3.0, -1.0, -1.0));
        assert!(accel_miss(&w, o, d) && run_on(&w, o, d, None).is_none());
        // A floor and a wall 8 m behind the ball: the floor runs on, the wall does not.
        let floor = (cuboid("floor", glam::Vec3::new(20.0, 0.02, 20.0), 0), DVec3::new(0.0, -0.01, 0.0));
        let wall = (cuboid("wall", glam::Vec3::new(20.0, 10.0, 0.02), 0), DVec3::new(0.0, 5.0, -8.0));
        let w = crate::scene::test_world(vec![floor, wall, ball], None);
        let faces: Vec<(usize, bool)> = w.backdrops.iter().map(|b| (b.object, b.face.is_some())).collect();
        assert_eq!(faces, vec![(0, true), (1, false)]);
    }

    fn accel_miss(w: &World, o: Vec3, d: Vec3) -> bool {
        Accel::new(w).closest(o, d, 0.0, f32::INFINITY).is_none()
    }
}
