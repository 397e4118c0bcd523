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

/// A triangle prepared for Moller-Trumbore: `v0`, edges `e1 = v1 - v0`, `e2 = v2 - v0`.
#[derive(Clone, Copy)]
struct Tri {
    v0: Vec3A,
    e1: Vec3A,
    e2: Vec3A,
    id: u32,
}

impl Tri {
    /// Distance and barycentrics of the hit within [tmin, tmax], if any. Degenerate triangles
    /// (zero determinant) and NaN inputs never hit.
    #[inline(always)]
    fn intersect(&self, o: Vec3A, d: Vec3A, tmin: f32, tmax: f32) -> Option<(f32, f32, f32)> {
        let p = d.cross(self.e2);
        let det = self.e1.dot(p);
        if det == 0.0 || !det.is_finite() {
            return None;
        }
        let inv = 1.0 / det;
        let s = o - self.v0;
        let u = s.dot(p) * inv;
        if !(0.0..=1.0).contains(&u) {
            return None;
        }
        let q = s.cross(self.e1);
        let v = d.dot(q) * inv;
        if !(v >= 0.0 && u + v <= 1.0) {
            return None;
        }
        let t = self.e2.dot(q) * inv;
        (t >= tmin && t <= tmax).then_some((t, u, v))
    }
}

pub struct Accel {
    bvh: Option<Bvh2>,
    /// Triangles in BVH leaf order (so leaves index them directly).
    tris: Vec<Tri>,
}

impl Accel {
    /// Builds a BVH2 over the world's triangles (medium preset: no spatial splits, so each
    /// triangle appears once). The build is deterministic for a given triangle list.
    pub fn new(world: &World) -> Accel {
        if world.positions.is_empty() {
            return Accel { bvh: None, tris: Vec::new() };
        }
        let tris: Vec<Triangle> = world
            .positions
            .iter()
            .map(|[a, b, c]| Triangle { v0: (*a).into(), v1: (*b).into(), v2: (*c).into() })
            .collect();
        let bvh = build_bvh2_from_tris(&tris, BvhBuildParams::medium_build(), &mut Duration::default());
        let ordered = bvh
            .primitive_indices
            .iter()
            .map(|&i| {
                let t = &tris[i as usize];
                Tri { v0: t.v0, e1: t.v1 - t.v0, e2: t.v2 - t.v0, id: i }
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
        let (o, d) = (Vec3A::from(origin), Vec3A::from(dir));
        let ray = Ray::new(o, d, tmin, tmax);
        let mut best: Option<Hit> = None;
        let mut hit = obvhs::ray::RayHit::none();
        bvh.ray_traverse(ray, &mut hit, |r, slot| {
            let tri = &self.tris[slot];
            match tri.intersect(o, d, tmin, r.tmax) {
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
        let (o, d) = (Vec3A::from(origin), Vec3A::from(dir));
        let ray = Ray::new(o, d, tmin, tmax);
        !bvh.ray_traverse_miss(ray, |_, slot| {
            self.tris[slot].intersect(o, d, tmin, tmax).map_or(f32::INFINITY, |(t, _, _)| t)
        })
    }

    /// Closest hit with a bare obvhs traversal and its own triangle test: the baseline the
    /// benchmark compares the pipeline against.
    pub fn bare_traversal(&self, origin: Vec3, dir: Vec3) -> bool {
        let Some(bvh) = self.bvh.as_ref() else {
            return false;
        };
        let (o, d) = (Vec3A::from(origin), Vec3A::from(dir));
        let mut hit = obvhs::ray::RayHit::none();
        bvh.ray_traverse(Ray::new_inf(o, d), &mut hit, |r, slot| {
            self.tris[slot].intersect(o, d, 0.0, r.tmax).map_or(f32::INFINITY, |(t, _, _)| t)
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
}
