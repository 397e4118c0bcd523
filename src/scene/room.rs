//! Open rooms: a floor and walls modelled as slabs, the furniture standing in the corner they
//! make, as Blender users build interiors and stage sets. Their sides are backdrops
//! (`backdrop`) though hardly larger than the furniture: framed with them, the picture was the
//! whole corner seen from outside its edges, a box floating in black, the furniture small in
//! it. A side is a large slab that meets another at right angles, facing the way the other
//! runs, with everything else on that side; a chair built of boards has its legs below its seat
//! and its back above, so it is never a room (an open crate or a bookcase of boards with things
//! in it would be). What hangs flat on a side (a picture, a window, a rug) is setting too: framed
//! with a window on the far wall, a figure seated in the room was a third of the canvas tall.

use glam::DVec3;

use super::World;

/// A side of a room is a slab: every corner within this share of its extent of one plane (a
/// wall 25 cm thick in a room 2.5 m across).
pub const SLAB_SHARE: f64 = 0.1;
/// A side of a room is at least this many times the extent of the largest object that is not
/// a slab (a sofa in a small room).
pub const ROOM_RATIO: f64 = 1.5;
/// A side of a room spans at least this share of the whole scene's extent.
pub const ROOM_SHARE: f64 = 0.5;
/// Two sides meet at right angles: the cosine between their normals at most this (10 deg).
const RIGHT_ANGLE_COS: f64 = 0.17;
/// Two sides meet: the gap between their boxes at most this share of the smaller one's extent.
const MEET_SHARE: f64 = 0.02;
/// A slab hangs on a side when parallel to it (the cosine between their normals at least this,
/// 10 deg), over it and within this share of the side's extent of its faces (a picture, a
/// window, a rug; not a table top over a large floor, nor a sofa's back before a wall).
const PARALLEL_COS: f64 = 0.985;
const HANG_SHARE: f64 = 0.02;

/// A slab among the candidates: object, unit normal, a point of its plane (render space).
pub type Slab = (usize, DVec3, DVec3);

/// An open room's sides and what hangs flat on them.
#[derive(Debug, Default)]
pub struct Room {
    pub sides: Vec<Slab>,
    pub hangings: Vec<Slab>,
}

