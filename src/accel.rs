//! Ray queries against the scene's triangles: the only user of obvhs (BVH2 build, closest hit,
//! occlusion).

use std::time::Duration;

use glam::{Vec3, Vec3A};
use obvhs::{BvhBuildParams, bvh2::Bvh2, bvh2::builder::build_bvh2_from_tris, ray::Ray, triangle::Triangle};

use crate::scene::World;

/// A closest hit: `tri` indexes `World::positions`; the hit point is
/// `(1 - u - v) p0 + u p1 + v p2`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub tri: u32,
    pub t: f32,
    pub u: f32,
    pub v: f32,
}

/// A ray prepared for the watertight triangle test (Woop, Benthin and Wald, "Watertight
/// Ray/Triangle Intersection", JCGT 2(1), 2013): the axis the ray is most aligned with
/// becomes z, and a shear maps the ray onto +z, so each triangle is tested in 2D.
#[derive(Clone, Copy)]
struct ShearedRay {
    o: Vec3A,
    /// Permuted axes (kx, ky, kz), kz the largest component of the direction.
    k: [usize; 3],
    /// Shear constants (Sx, Sy, Sz).
    s: [f32; 3],
}

impl ShearedRay {
    #[inline(always)]
    fn new(o: Vec3A, d: Vec3A) -> ShearedRay {
        let a = d.abs();
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let (mut kx, mut ky) = ((kz + 1) % 3, (kz + 2) % 3);
        // Keep the triangles' winding (and so the sign of the edge functions) consistent.
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let sz = 1.0 / d[kz];
        ShearedRay { o, k: [kx, ky, kz], s: [d[kx] * sz, d[ky] * sz, sz] }
    }
}

/// A triangle's corners exactly as in the world (not v0 + edge: rounding would open cracks
/// between neighbours, which must compute their shared edge from identical numbers).
#[derive(Clone, Copy)]
struct Tri {
    p: [Vec3A; 3],
    id: u32,
}

impl Tri {
    /// Distance and barycentrics (u, v) of the hit within [tmin, tmax], if any. Watertight: a
    /// ray through a shared edge or vertex hits at least one of the triangles sharing it (the
    /// Moller-Trumbore test this replaces let ~3% of axis-aligned rays through a tessellated
    /// floor fall through its edges). Degenerate triangles, rays in a triangle's plane and NaN
    /// inputs never hit; both faces hit.
    #[inline(always)]
    fn intersect(&self, r: &ShearedRay, tmin: f32, tmax: f32) -> Option<(f32, f32, f32)> {
        let [kx, ky, kz] = r.k;
        let [sx, sy, sz] = r.s;
        let a = self.p[0] - r.o;
        let b = self.p[1] - r.o;
        let c = self.p[2] - r.o;
        let (ax, ay) = (a[kx] - sx * a[kz], a[ky] - sy * a[kz]);
        let (bx, by) = (b[kx] - sx * b[kz], b[ky] - sy * b[kz]);
        let (cx, cy) = (c[kx] - sx * c[kz], c[ky] - sy * c[kz]);
        let mut eu = cx * by - cy * bx;
        let mut ev = ax * cy - ay * cx;
        let mut ew = bx * ay - by * ax;
        // An edge function of exactly 0 may be rounding: decide it in double precision.
        if eu == 0.0 || ev == 0.0 || ew == 0.0 {
            let f = |x: f32| x as f64;
            eu = (f(cx) * f(by) - f(cy) * f(bx)) as f32;
            ev = (f(ax) * f(cy) - f(ay) * f(cx)) as f32;
            ew = (f(bx) * f(ay) - f(by) * f(ax)) as f32;
        }
        if (eu < 0.0 || ev < 0.0 || ew < 0.0) && (eu > 0.0 || ev > 0.0 || ew > 0.0) {
            return None;
        }
        let det = eu + ev + ew;
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let t = (eu * (sz * a[kz]) + ev * (sz * b[kz]) + ew * (sz * c[kz])) / det;
        if !(t >= tmin && t <= tmax) {
            return None;
        }
        // eu weighs p0, ev p1, ew p2; the hit is (1 - u - v) p0 + u p1 + v p2.
        Some((t, ev / det, ew / det))
    }
}

/// Smallest magnitude of a direction component we trace. obvhs replaces 1/d by 1/EPSILON for
/// |d| <= f32::EPSILON (to avoid infinities), so its slab test follows a different line than
/// the ray for nearly axis-aligned directions and culls boxes the ray does cross: a ray with
/// d = (1e-7, 0, -1) fell through a floor. We trace such rays with the component set to
/// +-MIN_COMPONENT instead (the inverse is then exact), a tilt of under 5e-7 radians: a shift
/// of 1.5e-6 render units at the far side of the scene, far below a pixel. Traversal and
/// triangle test use the same direction, so they agree.
const MIN_COMPONENT: f32 = 4.0 * f32::EPSILON;

