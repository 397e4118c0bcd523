//! Ray queries against the scene's triangles: the only user of obvhs. A two-level BVH (a BVH2
//! per geometry, the small baked objects' also as one, a BVH2 over the placed objects): closest
//! hit, occlusion, and the updates an animation or a changed scene needs (see `Accel`).

use std::time::Duration;

use glam::{Affine3A, Vec3, Vec3A, Vec4, Vec4Swizzles};
use obvhs::aabb::Aabb;
use obvhs::bvh2::Bvh2;
use obvhs::bvh2::builder::build_bvh2;
use obvhs::ploc::PlocBuilder;
use obvhs::{BvhBuildParams, ray::Ray, triangle::Triangle};
use rayon::prelude::*;

use crate::scene::World;
use crate::scene::backdrop::Backdrop;
use crate::scene::world::Geometry;
use crate::util::hash::update_words;
use crate::util::sort::sort_by_buckets;

mod blas;
mod instances;
mod traverse;
mod triangle;
mod update;

use blas::*;
use instances::*;
use traverse::*;
use triangle::*;

/// A closest hit: `tri` is the global triangle id (`World::triangle`), `object` indexes
/// `World::objects`; the hit point is `(1 - u - v) p0 + u p1 + v p2`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub tri: u32,
    pub object: u32,
    pub t: f32,
    pub u: f32,
    pub v: f32,
}

/// Ray queries against the world: a two-level BVH. Each geometry (one per mesh, see
/// `scene::world`) has a bottom-level BVH (BLAS) over its triangles, built once per distinct
/// content; a top-level BVH (TLAS) over the objects' boxes places them. An instanced mesh
/// costs one BLAS however many objects place it; an object that moves costs a TLAS rebuild
/// (`update_instances`); a changed scene reuses every BLAS whose content is unchanged
/// (`update`).
///
/// Queries answer exactly as one BVH over the flattened triangles would: the closest hit,
/// ties to the lowest triangle id, whatever the traversal order. An object whose geometry is
/// baked for it (every object of a scene without instancing) is traced with the render-space
/// ray itself, bit for bit as before the two levels; instances trace the ray carried into
/// their base space by an f32 affine map (hits within f32 rounding of the flattened ones).
#[derive(Default)]
pub struct Accel {
    /// BLASes by index; `geometry_blas` maps geometries onto them (None: nothing hittable).
    blas: Vec<Blas>,
    geometry_blas: Vec<Option<u32>>,
    /// TLAS leaves in leaf order.
    instances: Vec<Instance>,
    /// The TLAS and its traversal layout.
    tlas: Option<(Bvh2, Pairs)>,
    /// The small baked objects as one BLAS (`Group`), one TLAS leaf (`GROUP`).
    group: Option<Group>,
}

/// What `Accel::update` did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct UpdateStats {
    /// BLASes built.
    pub built: usize,
    /// BLASes kept from before (same content).
    pub reused: usize,
}

impl Accel {
    /// Builds a BLAS per distinct geometry content (in parallel) and the TLAS.
    pub fn new(world: &World) -> Accel {
        let mut a = Accel::default();
        a.update(world);
        a
    }
}

impl Accel {
    /// Triangles held by the BLASes (each distinct geometry once).
    pub fn stored_triangles(&self) -> usize {
        self.blas.iter().map(|b| b.tris.len()).sum()
    }

    /// Objects traced (coincident copies and objects with nothing hittable left out): the TLAS's
    /// leaves, the group's members counted one by one.
    pub fn instance_count(&self) -> usize {
        self.instances.len() + self.group.as_ref().map_or(0, |g| g.members.len() - 1)
    }

    /// Objects traced through the group's one BLAS (`Group`; 0 when there is none).
    pub fn grouped_objects(&self) -> usize {
        self.group.as_ref().map_or(0, |g| g.members.len())
    }