/// The sides of an open room among `candidates` (the largest objects of `world`, its objects'
/// `bounds` made) and what hangs on them; neither when nothing else is left. The sides: the
/// slabs at least `ROOM_RATIO` times the largest other object and `ROOM_SHARE` of the scene
/// that meet another such at right angles, each with every object that is not such a slab on
/// the side the others run to (in `candidates`' order, each normal facing in). What hangs on
/// them: the slabs parallel to a side and on it (in object order).
pub fn sides(world: &World, candidates: &[usize]) -> Room {
    let objects = &world.objects;
    let bounds = |o: usize| objects[o].bounds.map(|(lo, hi, _)| (lo.as_dvec3(), hi.as_dvec3()));
    let extent = |o: usize| bounds(o).map_or(0.0, |(lo, hi)| (hi - lo).length());
    let slabs: Vec<Slab> = candidates
        .iter()
        .filter_map(|&o| super::backdrop::plane_within(world, o, extent(o), SLAB_SHARE).map(|(n, p)| (o, n, p)))
        .collect();
    let is_slab = |o: usize| slabs.iter().any(|s| s.0 == o);
    let largest = (0..objects.len()).filter(|&o| !is_slab(o)).map(extent).fold(0.0, f64::max);
    let scene = (world.bounds.1 - world.bounds.0).as_dvec3().length();
    let least = (ROOM_RATIO * largest).max(ROOM_SHARE * scene);
    let large: Vec<Slab> = slabs.into_iter().filter(|s| extent(s.0) >= least && least > 0.0).collect();
    let meet = |a: &Slab, b: &Slab| {
        let (Some((alo, ahi)), Some((blo, bhi))) = (bounds(a.0), bounds(b.0)) else { return false };
        let gap = (blo - ahi).max(alo - bhi).max(DVec3::ZERO).length();
        a.0 != b.0 && a.1.dot(b.1).abs() <= RIGHT_ANGLE_COS && gap <= MEET_SHARE * extent(a.0).min(extent(b.0))
    };
    let meeting: Vec<Slab> = large.iter().filter(|a| large.iter().any(|b| meet(a, b))).copied().collect();
    if meeting.is_empty() {
        return Room::default();
    }
    let others: Vec<usize> = (0..objects.len()).filter(|&o| !large.iter().any(|s| s.0 == o)).collect();
    // Each side faces into the room, the way the sides it meets run from it (a floor faces up,
    // where its walls rise), and everything else stands on that side: a chair's seat has its
    // back above it and its legs below, so it is no floor.
    let inward = |side: &Slab| {
        let (o, normal, point) = *side;
        let level = point.dot(normal);
        let run: f64 = meeting
            .iter()
            .filter(|b| meet(side, b))
            .map(|b| {
                let (a, c) = span(world, b.0, normal);
                0.5 * (a + c) - level
            })
            .sum();
        let normal = if run > 0.0 { normal } else { -normal };
        let tolerance = SLAB_SHARE * extent(o);
        let level = point.dot(normal);
        let inside = |other: usize| {
            let Some((lo, hi)) = bounds(other) else { return true };
            super::backdrop::box_corners(lo, hi).all(|c| c.dot(normal) >= level - tolerance)
                || span(world, other, normal).0 >= level - tolerance
        };
        (run.abs() > 0.0 && others.iter().all(|&other| inside(other))).then_some((o, normal, point))
    };
    let facing: Vec<Slab> = meeting.iter().filter_map(inward).collect();
    let sides: Vec<Slab> = facing.iter().filter(|a| facing.iter().any(|b| meet(a, b))).copied().collect();
    if sides.is_empty() {
        return Room::default();
    }
    // What hangs on a side: parallel to it, over it, and no further from its faces than
    // `HANG_SHARE` of its size.
    let near = |o: usize, &(side, _, _): &Slab| {
        let (Some((lo, hi)), Some((slo, shi))) = (bounds(o), bounds(side)) else { return false };
        let reach = DVec3::splat(HANG_SHARE * extent(side));
        lo.cmple(shi + reach).all() && hi.cmpge(slo - reach).all()
    };
    let lies_on = |o: usize, normal: DVec3, &(side, side_normal, _): &Slab| {
        let tolerance = HANG_SHARE * extent(side);
        let ((a, b), (sa, sb)) = (span(world, o, side_normal), span(world, side, side_normal));
        normal.dot(side_normal).abs() >= PARALLEL_COS && a >= sa - tolerance && b <= sb + tolerance
    };
    let mut hangings = Vec::new();
    for o in 0..objects.len() {
        let close: Vec<&Slab> = sides.iter().filter(|side| near(o, side)).collect();
        if close.is_empty() || sides.iter().chain(&hangings).any(|s| s.0 == o) {
            continue;
        }
        if let Some((normal, point)) = super::backdrop::plane_within(world, o, extent(o), SLAB_SHARE)
            && close.iter().any(|side| lies_on(o, normal, side))
        {
            hangings.push((o, normal, point));
        }
    }
    // A room with nothing standing in it is its own subject.
    if sides.len() + hangings.len() >= objects.iter().filter(|o| o.bounds.is_some()).count() {
        return Room::default();
    }
    Room { sides, hangings }
}

/// The least and greatest of `normal . p` over object `o`'s corners (render space), of up to
/// `SPAN_SAMPLE` of its triangles evenly spread: how far it reaches either way along `normal`.
fn span(world: &World, o: usize, normal: DVec3) -> (f64, f64) {
    super::backdrop::sampled(world, o, SPAN_SAMPLE)
        .flatten()
        .filter(|p| p.is_finite())
        .map(|p| p.dot(normal))
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), d| (a.min(d), b.max(d)))
}