#[inline(always)]
fn traced_direction(d: Vec3A) -> Vec3A {
    let fix = |x: f32| if x.abs() < MIN_COMPONENT { MIN_COMPONENT.copysign(x) } else { x };
    Vec3A::new(fix(d.x), fix(d.y), fix(d.z))
}

/// obvhs's medium preset without reinsertion: reinsertion's branch-and-bound search cannot
/// prune among heavily overlapping triangles and turns quadratic there (30,000 overlapping
/// boxes, 360K triangles: 38 s; 100,000: over 2 min). Without it the same scenes build in
/// well under a second, and primary rays on the test meshes trace as fast (BENCHMARKS.md).
const BUILD: BvhBuildParams = BvhBuildParams {
    reinsertion_batch_ratio: 0.0,
    post_collapse_reinsertion_batch_ratio_multiplier: 0.0,
    ..BvhBuildParams::medium_build()
};

pub struct Accel {
    bvh: Option<Bvh2>,
    /// Triangles in BVH leaf order (so leaves index them directly).
    tris: Vec<Tri>,
}

impl Accel {
    /// Builds a BVH2 over the world's triangles (medium preset: no spatial splits, so each
    /// triangle appears once). The build is deterministic for a given triangle list.
    ///
    /// Left out, as no query could ever return them: triangles with a non-finite corner
    /// (their NaN or infinite bounds corrupt the tree: a NaN vertex once hid a quad beside it),
    /// triangles with two equal corners (the watertight test's determinant is exactly 0), and
    /// exact copies of a lower-numbered triangle (ties go to the lowest id). obvhs's PLOC
    /// build degenerates to quadratic time on coincident triangles: 30,000 instances of a
    /// box at one place (a 0.5 MB file) took 106 s to build, now milliseconds.
    pub fn new(world: &World) -> Accel {
        let mut seen = std::collections::HashSet::new();
        let ids: Vec<u32> = (0..world.positions.len() as u32)
            .filter(|&i| {
                let [a, b, c] = world.positions[i as usize];
                if !(a.is_finite() && b.is_finite() && c.is_finite()) || a == b || b == c || a == c {
                    return false;
                }
                // The corners as a set (either winding, any starting corner), bit for bit.
                let mut key = [a, b, c].map(|p| p.to_array().map(f32::to_bits));
                key.sort_unstable();
                seen.insert(key)
            })
            .collect();
        if ids.is_empty() {
            return Accel { bvh: None, tris: Vec::new() };
        }
        let tris: Vec<Triangle> = ids
            .iter()
            .map(|&i| {
                let [a, b, c] = world.positions[i as usize];
                Triangle { v0: a.into(), v1: b.into(), v2: c.into() }
            })
            .collect();
        let bvh = build_bvh2_from_tris(&tris, BUILD, &mut Duration::default());
        let ordered = bvh
            .primitive_indices
            .iter()
            .map(|&i| {
                let t = &tris[i as usize];
                Tri { p: [t.v0, t.v1, t.v2], id: ids[i as usize] }
            })
            .collect();
        Accel { bvh: Some(bvh), tris: ordered }
    }

