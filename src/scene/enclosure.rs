//! Enclosures: a room modelled as one closed mesh (a box with the furniture and the scene's
//! camera inside it), or a sky dome, as Blender users build interiors. A converging camera is
//! framed around the subject and wraps around it, so most of its rays start outside the room:
//! they hit the room's outer walls, and the picture was the closed box seen from outside with
//! everything the user put in it hidden. An enclosure is rendered, shaded and faceted like
//! anything else, but:
//! - the cameras are framed around the scene without it (`framing::subject`), as a backdrop;
//! - it has its inner side only: a ray entering it through a wall passes that wall (`Accel`),
//!   and sees the contents and the far walls from inside, as a cutaway; a ray from inside sees
//!   the walls as the scene's camera does;
//! - it casts no shadow: the renderer's lights are the painter's, not the room's lamps, and
//!   they would light nothing inside a closed box.
//!
//! An object is an enclosure when its surface closes around the scene camera's position and
//! around at least one other object (rays along six directions from each all meet it), so a
//! bowl holding fruit (open at the top) or a truck's body is never one, and a camera placed
//! inside an object with nothing else in it keeps that object as its subject.

use glam::DVec3;

use super::World;

/// Objects with more triangles than this are not tested (rooms and domes are simple shells;
/// the test reads every triangle six times per point).
pub const MAX_TRIANGLES: u32 = 200_000;
/// Other objects whose enclosure is tested, nearest the camera first: one enclosed is enough.
const OTHERS_TESTED: usize = 16;

/// Directions of the closedness test: the six axes, each tilted a little off them so a ray
/// does not run along the edges and diagonals of a box's triangles.
const DIRECTIONS: [[f64; 3]; 6] = [
    [1.0, 0.0123, 0.0271],
    [-1.0, 0.0191, -0.0137],
    [0.0217, 1.0, 0.0113],
    [-0.0149, -1.0, 0.0233],
    [0.0131, -0.0259, 1.0],
    [-0.0241, 0.0167, -1.0],
];

/// An enclosure object and which way its triangles' winding faces: `outward` when the normals
/// their winding gives (corners counter-clockwise) point out of it (a box as modelled), false
/// when they point in (a room whose normals were flipped).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Enclosure {
    pub object: usize,
    pub outward: bool,
}

/// The enclosures of `world` (its objects' `bounds` made) around `camera` (render space), in
/// object order; none without a camera. Backdrops are neither enclosures nor contents.
pub fn enclosures(world: &World, camera: Option<DVec3>) -> Vec<Enclosure> {
    let Some(eye) = camera.filter(|c| c.is_finite()) else { return Vec::new() };
    let objects = &world.objects;
    let backdrop = |o: usize| world.backdrops.iter().any(|b| b.object == o);
    let inside_box = |o: usize, p: DVec3| {
        objects[o].bounds.is_some_and(|(lo, hi, _)| p.cmpge(lo.as_dvec3()).all() && p.cmple(hi.as_dvec3()).all())
    };
    let centre = |o: usize| objects[o].bounds.map(|(lo, hi, _)| (lo.as_dvec3() + hi.as_dvec3()) * 0.5);
    let candidates: Vec<usize> = (0..objects.len())
        .filter(|&o| !backdrop(o) && objects[o].triangle_count <= MAX_TRIANGLES && inside_box(o, eye))
        .collect();
    let mut found = Vec::new();
    for &o in &candidates {
        let tris: Vec<[DVec3; 3]> = (0..objects[o].triangle_count)
            .map(|t| world.triangle(objects[o].first_triangle + t).map(|p| p.as_dvec3()))
            .filter(|t| t.iter().all(|p| p.is_finite()))
            .collect();
        if !closes_around(&tris, eye) {
            continue;
        }
        // Another object inside it: the nearest few to the camera whose box centre it holds.
        let mut others: Vec<(f64, DVec3)> = (0..objects.len())
            .filter(|&k| k != o && !backdrop(k))
            .filter_map(|k| centre(k).filter(|&c| inside_box(o, c)).map(|c| ((c - eye).length_squared(), c)))
            .collect();
        others.sort_by(|a, b| a.0.total_cmp(&b.0));
        if !others.iter().take(OTHERS_TESTED).any(|&(_, c)| closes_around(&tris, c)) {
            continue;
        }
        // The signed volume seen from the camera: positive when the winding faces out.
        let volume: f64 = tris.iter().map(|t| (t[0] - eye).dot((t[1] - eye).cross(t[2] - eye))).sum();
        found.push(Enclosure { object: o, outward: volume > 0.0 });
    }
    found
}

