//! Backdrops: a floor, a wall or a shadow-catcher plane much larger than everything else in
//! the scene, as most scenes made in Blender stand their objects on one, and the sides of an
//! open room (`room`), so the subject, not the floor, fills the canvas. A backdrop is rendered,
//! shaded and faceted like anything else, but:
//! - the cameras are framed around the scene without it (`framing::subject`): with it, objects
//!   on a 20 m floor were a few pixels tall on a kite of floor;
//! - it has one side, the subject's: a ray that starts behind its plane passes through it
//!   (`Accel`). A converging camera wraps around its subject, so the rays of the lower rows
//!   start below the floor, and the floor's unlit underside covered the lower half of the
//!   canvas; through it they see the subject from below, another of its sides;
//! - when the subject stands on or against it, it runs on past its edges (`trace::run_on`): a
//!   ray that misses everything and meets its plane from the subject's side shows it there, as a
//!   floor continued under a room's furniture where the camera looks past the floor's near edge.
//!   What hangs on a room's side does not.

use glam::{DVec3, Vec3};

use super::World;

/// A backdrop is flat: every corner within this share of its extent of one plane (a plane, or
/// a box a few centimetres thick).
pub const FLAT_SHARE: f64 = 0.01;
/// A backdrop is large: its extent at least this many times the extent of everything that is
/// not a backdrop (a sheet of paper on a table, a picture on a wall stay part of the subject).
pub const BACKDROP_RATIO: f64 = 2.0;
/// The largest objects (by extent) tested for flatness: backdrops are among the largest.
const CANDIDATES: usize = 8;
/// Triangles of an object read to decide whether it is flat (evenly spread over it).
const FLAT_SAMPLE: usize = 4096;

/// A backdrop object and its plane (render space): `normal . p = offset` through its corner
/// nearest the subject, `normal` (unit) towards the subject.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Backdrop {
    pub object: usize,
    pub normal: Vec3,
    pub offset: f32,
    /// Its largest triangle on that plane, which a ray missing everything runs on to past the
    /// backdrop's edges (`trace::run_on`); None when no triangle lies on it.
    pub face: Option<u32>,
    /// A sweep modelled in one layer (`sweep`): its one side is its triangles' (rays meeting a
    /// triangle from behind pass it, `Accel`), not its plane's; true when their winding faces
    /// the subject. None: rays starting behind the plane pass the whole object.
    pub winding: Option<bool>,
}

impl Backdrop {
    /// Whether `p` lies behind the plane, on the side away from the subject.
    #[inline]
    pub fn behind(&self, p: Vec3) -> bool {
        self.normal.dot(p) < self.offset
    }
}