/// Triangles of an object read for its reach along a side's normal (evenly spread).
const SPAN_SAMPLE: usize = 256;

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::framing::subject::Subject;
    use crate::scene::Mesh;
    use crate::scene::default::{cuboid, ellipsoid};

    fn scene(parts: Vec<(Mesh, DVec3)>, camera: Option<DVec3>) -> World {
        crate::scene::test_world(parts, camera)
    }

    fn slab(size: Vec3, at: DVec3) -> (Mesh, DVec3) {
        (cuboid("slab", size, 0), at)
    }

    /// A room `side` wide and 2.5 high, walls `thick`: the floor under y = 0, the back wall
    /// behind z = -side / 2, the left wall left of x = -side / 2.
    fn corner(side: f32, thick: f32) -> Vec<(Mesh, DVec3)> {
        let (h, t) = (side as f64 * 0.5, thick as f64 * 0.5);
        vec![
            slab(Vec3::new(side, thick, side), DVec3::new(0.0, -t, 0.0)),
            slab(Vec3::new(side, 2.5, thick), DVec3::new(0.0, 1.25, -h - t)),
            slab(Vec3::new(thick, 2.5, side), DVec3::new(-h - t, 1.25, 0.0)),
        ]
    }

    /// Furniture: a table-sized box and a ball on the floor, a picture on the back wall.
    fn furniture(side: f64) -> Vec<(Mesh, DVec3)> {
        vec![
            (cuboid("table", Vec3::new(1.1, 0.75, 0.7), 0), DVec3::new(0.2, 0.375, -0.3)),
            (ellipsoid("ball", Vec3::splat(0.3), 12, 24, 0), DVec3::new(-0.6, 0.3, 0.2)),
            (cuboid("picture", Vec3::new(0.7, 0.5, 0.03), 0), DVec3::new(0.0, 1.6, -side * 0.5 + 0.015)),
        ]
    }

    fn backdrop_objects(w: &World) -> Vec<usize> {
        w.backdrops.iter().map(|b| b.object).collect()
    }

    #[test]
    fn the_floor_and_walls_of_an_open_room_are_backdrops_facing_in() {
        for (side, thick) in [(3.0, 0.05), (3.5, 0.25), (5.0, 0.15)] {
            let mut parts = corner(side, thick);
            parts.extend(furniture(side as f64));
            let w = scene(parts, Some(DVec3::new(2.2, 1.7, 2.8)));
            // The floor and the two walls, then the picture on the back wall.
            assert_eq!(backdrop_objects(&w), vec![0, 1, 2, 5], "room {side} m, walls {thick} m");
            // Each faces the furniture: the table's centre is in front of every side.
            let table = w.to_render.point(DVec3::new(0.2, 0.375, -0.3));
            assert!(w.backdrops.iter().all(|b| !b.behind(table)), "{:?}", w.backdrops);
            // The floor's plane is its top face.
            let floor = w.backdrops[0];
            assert!(floor.behind(w.to_render.point(DVec3::new(0.0, -0.02, 0.0))));
            assert!(!floor.behind(w.to_render.point(DVec3::new(0.0, 0.02, 0.0))));
            // The floor runs on past its edges, on its top face; the walls, which nothing stands
            // against, and the picture do not.
            let faces: Vec<bool> = w.backdrops.iter().map(|b| b.face.is_some()).collect();
            assert_eq!(faces, vec![true, false, false, false]);
            for b in &w.backdrops[..1] {
                let corners = w.triangle(b.face.unwrap());
                assert!(corners.iter().all(|p| (b.normal.dot(*p) - b.offset).abs() < 1e-5), "{b:?}");
            }
        }
    }

    #[test]
    fn what_hangs_flat_on_a_side_is_setting_and_what_stands_out_from_it_is_not() {
        let mut parts = corner(3.5, 0.25);
        parts.extend(furniture(3.5));
        // A rug on the floor, a window in the left wall's inner face, a shelf (a board standing
        // out from the back wall) and a cupboard against it (not a slab).
        parts.push(slab(Vec3::new(1.2, 0.01, 0.8), DVec3::new(0.3, 0.005, 0.5)));
        parts.push(slab(Vec3::new(0.03, 0.8, 0.9), DVec3::new(-1.735, 1.5, 0.3)));
        parts.push(slab(Vec3::new(1.0, 0.03, 0.25), DVec3::new(-0.8, 1.4, -1.625)));
        parts.push(slab(Vec3::new(0.8, 1.8, 0.5), DVec3::new(1.2, 0.9, -1.5)));
        let w = scene(parts, Some(DVec3::new(2.2, 1.7, 2.8)));
        assert_eq!(backdrop_objects(&w), vec![0, 1, 2, 5, 6, 7], "{:?}", w.backdrops);
        assert!(w.backdrops[3..].iter().all(|b| b.face.is_none()), "{:?}", w.backdrops);
    }

    proptest::proptest! {
        /// The room is found whichever way it is turned (a z-up export, a tilted set) and at
        /// any scale (millimetres to kilometres).
        #[test]
        fn a_room_is_found_turned_and_scaled_any_way(
            axis in (-1.0f32..1.0, -1.0f32..1.0, -1.0f32..1.0),
            angle in -3.2f32..3.2,
            scale in -3.0f32..3.0,
        ) {
            let axis = Vec3::new(axis.0, axis.1, axis.2).try_normalize().unwrap_or(Vec3::Y);
            let (turn, size) = (glam::Quat::from_axis_angle(axis, angle), 10f32.powf(scale));
            let mut parts = corner(3.5, 0.25);
            parts.extend(furniture(3.5));
            let parts: Vec<(Mesh, DVec3)> = parts
                .into_iter()
                .map(|(mut mesh, at)| {
                    let at = at.as_vec3();
                    mesh.positions.iter_mut().for_each(|p| *p = turn * ((*p + at) * size));
                    mesh.normals.iter_mut().for_each(|n| *n = turn * *n);
                    (mesh, DVec3::ZERO)
                })
                .collect();
            let w = scene(parts, None);
            proptest::prop_assert_eq!(backdrop_objects(&w), vec![0, 1, 2, 5]);
        }
    }

    /// The cameras are framed around the furniture, not the corner.
    #[test]
    fn the_subject_is_the_furniture() {
        let mut parts = corner(3.0, 0.05);
        parts.extend(furniture(3.0));
        let w = scene(parts, Some(DVec3::new(2.2, 1.7, 2.8)));
        let subject = Subject::new(&w, 5000, 500, None);
        // The furniture's box (scene units): the table and the ball (the picture hangs on the
        // wall).
        let (lo, hi) = (DVec3::new(-0.9, 0.0, -0.65), DVec3::new(0.75, 0.75, 0.5));
        let centre = w.to_render.point_f64((lo + hi) * 0.5);
        let half_diagonal = 0.5 * (hi - lo).length() * w.to_render.scale;
        assert!((subject.centre - centre).length() < 0.02 * half_diagonal, "{:?} vs {centre:?}", subject.centre);
        assert!(subject.radius <= half_diagonal * 1.001, "{} vs {half_diagonal}", subject.radius);
        assert!(subject.radius > 0.8 * half_diagonal, "{} vs {half_diagonal}", subject.radius);
        // The corner's half-diagonal is about 1 in render units: the furniture under half.
        assert!(subject.radius < 0.45, "{}", subject.radius);
    }

    #[test]
    fn boards_of_furniture_sides_apart_and_crowded_rooms_are_not_rooms() {
        // A chair of boards alone: a seat with its legs below and its back rising above it.
        let chair = vec![
            slab(Vec3::new(1.0, 0.04, 1.0), DVec3::new(0.0, 0.45, 0.0)),
            slab(Vec3::new(1.0, 1.0, 0.04), DVec3::new(0.0, 0.97, -0.48)),
            slab(Vec3::new(0.05, 0.45, 0.05), DVec3::new(0.45, 0.225, 0.45)),
            slab(Vec3::new(0.05, 0.45, 0.05), DVec3::new(-0.45, 0.225, 0.45)),
        ];
        assert!(scene(chair.clone(), None).backdrops.is_empty());
        // The same with a cushion on its seat.
        let mut cushioned = chair;
        cushioned.push((ellipsoid("cushion", Vec3::new(0.3, 0.08, 0.3), 12, 24, 0), DVec3::new(0.0, 0.55, 0.0)));
        assert!(scene(cushioned, None).backdrops.is_empty());
        // A floor and a wall that do not meet (a gap of a metre between them).
        let mut apart = corner(3.0, 0.05);
        apart.truncate(2);
        apart[1].1.z -= 1.0;
        apart.extend(furniture(5.0));
        assert!(scene(apart, None).backdrops.is_empty());
        // Furniture larger than the room's sides allow (a 2.5 m wardrobe in a 3 m room).
        let mut crowded = corner(3.0, 0.05);
        crowded.push((cuboid("wardrobe", Vec3::new(1.2, 2.4, 0.6), 0), DVec3::new(0.5, 1.2, -1.2)));
        assert!(scene(crowded, None).backdrops.is_empty());
        // Something behind the back wall: that wall faces it too, so it is no side; the floor
        // and the left wall still make a corner with everything in it (the picture on the back
        // wall then hangs on no side).
        let mut behind = corner(3.0, 0.05);
        behind.extend(furniture(3.0));
        behind.push((ellipsoid("outside", Vec3::splat(0.3), 12, 24, 0), DVec3::new(0.0, 0.3, -2.5)));
        assert_eq!(backdrop_objects(&scene(behind, None)), vec![0, 2]);
        // An empty corner (a rug its only content) is its own subject.
        let mut empty = corner(3.0, 0.05);
        empty.push(slab(Vec3::new(1.2, 0.01, 0.8), DVec3::new(0.3, 0.005, 0.5)));
        assert!(scene(empty, None).backdrops.is_empty());
    }

    /// In a large room a table top a few percent of the room's size above the floor stands on
    /// legs; it does not lie on the floor.
    #[test]
    fn a_table_top_in_a_large_room_is_furniture() {
        let mut parts = corner(12.0, 0.2);
        parts.push(slab(Vec3::new(1.4, 0.03, 0.8), DVec3::new(0.0, 0.735, 0.0)));
        for (x, z) in [(-0.65, -0.35), (0.65, -0.35), (-0.65, 0.35), (0.65, 0.35)] {
            parts.push(slab(Vec3::new(0.05, 0.72, 0.05), DVec3::new(x, 0.36, z)));
        }
        let w = scene(parts, Some(DVec3::new(4.0, 1.7, 4.0)));
        assert_eq!(backdrop_objects(&w), vec![0, 1, 2], "{:?}", w.backdrops);
    }
}