    /// The closest hit along `origin + t dir`, t in [tmin, tmax]. Equal distances resolve to
    /// the lowest triangle id, so the result never depends on traversal order.
    #[inline]
    pub fn closest(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Option<Hit> {
        let bvh = self.bvh.as_ref()?;
        if !(origin.is_finite() && dir.is_finite()) || dir == Vec3::ZERO {
            return None;
        }
        let (o, d) = (Vec3A::from(origin), traced_direction(Vec3A::from(dir)));
        let ray = Ray::new(o, d, tmin, tmax);
        let sheared = ShearedRay::new(o, d);
        let mut best: Option<Hit> = None;
        let mut hit = obvhs::ray::RayHit::none();
        bvh.ray_traverse(ray, &mut hit, |r, slot| {
            let tri = &self.tris[slot];
            match tri.intersect(&sheared, tmin, r.tmax) {
                Some((t, u, v)) => {
                    let better = match best {
                        None => true,
                        Some(b) => t < b.t || (t == b.t && tri.id < b.tri),
                    };
                    if better {
                        best = Some(Hit { tri: tri.id, t, u, v });
                    }
                    // Slightly beyond t, so nodes whose entry is exactly t are still visited
                    // and an equal-distance triangle there can win the id tie-break.
                    t * (1.0 + 4.0 * f32::EPSILON) + f32::MIN_POSITIVE
                }
                None => f32::INFINITY,
            }
        });
        best
    }

    /// Whether anything lies along `origin + t dir` for t in [tmin, tmax] (shadow rays).
    #[inline]
    pub fn occluded(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> bool {
        let Some(bvh) = self.bvh.as_ref() else {
            return false;
        };
        if !(origin.is_finite() && dir.is_finite()) || dir == Vec3::ZERO {
            return false;
        }
        let (o, d) = (Vec3A::from(origin), traced_direction(Vec3A::from(dir)));
        let ray = Ray::new(o, d, tmin, tmax);
        let sheared = ShearedRay::new(o, d);
        !bvh.ray_traverse_miss(ray, |_, slot| {
            self.tris[slot].intersect(&sheared, tmin, tmax).map_or(f32::INFINITY, |(t, _, _)| t)
        })
    }

    /// Closest hit with a bare obvhs traversal and its own triangle test: the baseline the
    /// benchmark compares the pipeline against.
    pub fn bare_traversal(&self, origin: Vec3, dir: Vec3) -> bool {
        let Some(bvh) = self.bvh.as_ref() else {
            return false;
        };
        let (o, d) = (Vec3A::from(origin), traced_direction(Vec3A::from(dir)));
        let sheared = ShearedRay::new(o, d);
        let mut hit = obvhs::ray::RayHit::none();
        bvh.ray_traverse(Ray::new_inf(o, d), &mut hit, |r, slot| {
            self.tris[slot].intersect(&sheared, 0.0, r.tmax).map_or(f32::INFINITY, |(t, _, _)| t)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{Scene, World};

    fn world_of(tris: Vec<[Vec3; 3]>) -> World {
        let mut w = World::new(&Scene::default_scene());
        w.positions = tris;
        w
    }

    #[test]
    fn hits_a_triangle_with_barycentrics() {
        let w = world_of(vec![[Vec3::new(0.0, 0.0, 0.0), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0)]]);
        let a = Accel::new(&w);
        let h = a.closest(Vec3::new(0.25, 0.5, 1.0), Vec3::NEG_Z, 0.0, f32::INFINITY).unwrap();
        assert_eq!(h.tri, 0);
        assert!((h.t - 1.0).abs() < 1e-6);
        assert!((h.u - 0.25).abs() < 1e-6 && (h.v - 0.5).abs() < 1e-6);
        assert!(a.closest(Vec3::new(2.0, 2.0, 1.0), Vec3::NEG_Z, 0.0, f32::INFINITY).is_none());
        assert!(a.occluded(Vec3::new(0.25, 0.25, 1.0), Vec3::NEG_Z, 0.0, 2.0));
        assert!(!a.occluded(Vec3::new(0.25, 0.25, 1.0), Vec3::NEG_Z, 0.0, 0.5));
    }

    #[test]
    fn closest_of_two_and_ties_go_to_the_lower_id() {
        let t = |z: f32| [Vec3::new(-1.0, -1.0, z), Vec3::new(1.0, -1.0, z), Vec3::new(0.0, 1.0, z)];
        let w = world_of(vec![t(-1.0), t(0.0), t(0.0)]);
        let a = Accel::new(&w);
        let h = a.closest(Vec3::new(0.0, 0.0, 5.0), Vec3::NEG_Z, 0.0, f32::INFINITY).unwrap();
        assert_eq!(h.tri, 1);
    }

    #[test]
    fn degenerate_and_nan_never_hit() {
        let w = world_of(vec![[Vec3::ZERO, Vec3::X, Vec3::X * 2.0], [Vec3::ZERO, Vec3::ZERO, Vec3::ZERO]]);
        let a = Accel::new(&w);
        for o in [Vec3::new(0.5, 0.0, 1.0), Vec3::new(0.2, 0.2, 1.0)] {
            assert!(a.closest(o, Vec3::NEG_Z, 0.0, f32::INFINITY).is_none());
        }
        assert!(a.closest(Vec3::NAN, Vec3::NEG_Z, 0.0, f32::INFINITY).is_none());
    }

    /// A height field of shared-vertex triangles (not coplanar) and a triangle fan around
    /// one vertex.
    fn grid(n: u32) -> Vec<[Vec3; 3]> {
        let v = |i: u32, j: u32| {
            let (x, y) = (i as f32 / n as f32 * 2.0 - 1.0, j as f32 / n as f32 * 2.0 - 1.0);
            Vec3::new(x, y, 1e-4 * ((i * 7 + j * 13) % 5) as f32)
        };
        let mut tris = Vec::new();
        for j in 0..n {
            for i in 0..n {
                tris.push([v(i, j), v(i + 1, j), v(i + 1, j + 1)]);
                tris.push([v(i, j), v(i + 1, j + 1), v(i, j + 1)]);
            }
        }
        tris
    }

    /// Regression (found by tests/robustness.rs): with Moller-Trumbore, axis-aligned rays
    /// through the shared edges and vertices of a tessellated floor fell through it (69 of
    /// 2304 orthographic pixels). The watertight test never lets one through.
    #[test]
    fn rays_through_shared_edges_and_vertices_never_fall_through() {
        let n = 12;
        let a = Accel::new(&world_of(grid(n)));
        let mut misses = 0;
        let mut total = 0;
        for dir in [Vec3::NEG_Z, Vec3::Z, Vec3::new(0.3, -0.2, -1.0).normalize(), Vec3::new(1e-7, 0.0, -1.0)] {
            for j in 1..4 * n {
                for i in 1..4 * n {
                    // Every vertex, every edge midpoint and every cell centre (in the plane).
                    let (x, y) = (i as f32 / (2 * n) as f32 - 1.0, j as f32 / (2 * n) as f32 - 1.0);
                    if x.abs() >= 0.99 || y.abs() >= 0.99 {
                        continue;
                    }
                    let origin = Vec3::new(x, y, 0.0) - dir * 3.0;
                    total += 1;
                    if a.closest(origin, dir, 0.0, f32::INFINITY).is_none() {
                        misses += 1;
                    }
                    assert!(
                        a.occluded(origin, dir, 0.0, 10.0),
                        "{origin:?} {dir:?} {:?}",
                        a.closest(origin, dir, 0.0, f32::INFINITY)
                    );
                }
            }
        }
        assert_eq!(misses, 0, "{misses} of {total} rays fell through");
    }

    #[test]
    fn barycentrics_reconstruct_the_hit_point_for_any_axis() {
        let tri = [Vec3::new(0.1, -0.3, 0.2), Vec3::new(1.0, 0.2, -0.4), Vec3::new(-0.2, 0.9, 0.5)];
        let a = Accel::new(&world_of(vec![tri]));
        let target = tri[0] * 0.2 + tri[1] * 0.3 + tri[2] * 0.5;
        for dir in [Vec3::X, Vec3::NEG_X, Vec3::Y, Vec3::NEG_Y, Vec3::Z, Vec3::NEG_Z, Vec3::new(0.5, -0.7, 0.2)] {
            let dir = dir.normalize();
            let o = target - dir * 2.0;
            let h = a.closest(o, dir, 0.0, f32::INFINITY).unwrap_or_else(|| panic!("{dir:?} missed"));
            // f32 error grows as 1 / cos(incidence): allow for grazing directions.
            let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]).normalize();
            let tol = 2e-6 / n.dot(dir).abs();
            let p = tri[0] * (1.0 - h.u - h.v) + tri[1] * h.u + tri[2] * h.v;
            assert!((p - target).length() < tol, "{dir:?}: {p:?}");
            assert!((o + dir * h.t - target).length() < tol);
        }
    }

    /// Regression: 30,000 instances of a box at one place took 106 s to build (obvhs's PLOC
    /// and reinsertion degenerate on coincident triangles). Copies, whatever their winding
    /// or first corner, and triangles with repeated corners are left out of the tree, and
    /// every query answers as if they were there (ties go to the lowest id anyway).
    #[test]
    fn coincident_copies_and_repeated_corners_are_left_out() {
        let box_tris: Vec<[Vec3; 3]> = (0..6)
            .flat_map(|f| {
                let (a, b) = (f % 3, (f % 3 + 1) % 3);
                let s = if f < 3 { 1.0 } else { -1.0 };
                let c = |u: f32, v: f32| {
                    let mut p = Vec3::splat(s);
                    p[a] = u;
                    p[b] = v;
                    p
                };
                [[c(-1.0, -1.0), c(1.0, -1.0), c(1.0, 1.0)], [c(-1.0, -1.0), c(1.0, 1.0), c(-1.0, 1.0)]]
            })
            .collect();
        let mut tris = Vec::new();
        for copy in 0..3000 {
            for t in &box_tris {
                // Rotate the corners and flip the winding on some copies: still the same triangle.
                let t = match copy % 3 {
                    0 => *t,
                    1 => [t[1], t[2], t[0]],
                    _ => [t[2], t[1], t[0]],
                };
                tris.push(t);
            }
        }
        tris.push([Vec3::ZERO, Vec3::ZERO, Vec3::X]);
        let a = Accel::new(&world_of(tris));
        assert_eq!(a.tris.len(), 12, "only the first box's triangles are built");
        assert!(a.tris.iter().all(|t| t.id < 12));
        for dir in [Vec3::NEG_Z, Vec3::new(0.3, -0.5, -0.8).normalize(), Vec3::X] {
            let o = Vec3::new(0.1, 0.2, 0.3) - dir * 5.0;
            let h = a.closest(o, dir, 0.0, f32::INFINITY).unwrap();
            assert!(h.tri < 12, "a copy won: {h:?}");
            assert!(a.occluded(o, dir, 0.0, 10.0));
        }
    }
}