/// The backdrops of `world` (its objects' `bounds` made): the flat ones among the
/// `CANDIDATES` largest objects that are `BACKDROP_RATIO` times larger than the box of every
/// object that is not flat, and the sides of an open room among them (`room::sides`), in
/// object order. None when every object is flat (a board alone is its own subject).
pub fn backdrops(world: &World) -> Vec<Backdrop> {
    let objects = &world.objects;
    let bounds = |o: usize| objects[o].bounds.map(|(lo, hi, _)| (lo.as_dvec3(), hi.as_dvec3()));
    let extent = |o: usize| bounds(o).map_or(0.0, |(lo, hi)| (hi - lo).length());
    let mut by_size: Vec<usize> = (0..objects.len()).filter(|&o| bounds(o).is_some()).collect();
    by_size.sort_by(|&a, &b| extent(b).total_cmp(&extent(a)).then(a.cmp(&b)));
    let flat: Vec<(usize, DVec3, DVec3)> = by_size
        .iter()
        .take(CANDIDATES)
        .filter_map(|&o| plane_of(world, o, extent(o)).map(|(n, p)| (o, n, p)))
        .collect();
    let box_without = |skip: &dyn Fn(usize) -> bool| {
        (0..objects.len())
            .filter(|&o| !skip(o))
            .filter_map(bounds)
            .fold((DVec3::INFINITY, DVec3::NEG_INFINITY), |(lo, hi), (a, b)| (lo.min(a), hi.max(b)))
    };
    let (lo, hi) = box_without(&|o| flat.iter().any(|f| f.0 == o));
    if !lo.is_finite() {
        return Vec::new();
    }
    let solid = (hi - lo).length();
    let mut chosen: Vec<(usize, DVec3, DVec3)> =
        flat.into_iter().filter(|f| extent(f.0) >= BACKDROP_RATIO * solid).collect();
    let room = super::room::sides(world, &by_size[..by_size.len().min(CANDIDATES)]);
    // What hangs on a room's side does not run on past its edges: its plane lies in front of
    // the wall's.
    let hangs = |o: usize| room.hangings.iter().any(|h| h.0 == o);
    for side in room.sides.iter().chain(&room.hangings) {
        if !chosen.iter().any(|c| c.0 == side.0) {
            chosen.push(*side);
        }
    }
    // Sweeps (`sweep`): a sheet bent from a floor into a wall, as large as a backdrop; its plane
    // is its floor's.
    let sweeps: Vec<(usize, super::sweep::Sweep)> = by_size
        .iter()
        .take(CANDIDATES)
        .filter(|&&o| !chosen.iter().any(|c| c.0 == o))
        .filter_map(|&o| {
            let (lo, hi) = box_without(&|k| k == o || chosen.iter().any(|c| c.0 == k));
            let large = lo.is_finite() && extent(o) >= BACKDROP_RATIO * (hi - lo).length();
            large.then(|| super::sweep::sweep(world, o, (lo, hi)).map(|s| (o, s))).flatten()
        })
        .collect();
    // The subject's centre: the box of everything else.
    let (lo, hi) = box_without(&|o| chosen.iter().any(|f| f.0 == o) || sweeps.iter().any(|s| s.0 == o));
    let centre = (lo + hi) * 0.5;
    let planes = chosen.into_iter().map(|(o, normal, point)| {
        let normal = if (centre - point).dot(normal) >= 0.0 { normal } else { -normal };
        // The plane through the corner nearest the subject (a slab's top face).
        let offset = corners(world, o).map(|p| p.dot(normal)).fold(f64::NEG_INFINITY, f64::max);
        (o, normal, offset, !hangs(o), None)
    });
    let mut found: Vec<Backdrop> = planes
        .chain(sweeps.into_iter().map(|(o, s)| (o, s.normal, s.offset, true, s.winding)))
        .filter(|&(_, normal, offset, ..)| normal.is_finite() && offset.is_finite())
        .map(|(o, normal, offset, runs_on, winding)| {
            // Only what the subject stands on or against runs on: a floor to the canvas's
            // edge, not a low garden wall into the sky behind the subject.
            let touches = gap_to(lo, hi, normal, offset).abs() <= TOUCH_SHARE * (hi - lo).length();
            Backdrop {
                object: o,
                normal: normal.as_vec3(),
                offset: offset as f32,
                face: if runs_on && touches { face(world, o, normal, offset) } else { None },
                winding,
            }
        })
        .collect();
    found.sort_unstable_by_key(|b| b.object);
    found
}