    /// Bytes held by the BVHs and their triangles (heap, approximate).
    pub fn memory_bytes(&self) -> usize {
        let node = std::mem::size_of::<obvhs::bvh2::node::Bvh2Node>();
        self.blas
            .iter()
            .chain(self.group.as_ref().map(|g| &g.blas))
            .map(|b| {
                b.bvh.nodes.capacity() * node
                    + b.tris.capacity() * std::mem::size_of::<Tri>()
                    + b.pairs.pairs.capacity() * std::mem::size_of::<Pair>()
            })
            .sum::<usize>()
            + self
                .tlas
                .as_ref()
                .map_or(0, |(t, p)| t.nodes.capacity() * node + p.pairs.capacity() * std::mem::size_of::<Pair>())
            + self.instances.capacity() * std::mem::size_of::<Instance>()
    }

    /// The closest hit along `origin + t dir`, t in [tmin, tmax]. Equal distances resolve to
    /// the lowest triangle id, so the result never depends on traversal order.
    #[inline]
    pub fn closest(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> Option<Hit> {
        let (_, tlas) = self.tlas.as_ref()?;
        if !(origin.is_finite() && dir.is_finite()) || dir == Vec3::ZERO {
            return None;
        }
        let world = LocalRay::new(Vec3A::from(origin), Vec3A::from(dir));
        let mut best: Option<Hit> = None;
        traverse_closest(tlas, Ray::new(world.o, world.d, tmin, tmax), |r, slot| {
            let inst = &self.instances[slot];
            if inst.skipped_from(world.o) {
                return f32::INFINITY;
            }
            let before = best.map(|b| (b.t, b.tri));
            self.blas_of(inst).closest(&inst.ray(&world), tmin, r.tmax, inst.owner(), &mut best);
            match best {
                Some(b) if before != Some((b.t, b.tri)) => just_beyond(b.t),
                _ => f32::INFINITY,
            }
        });
        if let Some(hit) = best.as_mut() {
            self.resolve_group(hit);
        }
        best
    }

    /// A hit in the group (`GROUP` as its object) given the object its triangle lies in.
    #[inline]
    fn resolve_group(&self, hit: &mut Hit) {
        if hit.object == GROUP {
            hit.object = self.group.as_ref().map_or(GROUP, |g| g.object_of(hit.tri));
        }
    }

    /// The BLAS instance `inst` traces: its own, or the group's.
    #[inline(always)]
    fn blas_of(&self, inst: &Instance) -> &Blas {
        match (inst.blas, &self.group) {
            (GROUP, Some(group)) => &group.blas,
            (b, _) => &self.blas[b as usize],
        }
    }

    /// `closest` for up to four rays (`rays[l]` = (origin, dir)), answered together: the
    /// same hits as `closest` for each, bit for bit. Neighbouring pixels' primary rays (a
    /// 2 x 2 block) walk the trees as one packet (`Pairs::traverse4`); rays not sharing their
    /// dominant axes, invalid rays and trees too deep for the packet's stack go one by one.
    pub fn closest4(&self, rays: &[(Vec3, Vec3)], tmin: f32, tmax: f32) -> [Option<Hit>; 4] {
        assert!(!rays.is_empty() && rays.len() <= 4, "1 to 4 rays");
        let mut best = [None; 4];
        let Some((_, tlas)) = self.tlas.as_ref() else {
            return best;
        };
        let valid = |(o, d): &(Vec3, Vec3)| o.is_finite() && d.is_finite() && *d != Vec3::ZERO;
        let world: [LocalRay; 4] = std::array::from_fn(|l| {
            let (o, d) = rays[l.min(rays.len() - 1)];
            LocalRay::new(Vec3A::from(o), Vec3A::from(d))
        });
        if rays.len() == 1
            || !rays.iter().all(valid)
            || world.iter().any(|r| r.sheared.k != world[0].sheared.k)
            || tlas.depth > INLINE_STACK
        {
            for (l, &(o, d)) in rays.iter().enumerate() {
                best[l] = self.closest(o, d, tmin, tmax);
            }
            return best;
        }
        let limit = Vec4::from_array(std::array::from_fn(|l| if l < rays.len() { tmax } else { f32::NEG_INFINITY }));
        let obvh: [Ray; 4] = std::array::from_fn(|l| Ray::new(world[l].o, world[l].d, tmin, limit[l]));
        let o = [0, 1, 2].map(|a| Vec4::from_array(world.map(|r| r.o[a])));
        let inv = [0, 1, 2].map(|a| Vec4::from_array(obvh.map(|r| r.inv_direction[a])));
        let mut limit = limit;
        tlas.traverse4(o, inv, &obvh, &mut limit, |first, count, lanes, limit| {
            for slot in first..first + count {
                let inst = &self.instances[slot as usize];
                let lanes = match inst.backdrop {
                    Some(_) => (0..4)
                        .filter(|&l| lanes & (1 << l) != 0 && !inst.skipped_from(world[l].o))
                        .fold(0, |m, l| m | 1 << l),
                    None => lanes,
                };
                if lanes == 0 {
                    continue;
                }
                let before = best.map(|b| b.map(|b| (b.t, b.tri)));
                let blas = self.blas_of(inst);
                if inst.to_base.is_none() {
                    let own = Vec4::select(mask_lanes(lanes), *limit, Vec4::NEG_INFINITY);
                    blas.closest4(&world, tmin, own, inst.owner(), &mut best);
                } else {
                    for l in (0..4).filter(|l| lanes & (1 << l) != 0) {
                        let ray = inst.ray(&world[l]);
                        blas.closest(&ray, tmin, limit[l], inst.owner(), &mut best[l]);
                    }
                }
                // As `closest`'s top level: a lane's limit drops to just beyond a new best.
                for l in 0..4 {
                    if let Some(b) = best[l].filter(|b| before[l] != Some((b.t, b.tri))) {
                        let slack = just_beyond(b.t);
                        if slack < limit[l] {
                            limit[l] = slack;
                        }
                    }
                }
            }
        });
        best.iter_mut().flatten().for_each(|hit| self.resolve_group(hit));
        best
    }

    /// Whether anything lies along `origin + t dir` for t in [tmin, tmax] (shadow rays).
    #[inline]
    pub fn occluded(&self, origin: Vec3, dir: Vec3, tmin: f32, tmax: f32) -> bool {
        let Some((_, tlas)) = self.tlas.as_ref() else {
            return false;
        };
        if !(origin.is_finite() && dir.is_finite()) || dir == Vec3::ZERO {
            return false;
        }
        let world = LocalRay::new(Vec3A::from(origin), Vec3A::from(dir));
        !traverse_miss(tlas, Ray::new(world.o, world.d, tmin, tmax), |_, slot| {
            let inst = &self.instances[slot];
            if inst.skipped_from(world.o) || inst.shadowless {
                return f32::INFINITY;
            }
            self.blas_of(inst).any_hit(&inst.ray(&world), tmin, tmax).unwrap_or(f32::INFINITY)
        })
    }

    /// Closest hit with bare obvhs traversals (TLAS, then each BLAS) and our triangle test,
    /// no tie-break: the baseline the benchmark compares the pipeline against.
    pub fn bare_traversal(&self, origin: Vec3, dir: Vec3) -> bool {
        let Some((tlas, _)) = self.tlas.as_ref() else {
            return false;
        };
        let world = LocalRay::new(Vec3A::from(origin), Vec3A::from(dir));
        let mut hit = obvhs::ray::RayHit::none();
        tlas.ray_traverse(Ray::new_inf(world.o, world.d), &mut hit, |r, slot| {
            let inst = &self.instances[slot];
            let ray = inst.ray(&world);
            let blas = self.blas_of(inst);
            let mut h = obvhs::ray::RayHit::none();
            blas.bvh.ray_traverse(Ray::new(ray.o, ray.d, 0.0, r.tmax), &mut h, |r, slot| {
                blas.tris[slot].intersect(&ray.sheared, 0.0, r.tmax).map_or(f32::INFINITY, |(t, _, _)| t)
            });
            h.t
        })
    }
}

#[cfg(test)]
mod tests;