/// Whether the triangles close around `p`: a ray from `p` along each of `DIRECTIONS` meets one.
fn closes_around(tris: &[[DVec3; 3]], p: DVec3) -> bool {
    DIRECTIONS.iter().all(|d| {
        let d = DVec3::from(*d);
        tris.iter().any(|t| meets(t, p, d))
    })
}

/// Whether the ray `p + t d`, t > 0, meets triangle `t` (Moller-Trumbore, both faces).
fn meets(t: &[DVec3; 3], p: DVec3, d: DVec3) -> bool {
    let (e1, e2) = (t[1] - t[0], t[2] - t[0]);
    let h = d.cross(e2);
    let det = e1.dot(h);
    if det.abs() < 1e-300 {
        return false;
    }
    let inv = 1.0 / det;
    let s = p - t[0];
    let u = s.dot(h) * inv;
    if !(0.0..=1.0).contains(&u) {
        return false;
    }
    let q = s.cross(e1);
    let v = d.dot(q) * inv;
    if v < 0.0 || u + v > 1.0 {
        return false;
    }
    e2.dot(q) * inv > 0.0
}

#[cfg(test)]
mod tests {
    use glam::Vec3;

    use super::*;
    use crate::scene::Mesh;
    use crate::scene::default::{cuboid, ellipsoid};

    fn scene(parts: Vec<(Mesh, DVec3)>, camera: Option<DVec3>) -> World {
        crate::scene::test_world(parts, camera)
    }

    fn room() -> (Mesh, DVec3) {
        (cuboid("room", Vec3::new(10.0, 5.0, 10.0), 0), DVec3::new(0.0, 2.5, 0.0))
    }

    fn ball(at: DVec3) -> (Mesh, DVec3) {
        (ellipsoid("ball", Vec3::splat(0.5), 12, 24, 0), at)
    }

    #[test]
    fn a_closed_room_around_the_camera_and_its_contents_is_an_enclosure() {
        let w = scene(vec![room(), ball(DVec3::new(0.0, 0.5, -2.0))], Some(DVec3::new(0.0, 1.6, 4.0)));
        assert_eq!(w.enclosures, vec![Enclosure { object: 0, outward: true }]);
        // Its normals flipped (faces wound the other way): still one, facing in.
        let (mut mesh, at) = room();
        mesh.triangles.iter_mut().for_each(|t| t.swap(1, 2));
        let w = scene(vec![(mesh, at), ball(DVec3::new(0.0, 0.5, -2.0))], Some(DVec3::new(0.0, 1.6, 4.0)));
        assert_eq!(w.enclosures, vec![Enclosure { object: 0, outward: false }]);
    }

    /// The cameras are framed around the contents, not the walls (`framing::subject`).
    #[test]
    fn the_subject_is_the_rooms_contents() {
        let w = scene(vec![room(), ball(DVec3::new(0.0, 0.5, -2.0))], Some(DVec3::new(0.0, 1.6, 4.0)));
        let subject = crate::framing::subject::Subject::new(&w, 5000, 500, None);
        let ball_centre = w.to_render.point_f64(DVec3::new(0.0, 0.5, -2.0));
        // The ball's radius, 0.5, in render units; the room's half-diagonal is 1.
        let r = 0.5 * w.to_render.scale;
        assert!((subject.centre - ball_centre).length() < 0.1 * r, "{:?} vs {ball_centre:?}", subject.centre);
        assert!(subject.radius < 1.1 * r, "{} vs {r}", subject.radius);
    }

    #[test]
    fn open_shells_other_cameras_and_empty_rooms_are_not_enclosures() {
        let contents = ball(DVec3::new(0.0, 0.5, -2.0));
        // No camera; a camera outside the room.
        assert!(scene(vec![room(), contents.clone()], None).enclosures.is_empty());
        assert!(scene(vec![room(), contents.clone()], Some(DVec3::new(0.0, 1.6, 14.0))).enclosures.is_empty());
        // A room without its ceiling (two triangles facing up at y = 5).
        let (mut open, at) = room();
        let top: Vec<usize> = (0..open.triangles.len())
            .filter(|&t| open.triangles[t].iter().all(|&i| open.positions[i as usize].y > 2.4))
            .collect();
        assert_eq!(top.len(), 2);
        for t in top.into_iter().rev() {
            open.triangles.remove(t);
        }
        assert!(scene(vec![(open, at), contents.clone()], Some(DVec3::new(0.0, 1.6, 4.0))).enclosures.is_empty());
        // The camera inside a closed object with nothing else in it: that object is the subject.
        assert!(scene(vec![room(), ball(DVec3::new(30.0, 0.5, 0.0))], Some(DVec3::ZERO)).enclosures.is_empty());
    }
}