/// The largest of object `o`'s sampled triangles whose corners lie on the plane
/// `normal . p = offset` (within `FACE_SHARE` of the object's extent) and which faces along
/// `normal` or against it: a slab's face towards the subject.
fn face(world: &World, o: usize, normal: DVec3, offset: f64) -> Option<u32> {
    let obj = &world.objects[o];
    let (lo, hi, _) = obj.bounds?;
    let tolerance = FACE_SHARE * (hi - lo).as_dvec3().length();
    let step = (obj.triangle_count as usize).div_ceil(FLAT_SAMPLE).max(1);
    (0..obj.triangle_count)
        .step_by(step)
        .map(|t| obj.first_triangle + t)
        .filter_map(|tri| {
            let [a, b, c] = world.triangle(tri).map(|p| p.as_dvec3());
            let cross = (b - a).cross(c - a);
            let on = [a, b, c].iter().all(|p| (p.dot(normal) - offset).abs() <= tolerance);
            let flat = cross.try_normalize().is_some_and(|n| n.dot(normal).abs() >= FACE_COS);
            // Its shading normals run on with it: a triangle whose vertex normals lean (the
            // start of a bevel) would tilt them further away from it.
            let geometry = &world.geometries[obj.geometry];
            let corners = geometry.triangles[(tri - obj.first_triangle) as usize];
            let upright = corners.iter().all(|&i| {
                let n = obj.normal(geometry.normals[i as usize]).as_dvec3();
                n.try_normalize().is_some_and(|n| n.dot(normal).abs() >= FACE_COS)
            });
            (on && flat).then_some((tri, upright, cross.length()))
        })
        .max_by(|a, b| a.1.cmp(&b.1).then(a.2.total_cmp(&b.2)).then(b.0.cmp(&a.0)))
        .map(|(tri, ..)| tri)
}

/// The subject touches a backdrop when its box is within this share of its extent of the
/// backdrop's plane.
const TOUCH_SHARE: f64 = 0.05;

/// The eight corners of the box `lo`..`hi`.
pub(super) fn box_corners(lo: DVec3, hi: DVec3) -> impl Iterator<Item = DVec3> {
    (0..8).map(move |k| DVec3::new([lo.x, hi.x][k & 1], [lo.y, hi.y][(k >> 1) & 1], [lo.z, hi.z][k >> 2]))
}

/// How far the box `lo`..`hi` stands in front of the plane `normal . p = offset`: its nearest
/// corner's distance, negative when it reaches behind.
pub(super) fn gap_to(lo: DVec3, hi: DVec3, normal: DVec3, offset: f64) -> f64 {
    box_corners(lo, hi).map(|c| c.dot(normal) - offset).fold(f64::INFINITY, f64::min)
}

/// A backdrop's face lies within this share of its extent of its plane.
const FACE_SHARE: f64 = 1e-4;
/// A backdrop's face is parallel to its plane: the cosine between their normals at least this.
const FACE_COS: f64 = 0.9999;

/// Up to `samples` of object `o`'s triangles (render space), evenly spread (every n-th).
pub(super) fn sampled(world: &World, o: usize, samples: usize) -> impl Iterator<Item = [DVec3; 3]> + '_ {
    let obj = &world.objects[o];
    let count = obj.triangle_count as usize;
    let step = count.div_ceil(samples).max(1);
    (0..count).step_by(step).map(move |t| world.triangle(obj.first_triangle + t as u32).map(|p| p.as_dvec3()))
}

/// Up to `FLAT_SAMPLE` of object `o`'s triangles, those with finite corners.
fn triangles(world: &World, o: usize) -> impl Iterator<Item = [DVec3; 3]> + '_ {
    sampled(world, o, FLAT_SAMPLE).filter(|t| t.iter().all(|p| p.is_finite()))
}

fn corners(world: &World, o: usize) -> impl Iterator<Item = DVec3> + '_ {
    triangles(world, o).flatten()
}

/// The plane (unit normal, a point) of object `o` when every corner of its sampled triangles
/// lies within `FLAT_SHARE` of `extent` of the plane of its largest triangle.
fn plane_of(world: &World, o: usize, extent: f64) -> Option<(DVec3, DVec3)> {
    plane_within(world, o, extent, FLAT_SHARE)
}

/// `plane_of` within `share` of `extent`.
pub(super) fn plane_within(world: &World, o: usize, extent: f64, share: f64) -> Option<(DVec3, DVec3)> {
    if extent <= 0.0 {
        return None;
    }
    let area2 = |t: &[DVec3; 3]| (t[1] - t[0]).cross(t[2] - t[0]).length_squared();
    let largest = triangles(world, o).max_by(|a, b| area2(a).total_cmp(&area2(b)))?;
    let normal = (largest[1] - largest[0]).cross(largest[2] - largest[0]).try_normalize()?;
    let tolerance = share * extent;
    corners(world, o).all(|p| (p - largest[0]).dot(normal).abs() <= tolerance).then_some((normal, largest[0]))
}

#[cfg(test)]
mod tests {
    use glam::{DVec3, Vec3};

    use super::*;
    use crate::scene::Mesh;
    use crate::scene::default::{cuboid, ellipsoid};

    /// A two-triangle square `size` wide at y = 0, facing +Y.
    fn plane(size: f32) -> Mesh {
        let h = size * 0.5;
        let positions =
            vec![Vec3::new(-h, 0.0, -h), Vec3::new(h, 0.0, -h), Vec3::new(h, 0.0, h), Vec3::new(-h, 0.0, h)];
        Mesh {
            name: "plane".into(),
            normals: vec![Vec3::Y; 4],
            positions,
            uvs: None,
            colors: None,
            triangles: vec![[0, 2, 1], [0, 3, 2]],
            material: None,
        }
    }

    fn scene(parts: Vec<(Mesh, DVec3)>) -> World {
        crate::scene::test_world(parts, None)
    }

    fn ball() -> (Mesh, DVec3) {
        (ellipsoid("ball", Vec3::splat(1.0), 12, 24, 0), DVec3::new(0.0, 1.0, 0.0))
    }

    #[test]
    fn a_floor_much_larger_than_the_objects_is_a_backdrop_facing_them() {
        let w = scene(vec![(plane(20.0), DVec3::ZERO), ball()]);
        assert_eq!(w.backdrops.len(), 1);
        let b = w.backdrops[0];
        assert_eq!(b.object, 0);
        // Facing up (the ball), through the floor.
        let up = w.to_render.point(DVec3::new(0.0, 1.0, 0.0)) - w.to_render.point(DVec3::ZERO);
        assert!(b.normal.dot(up.normalize()) > 0.999, "{b:?}");
        assert!(!b.behind(w.to_render.point(DVec3::new(3.0, 0.5, 2.0))));
        assert!(b.behind(w.to_render.point(DVec3::new(3.0, -0.5, 2.0))));
        // A slab 10 cm thick: its plane is its top face.
        let w = scene(vec![(cuboid("slab", Vec3::new(30.0, 0.1, 30.0), 0), DVec3::new(0.0, -0.05, 0.0)), ball()]);
        assert_eq!(w.backdrops.len(), 1);
        assert!(!w.backdrops[0].behind(w.to_render.point(DVec3::new(0.0, 0.001, 0.0))));
        assert!(w.backdrops[0].behind(w.to_render.point(DVec3::new(0.0, -0.02, 0.0))));
        // A floor and a wall behind: both.
        let mut wall = plane(20.0);
        wall.positions.iter_mut().for_each(|p| *p = Vec3::new(p.x, -p.z + 10.0, -10.0));
        let w = scene(vec![(plane(20.0), DVec3::ZERO), (wall, DVec3::ZERO), ball()]);
        assert_eq!(w.backdrops.iter().map(|b| b.object).collect::<Vec<_>>(), vec![0, 1]);
    }

    #[test]
    fn flat_things_the_size_of_the_subject_and_flat_scenes_have_no_backdrop() {
        // A sheet of paper beside the ball; a floor only as large as the ball; a board alone;
        // two boards.
        assert!(scene(vec![(plane(1.5), DVec3::new(2.0, 0.0, 0.0)), ball()]).backdrops.is_empty());
        assert!(scene(vec![(plane(3.0), DVec3::ZERO), ball()]).backdrops.is_empty());
        assert!(scene(vec![(plane(20.0), DVec3::ZERO)]).backdrops.is_empty());
        assert!(scene(vec![(plane(20.0), DVec3::ZERO), (plane(1.0), DVec3::Y)]).backdrops.is_empty());
        // A floor bent 5% of its extent: not flat.
        let mut bent = plane(20.0);
        bent.positions[2].y = 1.5;
        assert!(scene(vec![(bent, DVec3::ZERO), ball()]).backdrops.is_empty());
    }
}
