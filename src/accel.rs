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

/// obvhs's medium preset without reinsertion (PLOC search distance 14; 6, the fast preset's,
/// measured on the 1M-triangle scene: no faster to build, 5% slower to trace): reinsertion's branch-and-bound search cannot
/// prune among heavily overlapping triangles and turns quadratic there (30,000 overlapping
/// boxes, 360K triangles: 38 s; 100,000: over 2 min). Without it the same scenes build in
/// well under a second, and primary rays on the test meshes trace as fast (BENCHMARKS.md).
const BUILD: BvhBuildParams = BvhBuildParams {
    reinsertion_batch_ratio: 0.0,
    post_collapse_reinsertion_batch_ratio_multiplier: 0.0,
    ..BvhBuildParams::medium_build()
};

/// What `build_bvh2_from_tris(tris, BUILD, ..)` builds, node for node and index for index
/// (tested): obvhs's PLOC, then `collapse` in place of obvhs's leaf collapse (BUILD has no
/// reinsertion, so nothing else runs).
fn build_tris(tris: &[Triangle]) -> Bvh2 {
    const _: () = assert!(BUILD.reinsertion_batch_ratio == 0.0 && !BUILD.pre_split);
    let mut bvh = PlocBuilder::with_capacity(tris.len()).build(
        BUILD.ploc_search_distance,
        tris,
        (0..tris.len() as u32).collect(),
        BUILD.sort_precision,
        BUILD.search_depth_threshold,
    );
    collapse(&mut bvh, BUILD.max_prims_per_leaf.clamp(1, 255), BUILD.collapse_traversal_cost);
    bvh.uses_spatial_splits = BUILD.pre_split;
    bvh
}

/// obvhs's `leaf_collapser::collapse` (SAH leaf collapse: two sibling leaves merge when
/// half_area(parent) x (count - cost) <= the sum of half_area(child) x count), giving the same
/// tree, for a tree whose children come after their parents (PLOC's) and with no parents or
/// primitive-to-node map kept. One serial pass bottom-up (children before parents: in reverse
/// node order) instead of parallel walks up from every leaf with atomic counters, which cost
/// ~4x the CPU on 2 cores (about a quarter of a 1M-triangle build).
fn collapse(bvh: &mut Bvh2, max_prims: u32, traversal_cost: f32) {
    let n = bvh.nodes.len();
    if max_prims <= 1 || n as u32 <= max_prims * 2 + 1 {
        return;
    }
    if !bvh.primitive_indices.is_empty() && bvh.primitive_indices.len() as u32 <= max_prims {
        return;
    }
    if bvh.nodes.is_empty() || bvh.nodes[0].is_leaf() {
        return;
    }
    assert!(
        bvh.children_are_ordered_after_parents && bvh.parents.is_empty() && bvh.primitives_to_nodes.is_empty(),
        "collapse takes a fresh PLOC tree"
    );
    let nodes = &bvh.nodes;
    // Per node: 1 if it stays, 0 if merged into its parent's leaf; primitives when a leaf
    // (after collapse), 0 otherwise. Then prefix sums: new node index and first primitive.
    let mut node_counts = vec![1u32; n];
    let mut prim_counts = vec![0u32; n];
    for i in (0..n).rev() {
        let node = &nodes[i];
        if node.is_leaf() {
            prim_counts[i] = node.prim_count;
            continue;
        }
        let first = node.first_index as usize;
        let (left_count, right_count) = (prim_counts[first], prim_counts[first + 1]);
        let total = left_count + right_count;
        if left_count > 0 && right_count > 0 && total <= max_prims {
            let (left, right) = (&nodes[first], &nodes[first + 1]);
            let collapse_cost = node.aabb().half_area() * (total as f32 - traversal_cost);
            let base_cost = left.aabb().half_area() * left_count as f32 + right.aabb().half_area() * right_count as f32;
            let same_prim = left.first_index == right.first_index && total == 2;
            if collapse_cost <= base_cost || same_prim {
                prim_counts[i] = total;
                prim_counts[first] = 0;
                prim_counts[first + 1] = 0;
                node_counts[first] = 0;
                node_counts[first + 1] = 0;
            }
        }
    }
    for i in 1..n {
        node_counts[i] += node_counts[i - 1];
        prim_counts[i] += prim_counts[i - 1];
    }
    let mut new_nodes = vec![nodes[0]; node_counts[n - 1] as usize];
    let mut new_indices = vec![0u32; prim_counts[n - 1] as usize];
    new_nodes[0].first_index = node_counts[nodes[0].first_index as usize - 1];
    let mut stack = Vec::new();
    for i in 1..n {
        let id = node_counts[i - 1] as usize;
        if id == node_counts[i] as usize {
            continue;
        }
        let mut node = nodes[i];
        let first_prim = prim_counts[i - 1];
        if first_prim == prim_counts[i] {
            node.first_index = node_counts[node.first_index as usize - 1];
        } else {
            node.prim_count = prim_counts[i] - first_prim;
            node.first_index = first_prim;
            // The subtree's primitives, left before right, as obvhs's top-down walk lays them.
            let mut at = first_prim as usize;
            stack.push(i);
            while let Some(j) = stack.pop() {
                let sub = &nodes[j];
                if sub.is_leaf() {
                    let r = sub.first_index as usize..(sub.first_index + sub.prim_count) as usize;
                    new_indices[at..at + r.len()].copy_from_slice(&bvh.primitive_indices[r.clone()]);
                    at += r.len();
                } else {
                    stack.push(sub.first_index as usize + 1);
                    stack.push(sub.first_index as usize);
                }
            }
        }
        new_nodes[id] = node;
    }
    bvh.nodes = new_nodes;
    bvh.primitive_indices = new_indices;
}

/// A triangle in a BLAS's leaf order: its corners in base space (see `scene::world`) and its
/// index within its geometry. 40 bytes (corners kept unaligned: the watertight test reads
/// them once, and aligned they cost 64).
#[derive(Clone, Copy)]
struct Tri {
    p: [Vec3; 3],
    id: u32,
}

/// Calls `$body` with the ray axes `$k` ([kx, ky, kz], one of the six `ShearedRay::new`
/// makes) bound as the constants `$kx, $ky, $kz`: one monomorphised copy per axis order,
/// chosen once per ray and BLAS rather than per triangle component.
macro_rules! with_axes {
    ($k:expr, |$kx:ident, $ky:ident, $kz:ident| $body:expr) => {
        match $k {
            [1, 2, 0] => {
                const $kx: usize = 1;
                const $ky: usize = 2;
                const $kz: usize = 0;
                $body
            }
            [2, 1, 0] => {
                const $kx: usize = 2;
                const $ky: usize = 1;
                const $kz: usize = 0;
                $body
            }
            [2, 0, 1] => {
                const $kx: usize = 2;
                const $ky: usize = 0;
                const $kz: usize = 1;
                $body
            }
            [0, 2, 1] => {
                const $kx: usize = 0;
                const $ky: usize = 2;
                const $kz: usize = 1;
                $body
            }
            [0, 1, 2] => {
                const $kx: usize = 0;
                const $ky: usize = 1;
                const $kz: usize = 2;
                $body
            }
            _ => {
                const $kx: usize = 1;
                const $ky: usize = 0;
                const $kz: usize = 2;
                $body
            }
        }
    };
}
impl Tri {
    /// Distance and barycentrics (u, v) of the hit within [tmin, tmax], if any. Watertight: a
    /// ray through a shared edge or vertex hits at least one of the triangles sharing it (the
    /// Moller-Trumbore test this replaces let ~3% of axis-aligned rays through a tessellated
    /// floor fall through its edges). Degenerate triangles, rays in a triangle's plane and NaN
    /// inputs never hit; both faces hit.
    #[inline(always)]
    fn intersect(&self, r: &ShearedRay, tmin: f32, tmax: f32) -> Option<(f32, f32, f32)> {
        with_axes!(r.k, |KX, KY, KZ| self.intersect_axes::<KX, KY, KZ>(r, tmin, tmax))
    }

    /// `intersect` with the ray's axes (kx, ky, kz) as constants: each corner's components
    /// are then fixed lanes, not a run-time index into a SIMD vector (a store and a load per
    /// component, ~20% of a primary ray's cost on venus_11k). The same operations in the
    /// same order, so the same bits.
    #[inline(always)]
    fn intersect_axes<const KX: usize, const KY: usize, const KZ: usize>(
        &self,
        r: &ShearedRay,
        tmin: f32,
        tmax: f32,
    ) -> Option<(f32, f32, f32)> {
        debug_assert_eq!(r.k, [KX, KY, KZ]);
        let [sx, sy, sz] = r.s;
        let a = Vec3A::from(self.p[0]) - r.o;
        let b = Vec3A::from(self.p[1]) - r.o;
        let c = Vec3A::from(self.p[2]) - r.o;
        let (a, b, c) = (lanes::<KX, KY, KZ>(a), lanes::<KX, KY, KZ>(b), lanes::<KX, KY, KZ>(c));
        let (ax, ay) = (a[0] - sx * a[2], a[1] - sy * a[2]);
        let (bx, by) = (b[0] - sx * b[2], b[1] - sy * b[2]);
        let (cx, cy) = (c[0] - sx * c[2], c[1] - sy * c[2]);
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
        let t = (eu * (sz * a[2]) + ev * (sz * b[2]) + ew * (sz * c[2])) / det;
        if !(t >= tmin && t <= tmax) {
            return None;
        }
        // eu weighs p0, ev p1, ew p2; the hit is (1 - u - v) p0 + u p1 + v p2.
        Some((t, ev / det, ew / det))
    }
}

/// Whose triangles a BLAS query reports hits as (`Instance::owner`): the first global
/// triangle id and the object of the instance traced, and its culling (`Instance::cull`).
#[derive(Clone, Copy)]
struct Owner {
    first_triangle: u32,
    object: u32,
    cull: f32,
}

impl Owner {
    #[inline(always)]
    fn hit(&self, tri: &Tri, t: f32, u: f32, v: f32) -> Hit {
        Hit { tri: self.first_triangle + tri.id, object: self.object, t, u, v }
    }
}

impl Tri {
    /// Whether a hit on this triangle is refused for a ray along `d` (`Instance::cull`): the
    /// sign of d . n (n the normal its winding gives) is `cull`'s opposite. Tested only on a
    /// hit, so instances without culling (`cull` 0) pay a compare per hit.
    #[inline(always)]
    fn culled(&self, d: Vec3A, cull: f32) -> bool {
        if cull == 0.0 {
            return false;
        }
        let [a, b, c] = self.p.map(Vec3A::from);
        cull * d.dot((b - a).cross(c - a)) < 0.0
    }
}

/// Component `K` of `v` (K a constant: a fixed lane).
#[inline(always)]
fn lane<const K: usize>(v: Vec3A) -> f32 {
    match K {
        0 => v.x,
        1 => v.y,
        _ => v.z,
    }
}

/// `v`'s components in the order (KX, KY, KZ).
#[inline(always)]
fn lanes<const KX: usize, const KY: usize, const KZ: usize>(v: Vec3A) -> [f32; 3] {
    [lane::<KX>(v), lane::<KY>(v), lane::<KZ>(v)]
}

/// Whether a triangle can ever be hit: finite corners, no two equal (the watertight test's
/// determinant is exactly 0 then).
fn hittable([a, b, c]: [Vec3; 3]) -> bool {
    a.is_finite() && b.is_finite() && c.is_finite() && a != b && b != c && a != c
}

/// A bottom-level BVH: one geometry's triangles in their base space.
struct Blas {
    bvh: Bvh2,
    /// `bvh` laid out for traversal.
    pairs: Pairs,
    /// Triangles in leaf order (leaves index them directly).
    tris: Vec<Tri>,
    /// Bounds of the triangles, base space.
    bounds: Aabb,
    /// Content key: a hash of the geometry's positions and triangles (`content_key`).
    key: u128,
}

/// The key a geometry's BLAS is shared and reused by: its base-space positions and
/// triangles, bit for bit (checked in full on a key match, see `same_content`).
fn content_key(g: &Geometry) -> u128 {
    let mut h = xxhash_rust::xxh3::Xxh3::new();
    // Each number's little-endian bytes in turn, fed in bulk.
    update_words(&mut h, &g.positions);
    h.update(&[0xff]);
    update_words(&mut h, &g.triangles);
    h.digest128()
}

fn same_content(a: &Geometry, b: &Geometry) -> bool {
    a.triangles == b.triangles
        && a.positions.len() == b.positions.len()
        && a.positions
            .iter()
            .zip(&b.positions)
            .all(|(p, q)| p.to_array().map(f32::to_bits) == q.to_array().map(f32::to_bits))
}

impl Blas {
    /// Builds over a geometry's hittable triangles (medium preset: no spatial splits, so each
    /// triangle appears once; deterministic for a given triangle list). Left out, as no query
    /// could ever return them: triangles with a non-finite corner (their NaN or infinite
    /// bounds corrupt the tree: a NaN vertex once hid a quad beside it), triangles with two
    /// equal corners, and exact copies of a lower-numbered triangle (ties go to the lowest
    /// id). obvhs's PLOC build degenerates to quadratic time on coincident triangles: 30,000
    /// copies of a box at one place took 106 s to build, now milliseconds. None when nothing
    /// is hittable.
    fn build(g: &Geometry, key: u128) -> Option<Blas> {
        // Exact copies found by sorting (hash of the corner set, id) in parallel: the same
        // triangles kept as a serial hash set gave (the lowest id of each corner set), at a
        // fraction of its cost on million-triangle meshes (issue 16).
        let corner_set = |i: u32| {
            // The corners as a set (either winding, any starting corner), bit for bit.
            let mut key = g.corners(i).map(|p| p.to_array().map(f32::to_bits));
            key.sort_unstable();
            key
        };
        let n = g.triangles.len();
        // Every id mapped (unhittable ones to `SKIP`), then those dropped: an indexed collect
        // writes in place, where a parallel filter collects into a list of pieces and copies.
        const SKIP: u32 = u32::MAX;
        let mut keyed: Vec<(u64, u32)> = (0..n as u32)
            .into_par_iter()
            .map(|i| {
                if !hittable(g.corners(i)) {
                    return (0, SKIP);
                }
                let mut bytes = [0u8; 36];
                for (k, c) in corner_set(i).iter().flatten().enumerate() {
                    bytes[4 * k..4 * k + 4].copy_from_slice(&c.to_le_bytes());
                }
                (xxhash_rust::xxh3::xxh3_64(&bytes), i)
            })
            .collect();
        keyed.retain(|k| k.1 != SKIP);
        // Sorted by the hash's leading 16 bits, then within each bucket: the order a sort of
        // the pairs gives (they are distinct), in about half the time.
        sort_by_buckets(&mut keyed, 1 << 16, |k| (k.0 >> 48) as usize);
        // Per id: whether it is built over (hittable and no copy of a lower id), so the kept
        // ids come out ascending without a second sort.
        let mut kept = vec![false; n];
        for k in &keyed {
            kept[k.1 as usize] = true;
        }
        let mut start = 0;
        while start < keyed.len() {
            let mut end = start + 1;
            while end < keyed.len() && keyed[end].0 == keyed[start].0 {
                end += 1;
            }
            // A run of equal hashes (ids ascending): a copy of any earlier member is dropped.
            for j in start + 1..end {
                let kj = corner_set(keyed[j].1);
                if (start..j).any(|k| kept[keyed[k].1 as usize] && corner_set(keyed[k].1) == kj) {
                    kept[keyed[j].1 as usize] = false;
                }
            }
            start = end;
        }
        drop(keyed);
        let ids: Vec<u32> = (0..n as u32).filter(|&i| kept[i as usize]).collect();
        drop(kept);
        if ids.is_empty() {
            return None;
        }
        let tris: Vec<Triangle> = ids
            .par_iter()
            .map(|&i| {
                let [a, b, c] = g.corners(i);
                Triangle { v0: a.into(), v1: b.into(), v2: c.into() }
            })
            .collect();
        let mut bvh = build_tris(&tris);
        drop(tris);
        let ordered: Vec<Tri> = bvh
            .primitive_indices
            .par_iter()
            .map(|&i| Tri { p: g.corners(ids[i as usize]), id: ids[i as usize] })
            .collect();
        // Leaves index `ordered` directly: the mapping is not needed any more.
        bvh.primitive_indices = Vec::new();
        let bounds = *bvh.nodes[0].aabb();
        let pairs = Pairs::new(&bvh);
        Some(Blas { bvh, pairs, tris: ordered, bounds, key })
    }

    /// New corners from the geometry (same triangles), leaf boxes recomputed and the tree
    /// refitted bottom-up. False (nothing changed) when the set of hittable triangles changed:
    /// then only a rebuild is right.
    fn refit(&mut self, g: &Geometry) -> bool {
        let hittable_now = (0..g.triangles.len() as u32).filter(|&i| hittable(g.corners(i))).count();
        if hittable_now != self.tris.len() || self.tris.iter().any(|t| !hittable(g.corners(t.id))) {
            return false;
        }
        for t in &mut self.tris {
            t.p = g.corners(t.id);
        }
        for node in &mut self.bvh.nodes {
            if node.is_leaf() {
                let mut b = Aabb::empty();
                for t in &self.tris[node.first_index as usize..(node.first_index + node.prim_count) as usize] {
                    for p in t.p {
                        b.extend(p.into());
                    }
                }
                node.set_aabb(b);
            }
        }
        self.bvh.refit_all();
        self.pairs = Pairs::new(&self.bvh);
        self.bounds = *self.bvh.nodes[0].aabb();
        true
    }

    /// The closest hit in this BLAS better than `best` (nearer, or as near with a lower
    /// triangle id), for the ray `o + t d` (base space) with `tmin <= t <= tmax`, reported as
    /// `owner`'s.
    #[inline(always)]
    fn closest(&self, ray: &LocalRay, tmin: f32, tmax: f32, owner: Owner, best: &mut Option<Hit>) {
        with_axes!(ray.sheared.k, |KX, KY, KZ| self.closest_axes::<KX, KY, KZ>(ray, tmin, tmax, owner, best))
    }

    /// `closest` with the ray's axes as constants (`Tri::intersect_axes`).
    #[inline(always)]
    fn closest_axes<const KX: usize, const KY: usize, const KZ: usize>(
        &self,
        ray: &LocalRay,
        tmin: f32,
        tmax: f32,
        owner: Owner,
        best: &mut Option<Hit>,
    ) {
        traverse_closest(&self.pairs, Ray::new(ray.o, ray.d, tmin, tmax), |r, slot| {
            let tri = &self.tris[slot];
            match tri.intersect_axes::<KX, KY, KZ>(&ray.sheared, tmin, r.tmax) {
                Some((t, u, v)) if !tri.culled(ray.d, owner.cull) => offer(best, owner.hit(tri, t, u, v)),
                _ => f32::INFINITY,
            }
        });
    }

    /// `closest` for a packet of four rays sharing their axes (`ShearedRay::k`), lane `l`
    /// within [tmin, tmax[l]] (-inf: no part) into `best[l]`; the same hits as `closest` for
    /// each lane alone (`Pairs::traverse4`).
    #[inline(always)]
    fn closest4(&self, rays: &[LocalRay; 4], tmin: f32, tmax: Vec4, owner: Owner, best: &mut [Option<Hit>; 4]) {
        if self.pairs.depth > INLINE_STACK {
            for (l, ray) in rays.iter().enumerate() {
                if tmax[l] >= tmin {
                    self.closest(ray, tmin, tmax[l], owner, &mut best[l]);
                }
            }
            return;
        }
        with_axes!(rays[0].sheared.k, |KX, KY, KZ| {
            let obvh: [Ray; 4] = std::array::from_fn(|l| Ray::new(rays[l].o, rays[l].d, tmin, tmax[l]));
            let o = [0, 1, 2].map(|a| Vec4::from_array(rays.map(|r| r.o[a])));
            let inv = [0, 1, 2].map(|a| Vec4::from_array(obvh.map(|r| r.inv_direction[a])));
            let mut limit = tmax;
            self.pairs.traverse4(o, inv, &obvh, &mut limit, |first, count, lanes, limit| {
                for tri in &self.tris[first as usize..(first + count) as usize] {
                    for l in 0..4 {
                        if lanes & (1 << l) == 0 {
                            continue;
                        }
                        // As `closest_axes` for lane l alone.
                        if let Some((t, u, v)) = tri.intersect_axes::<KX, KY, KZ>(&rays[l].sheared, tmin, limit[l])
                            && !tri.culled(rays[l].d, owner.cull)
                        {
                            let slack = offer(&mut best[l], owner.hit(tri, t, u, v));
                            if slack < limit[l] {
                                limit[l] = slack;
                            }
                        }
                    }
                }
            });
        })
    }

    /// Whether any triangle lies along the ray within [tmin, tmax]; the distance of one.
    #[inline(always)]
    fn any_hit(&self, ray: &LocalRay, tmin: f32, tmax: f32) -> Option<f32> {
        with_axes!(ray.sheared.k, |KX, KY, KZ| self.any_hit_axes::<KX, KY, KZ>(ray, tmin, tmax))
    }

    /// `any_hit` with the ray's axes as constants (`Tri::intersect_axes`).
    #[inline(always)]
    fn any_hit_axes<const KX: usize, const KY: usize, const KZ: usize>(
        &self,
        ray: &LocalRay,
        tmin: f32,
        tmax: f32,
    ) -> Option<f32> {
        let mut found = None;
        traverse_miss(&self.pairs, Ray::new(ray.o, ray.d, tmin, tmax), |_, slot| {
            match self.tris[slot].intersect_axes::<KX, KY, KZ>(&ray.sheared, tmin, tmax) {
                Some((t, _, _)) => {
                    found = Some(t);
                    t
                }
                None => f32::INFINITY,
            }
        });
        found
    }
}

/// A BVH2 laid out for traversal (perf9, issue 16): for each inner node, its two children's
/// boxes side by side, one four-lane vector per axis ([left min, right min, left max, right
/// max]), so one slab test of a few vector operations serves both children; with what each child
/// is (an inner node's own pair, or a leaf's triangles), 64 bytes, one cache line, per pair
/// instead of two 48-byte nodes. The traversal (`Pairs::traverse`) is obvhs's
/// `Bvh2::ray_traverse_dynamic` step for step: each child's entry distance is its slab test's
/// (the same subtractions, products, minima and maxima per lane), the nearer child first, the
/// same stack; so the same leaves are visited in the same order, with the same hits.
struct Pairs {
    /// The root's box and, when the root is a leaf, its (first primitive, count).
    root: Aabb,
    root_leaf: Option<(u32, u32)>,
    /// Pair 0 is the root's children (when the root is inner).
    pairs: Vec<Pair>,
    /// Longest path from the root in pairs: the most the stack holds.
    depth: usize,
}

/// Aligned to a cache line (64 bytes): one line per pair in every run, whatever address the
/// allocation gets (at 16 bytes, most pairs straddled two lines in some runs).
#[derive(Clone, Copy)]
#[repr(C, align(64))]
struct Pair {
    x: glam::Vec4,
    y: glam::Vec4,
    z: glam::Vec4,
    /// Per child: its pair (inner node) or first primitive (leaf).
    index: [u32; 2],
    /// Per child: its primitive count, 0 for an inner node.
    count: [u32; 2],
}

impl Pairs {
    /// The pair layout of `bvh` (an empty tree: nothing is ever hit).
    fn new(bvh: &Bvh2) -> Pairs {
        let empty = Pairs { root: Aabb::empty(), root_leaf: Some((0, 0)), pairs: Vec::new(), depth: 0 };
        let Some(root) = bvh.nodes.first() else { return empty };
        let mut out = Pairs { root: *root.aabb(), root_leaf: None, pairs: Vec::new(), depth: 0 };
        if root.is_leaf() {
            out.root_leaf = Some((root.first_index, root.prim_count));
            return out;
        }
        // Depth first: (node index of the left child, pair slot to fill, depth).
        let mut todo = vec![(root.first_index as usize, 0usize, 1usize)];
        out.pairs.push(Pair::EMPTY);
        while let Some((first, slot, depth)) = todo.pop() {
            out.depth = out.depth.max(depth);
            let (l, r) = (&bvh.nodes[first], &bvh.nodes[first + 1]);
            let (lb, rb) = (l.aabb(), r.aabb());
            let mut pair = Pair {
                x: glam::Vec4::new(lb.min.x, rb.min.x, lb.max.x, rb.max.x),
                y: glam::Vec4::new(lb.min.y, rb.min.y, lb.max.y, rb.max.y),
                z: glam::Vec4::new(lb.min.z, rb.min.z, lb.max.z, rb.max.z),
                index: [0; 2],
                count: [l.prim_count, r.prim_count],
            };
            for (k, node) in [l, r].into_iter().enumerate() {
                if node.is_leaf() {
                    pair.index[k] = node.first_index;
                } else {
                    pair.index[k] = out.pairs.len() as u32;
                    todo.push((node.first_index as usize, out.pairs.len(), depth + 1));
                    out.pairs.push(Pair::EMPTY);
                }
            }
            out.pairs[slot] = pair;
        }
        out
    }

    /// obvhs's `ray_traverse_dynamic` on this layout: `leaf(first, count, &mut ray)` is called
    /// for each leaf the ray reaches (it may lower `ray.tmax`); it returns false to stop.
    #[inline(always)]
    fn traverse<F: FnMut(u32, u32, &mut Ray) -> bool>(&self, ray: Ray, leaf: F) {
        if self.depth <= INLINE_STACK {
            self.traverse_on(&mut InlineStack::new(), ray, leaf)
        } else {
            self.traverse_on(&mut Vec::with_capacity(self.depth), ray, leaf)
        }
    }

    /// `traverse` on `stack`.
    #[inline(always)]
    fn traverse_on<S: NodeStack, F: FnMut(u32, u32, &mut Ray) -> bool>(
        &self,
        stack: &mut S,
        mut ray: Ray,
        mut leaf: F,
    ) {
        if !(self.root.intersect_ray(&ray) < ray.tmax) {
            return;
        }
        if let Some((first, count)) = self.root_leaf {
            if count > 0 {
                leaf(first, count, &mut ray);
            }
            return;
        }
        let (o, inv) = (ray.origin, ray.inv_direction);
        let (ox, oy, oz) = (glam::Vec4::splat(o.x), glam::Vec4::splat(o.y), glam::Vec4::splat(o.z));
        let (ix, iy, iz) = (glam::Vec4::splat(inv.x), glam::Vec4::splat(inv.y), glam::Vec4::splat(inv.z));
        let mut current = 0u32;
        loop {
            // SAFETY: `current` is 0 (the root is inner here, so `new` pushed pair 0) or an
            // index `new` stored for an inner child after pushing that pair.
            let pair = unsafe { self.pairs.get_unchecked(current as usize) };
            // Lanes: (t at min, t at max) of the left and right child along each axis, then
            // each child's near and far t, as `Aabb::intersect_ray` computes them.
            let tx = (pair.x - ox) * ix;
            let ty = (pair.y - oy) * iy;
            let tz = (pair.z - oz) * iz;
            let (sx, sy, sz) = (tx.zwxy(), ty.zwxy(), tz.zwxy());
            let near = tx.min(sx).max(ty.min(sy).max(tz.min(sz)));
            let far = tx.max(sx).min(ty.max(sy).min(tz.max(sz)));
            let crossed = far.cmpge(near) & far.cmpge(glam::Vec4::ZERO);
            let t = glam::Vec4::select(crossed, near, glam::Vec4::INFINITY);
            let (mut lt, mut rt) = (t.x, t.y);
            let (mut l, mut r) = (0usize, 1usize);
            if lt > rt {
                std::mem::swap(&mut lt, &mut rt);
                std::mem::swap(&mut l, &mut r);
            }
            // Whether to go down child `k` (entry `t`, against the ray's tmax as it is then): a
            // leaf is handed to `leaf` at once instead. None: `leaf` said stop.
            let mut go = |k: usize, t: f32, ray: &mut Ray| -> Option<bool> {
                let hit = t < ray.tmax;
                if hit && pair.count[k] != 0 {
                    return leaf(pair.index[k], pair.count[k], ray).then_some(false);
                }
                Some(hit)
            };
            let Some(go_left) = go(l, lt, &mut ray) else { return };
            let Some(go_right) = go(r, rt, &mut ray) else { return };
            match next_pair(stack, go_left.then_some(pair.index[l]), go_right.then_some(pair.index[r])) {
                Some(next) => current = next,
                None => return,
            }
        }
    }
}

impl Pairs {
    /// `traverse` for a packet of four rays (perf16, issue 16): `o` and `inv` hold the rays'
    /// origins and inverse directions per axis (one lane a ray), `tmax` each ray's current
    /// limit (-inf: the lane takes no part). Each pair's boxes are tested for all four rays at
    /// once, by the same operations per lane as `traverse_on` (so a lane enters exactly the
    /// boxes its ray alone would at that `tmax`); `leaf(first, count, lanes, tmax)` is called
    /// for each leaf with the bits of the lanes that reach it, and may lower their `tmax`. The
    /// nearer child is walked first by its nearest lane. Neighbouring pixels' rays walk mostly
    /// the same nodes, so one walk serves four: 1M primary rays on the 1M-triangle mesh took
    /// 0.69x the time of single rays, with the same hits. `self.depth` must be at most
    /// `INLINE_STACK`.
    #[inline(always)]
    fn traverse4<F: FnMut(u32, u32, u32, &mut Vec4)>(
        &self,
        o: [Vec4; 3],
        inv: [Vec4; 3],
        rays: &[Ray; 4],
        tmax: &mut Vec4,
        mut leaf: F,
    ) {
        debug_assert!(self.depth <= INLINE_STACK);
        let mut root = 0u32;
        for (l, ray) in rays.iter().enumerate() {
            if self.root.intersect_ray(ray) < tmax[l] {
                root |= 1 << l;
            }
        }
        if root == 0 {
            return;
        }
        if let Some((first, count)) = self.root_leaf {
            if count > 0 {
                leaf(first, count, root, tmax);
            }
            return;
        }
        // One child's entry distance per lane (infinite: missed), as `traverse_on` computes
        // it for one ray: the same subtractions, products, minima and maxima in the same order.
        let entry = |min: [f32; 3], max: [f32; 3]| -> Vec4 {
            let (ax, bx) = ((Vec4::splat(min[0]) - o[0]) * inv[0], (Vec4::splat(max[0]) - o[0]) * inv[0]);
            let (ay, by) = ((Vec4::splat(min[1]) - o[1]) * inv[1], (Vec4::splat(max[1]) - o[1]) * inv[1]);
            let (az, bz) = ((Vec4::splat(min[2]) - o[2]) * inv[2], (Vec4::splat(max[2]) - o[2]) * inv[2]);
            let near = ax.min(bx).max(ay.min(by).max(az.min(bz)));
            let far = ax.max(bx).min(ay.max(by).min(az.max(bz)));
            let crossed = far.cmpge(near) & far.cmpge(Vec4::ZERO);
            Vec4::select(crossed, near, Vec4::INFINITY)
        };
        let mut stack = InlineStack::new();
        let mut current = 0u32;
        loop {
            // SAFETY: as in `traverse_on`.
            let pair = unsafe { self.pairs.get_unchecked(current as usize) };
            let (x, y, z) = (pair.x, pair.y, pair.z);
            let mut t = [entry([x.x, y.x, z.x], [x.z, y.z, z.z]), entry([x.y, y.y, z.y], [x.w, y.w, z.w])];
            let (mut l, mut r) = (0usize, 1usize);
            let nearest = |t: Vec4, tmax: Vec4| Vec4::select(t.cmplt(tmax), t, Vec4::INFINITY).min_element();
            if nearest(t[0], *tmax) > nearest(t[1], *tmax) {
                (l, r) = (1, 0);
                t.swap(0, 1);
            }
            // Lanes going down child `k` (entry `t`, against the lanes' tmax as they are
            // then); a leaf is handed to `leaf` at once instead (no lane goes further).
            let mut go = |k: usize, t: Vec4, tmax: &mut Vec4| -> u32 {
                let lanes = t.cmplt(*tmax).bitmask();
                if lanes != 0 && pair.count[k] != 0 {
                    leaf(pair.index[k], pair.count[k], lanes, tmax);
                    return 0;
                }
                lanes
            };
            let go_left = go(l, t[0], tmax) != 0;
            let go_right = go(r, t[1], tmax) != 0;
            match next_pair(&mut stack, go_left.then_some(pair.index[l]), go_right.then_some(pair.index[r])) {
                Some(next) => current = next,
                None => return,
            }
        }
    }
}

impl Pair {
    const EMPTY: Pair =
        Pair { x: glam::Vec4::ZERO, y: glam::Vec4::ZERO, z: glam::Vec4::ZERO, index: [0; 2], count: [0; 2] };
}

/// Slightly beyond distance `t`: a closest-hit walk's new limit after a hit at `t`, so nodes
/// whose entry is exactly `t` are still visited and an equal-distance triangle there can win
/// the id tie-break.
#[inline(always)]
fn just_beyond(t: f32) -> f32 {
    t * (1.0 + 4.0 * f32::EPSILON) + f32::MIN_POSITIVE
}

/// Keeps `hit` in `best` when it is nearer, or as near with a lower triangle id (so the
/// result never depends on the order triangles are met); the walk's new limit either way.
#[inline(always)]
fn offer(best: &mut Option<Hit>, hit: Hit) -> f32 {
    let better = match best {
        None => true,
        Some(b) => hit.t < b.t || (hit.t == b.t && hit.tri < b.tri),
    };
    if better {
        *best = Some(hit);
    }
    just_beyond(hit.t)
}

/// The pair a walk visits next, given the children of the current pair it goes down (`near`
/// first, `far` kept on `stack` for later; None: not entered): None when the walk is done.
#[inline(always)]
fn next_pair<S: NodeStack>(stack: &mut S, near: Option<u32>, far: Option<u32>) -> Option<u32> {
    match (near, far) {
        (Some(near), Some(far)) => {
            stack.push(far);
            Some(near)
        }
        (Some(next), None) | (None, Some(next)) => Some(next),
        (None, None) => stack.pop(),
    }
}

/// The lanes of bit mask `lanes` (bit l: lane l) as a vector mask.
#[inline(always)]
fn mask_lanes(lanes: u32) -> glam::BVec4A {
    glam::BVec4A::new(lanes & 1 != 0, lanes & 2 != 0, lanes & 4 != 0, lanes & 8 != 0)
}

/// Depth up to which the traversal stack lives on the machine stack (the trees here are about
/// 20-40 deep).
const INLINE_STACK: usize = 64;

/// The traversal stack of pair indices.
trait NodeStack {
    fn push(&mut self, v: u32);
    fn pop(&mut self) -> Option<u32>;
}

/// A stack on the machine stack, never zero-filled (obvhs's stacks zero-fill their slots per
/// traversal, about 1% of a render's CPU).
struct InlineStack {
    data: [std::mem::MaybeUninit<u32>; INLINE_STACK],
    len: usize,
}

impl InlineStack {
    /// An empty stack, its slots left unwritten. perf10 (issue 16): built as
    /// `[MaybeUninit::uninit(); INLINE_STACK]` beside `len: 0`, the whole 264-byte struct was
    /// zero-filled by a `memset` call at every traversal (two per primary ray, two per shadow
    /// ray: about 2% of a render's CPU).
    #[inline(always)]
    fn new() -> InlineStack {
        // SAFETY: an array of `MaybeUninit` needs no initialisation.
        let data =
            unsafe { std::mem::MaybeUninit::<[std::mem::MaybeUninit<u32>; INLINE_STACK]>::uninit().assume_init() };
        InlineStack { data, len: 0 }
    }
}

impl NodeStack for InlineStack {
    #[inline(always)]
    fn push(&mut self, v: u32) {
        // At most one push per level of the tree, so `len` stays under its depth.
        self.data[self.len] = std::mem::MaybeUninit::new(v);
        self.len += 1;
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<u32> {
        if self.len == 0 {
            return None;
        }
        self.len -= 1;
        // SAFETY: the slots below `len` were written by `push`.
        Some(unsafe { self.data[self.len].assume_init() })
    }
}

impl NodeStack for Vec<u32> {
    #[inline(always)]
    fn push(&mut self, v: u32) {
        Vec::push(self, v)
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<u32> {
        Vec::pop(self)
    }
}

/// The closest-hit traversal of `tree`: `f(ray, slot)` gives a primitive's distance
/// (infinite: missed), and the ray's `tmax` drops to each nearer one.
#[inline(always)]
fn traverse_closest<F: FnMut(&Ray, usize) -> f32>(tree: &Pairs, ray: Ray, mut f: F) {
    tree.traverse(ray, |first, count, ray| {
        for id in first..first + count {
            let t = f(ray, id as usize);
            if t < ray.tmax {
                ray.tmax = t;
            }
        }
        true
    });
}

/// Whether no primitive of `tree` lies along the ray (stops at the first).
#[inline(always)]
fn traverse_miss<F: FnMut(&Ray, usize) -> f32>(tree: &Pairs, ray: Ray, mut f: F) -> bool {
    let mut miss = true;
    tree.traverse(ray, |first, count, ray| {
        for id in first..first + count {
            if f(ray, id as usize) < ray.tmax {
                miss = false;
                return false;
            }
        }
        true
    });
    miss
}

/// A ray in some BLAS's base space, ready for traversal and the watertight test.
#[derive(Clone, Copy)]
struct LocalRay {
    o: Vec3A,
    d: Vec3A,
    sheared: ShearedRay,
}

impl LocalRay {
    #[inline(always)]
    fn new(o: Vec3A, d: Vec3A) -> LocalRay {
        let d = traced_direction(d);
        LocalRay { o, d, sheared: ShearedRay::new(o, d) }
    }
}

/// A placed object in the top-level BVH.
#[derive(Clone, Copy)]
struct Instance {
    blas: u32,
    object: u32,
    first_triangle: u32,
    /// Render space -> base space; None: the identity (the geometry is baked for this object).
    to_base: Option<Affine3A>,
    /// A backdrop's plane (`scene::backdrop`): rays starting behind it pass through it.
    backdrop: Option<Backdrop>,
    /// An enclosure (`scene::enclosure`) has its inner side only: 1 or -1, the sign of d . n
    /// (d the ray in base space, n the normal its triangles' winding gives there) of the faces
    /// a ray leaves it through, which it hits; a ray entering through a face passes it. 0 for
    /// every other object. Enclosures cast no shadow (`occluded` passes them).
    cull: f32,
}

impl Instance {
    /// Whether a ray starting at `origin` (render space) passes through this instance: a
    /// backdrop has the subject's side only.
    #[inline(always)]
    fn skipped_from(&self, origin: Vec3A) -> bool {
        self.backdrop.is_some_and(|b| b.behind(Vec3::from(origin)))
    }

    /// What its BLAS's hits are reported as.
    #[inline(always)]
    fn owner(&self) -> Owner {
        Owner { first_triangle: self.first_triangle, object: self.object, cull: self.cull }
    }

    /// The render-space ray `world` in this instance's base space.
    #[inline(always)]
    fn ray(&self, world: &LocalRay) -> LocalRay {
        match &self.to_base {
            None => *world,
            Some(m) => LocalRay::new(m.transform_point3a(world.o), m.transform_vector3a(world.d)),
        }
    }
}

/// The objects whose geometry is baked for them (no placement), up to `GROUP_CAP` triangles
/// in all, traced as one BLAS over their render-space triangles (perf16, issues 14 and 16): a
/// ray through a table of a dozen small objects entered each object's box and walked each
/// BLAS in turn; one tree over them all splits space across objects. The still life's
/// primary rays took 0.67x the time, with the same hits. Every BLAS of a geometry is kept
/// too, so an object that moves or changes leaves the group (it is rebuilt, which the cap
/// keeps to milliseconds) and is traced through its own BLAS, as before.
struct Group {
    /// Its triangles' ids are global triangle ids (`Tri::id`), so ties resolve as before.
    blas: Blas,
    /// (first triangle, object) of each member, ascending: the object a hit's id lies in.
    members: Vec<(u32, u32)>,
    /// What it was built from: each member's (BLAS content key, first triangle, object).
    key: Vec<(u128, u32, u32)>,
}

/// The most triangles the group holds: its build (about 0.65 us a triangle on two cores,
/// 40 ms at the cap) repeats every BLAS build of its members.
const GROUP_CAP: usize = 1 << 16;
/// `Instance::blas` and `Hit::object` of the group's instance (resolved per hit).
const GROUP: u32 = u32::MAX;

impl Group {
    /// The group of `members` (instances with no placement, in ascending first triangle),
    /// reusing `old` when it was built from the same BLASes and objects.
    fn build(world: &World, blas: &[Blas], members: &[Instance], old: Option<Group>) -> Option<Group> {
        let key: Vec<(u128, u32, u32)> =
            members.iter().map(|m| (blas[m.blas as usize].key, m.first_triangle, m.object)).collect();
        if let Some(old) = old.filter(|g| g.key == key) {
            return Some(old);
        }
        // The members' geometries in one, then each triangle's id made global.
        let mut merged = Geometry {
            source: 0,
            base: glam::DMat4::IDENTITY,
            positions: Vec::new(),
            normals: Vec::new(),
            uvs: None,
            colors: None,
            triangles: Vec::new(),
        };
        let mut starts = Vec::with_capacity(members.len());
        for m in members {
            let g = &world.geometries[world.objects[m.object as usize].geometry];
            let offset = merged.positions.len() as u32;
            starts.push((merged.triangles.len() as u32, m.first_triangle));
            merged.positions.extend_from_slice(&g.positions);
            merged.triangles.extend(g.triangles.iter().map(|t| t.map(|i| i + offset)));
        }
        let mut group = Blas::build(&merged, 0)?;
        for t in &mut group.tris {
            let (start, first) = starts[starts.partition_point(|s| s.0 <= t.id) - 1];
            t.id = first + (t.id - start);
        }
        let members = members.iter().map(|m| (m.first_triangle, m.object)).collect();
        Some(Group { blas: group, members, key })
    }

    /// The object global triangle `tri` belongs to.
    fn object_of(&self, tri: u32) -> u32 {
        self.members[self.members.partition_point(|m| m.0 <= tri) - 1].1
    }
}

/// Ray queries against the world: a two-level BVH. Each geometry (one per mesh, see
/// `scene::world`) has a bottom-level BVH (BLAS) over its triangles, built once per distinct
/// content; a top-level BVH (TLAS) over the objects' boxes places them. An instanced mesh
/// costs one BLAS however many objects place it; an object that moves costs a TLAS rebuild
/// (`update_instances`); a mesh whose vertices changed costs a refit or rebuild of its BLAS
/// alone (`refit_mesh`, `rebuild_mesh`); a changed scene reuses every BLAS whose content is
/// unchanged (`update`).
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

    /// Brings the BVHs up to `world`, which may be a different world altogether (a changed
    /// scene file): every geometry whose content (base-space positions and triangles) has a
    /// BLAS already keeps it, only new content is built, and the TLAS is rebuilt. Costs a
    /// hash of every geometry's vertices; use `update_instances` when only transforms moved.
    pub fn update(&mut self, world: &World) -> UpdateStats {
        let keys: Vec<u128> = world.geometries.par_iter().map(content_key).collect();
        let old: std::collections::HashMap<u128, usize> =
            self.blas.iter().enumerate().map(|(i, b)| (b.key, i)).collect();
        // Geometries sharing a key share a BLAS (checked in full, so a hash collision only
        // costs a second BLAS).
        let mut owner: Vec<usize> = (0..keys.len()).collect();
        let mut first_of: std::collections::HashMap<u128, usize> = std::collections::HashMap::new();
        for (g, k) in keys.iter().enumerate() {
            match first_of.get(k) {
                Some(&f) if same_content(&world.geometries[f], &world.geometries[g]) => owner[g] = f,
                Some(_) => {}
                None => {
                    first_of.insert(*k, g);
                }
            }
        }
        let mut stats = UpdateStats::default();
        let to_build: Vec<usize> = (0..keys.len()).filter(|&g| owner[g] == g && !old.contains_key(&keys[g])).collect();
        stats.built = to_build.len();
        let built: Vec<Option<Blas>> =
            to_build.par_iter().map(|&g| Blas::build(&world.geometries[g], keys[g])).collect();
        let mut new_built: std::collections::HashMap<usize, Option<Blas>> = to_build.into_iter().zip(built).collect();
        let mut previous: Vec<Option<Blas>> = std::mem::take(&mut self.blas).into_iter().map(Some).collect();
        let mut blas = Vec::new();
        let mut index_of_owner: std::collections::HashMap<usize, Option<u32>> = std::collections::HashMap::new();
        let mut geometry_blas = vec![None; keys.len()];
        for g in 0..keys.len() {
            let o = owner[g];
            let slot = match index_of_owner.get(&o) {
                Some(s) => *s,
                None => {
                    let b = match new_built.remove(&o) {
                        Some(b) => b,
                        None => {
                            stats.reused += 1;
                            previous[old[&keys[o]]].take()
                        }
                    };
                    let s = b.map(|b| {
                        blas.push(b);
                        (blas.len() - 1) as u32
                    });
                    index_of_owner.insert(o, s);
                    s
                }
            };
            geometry_blas[g] = slot;
        }
        self.blas = blas;
        self.geometry_blas = geometry_blas;
        self.update_instances(world);
        stats
    }

    /// Rebuilds the TLAS from the objects' current placements (after
    /// `World::set_transforms`): no triangle is touched. Geometries added since the last
    /// build (an object given its own copy) get their BLAS first.
    pub fn update_instances(&mut self, world: &World) {
        if self.geometry_blas.len() < world.geometries.len() {
            for g in self.geometry_blas.len()..world.geometries.len() {
                let geometry = &world.geometries[g];
                let b = Blas::build(geometry, content_key(geometry));
                self.geometry_blas.push(b.map(|b| {
                    self.blas.push(b);
                    (self.blas.len() - 1) as u32
                }));
            }
        }
        // One instance per object with something hittable; exact duplicates (the same BLAS,
        // placed the same way: coincident copies) are left out like coincident triangles, the
        // first (lowest ids) kept. PLOC turns quadratic on thousands of equal boxes.
        let mut seen = std::collections::HashSet::new();
        let mut instances = Vec::new();
        let mut boxes = Vec::new();
        for (i, o) in world.objects.iter().enumerate() {
            let Some(blas) = self.geometry_blas.get(o.geometry).copied().flatten() else {
                continue;
            };
            let place_bits = o.placement.map(|p| {
                let m = p.to_render.to_cols_array();
                m.map(f32::to_bits)
            });
            if !seen.insert((blas, place_bits)) {
                continue;
            }
            let b = self.blas[blas as usize].bounds;
            let aabb = match &o.placement {
                None => b,
                Some(p) => {
                    let mut r = Aabb::empty();
                    for k in 0..8 {
                        let c = Vec3A::new(
                            if k & 1 == 0 { b.min.x } else { b.max.x },
                            if k & 2 == 0 { b.min.y } else { b.max.y },
                            if k & 4 == 0 { b.min.z } else { b.max.z },
                        );
                        r.extend(p.to_render.transform_point3a(c));
                    }
                    // Rounding of the f32 map must not cut off a grazing ray.
                    let pad = (r.max - r.min).max_element() * 1e-5 + 1e-6;
                    Aabb::new(r.min - pad, r.max + pad)
                }
            };
            if !(aabb.min.is_finite() && aabb.max.is_finite()) {
                continue;
            }
            instances.push(Instance {
                blas,
                object: i as u32,
                first_triangle: o.first_triangle,
                to_base: o.placement.map(|p| p.to_base),
                backdrop: world.backdrops.iter().find(|b| b.object == i).copied(),
                cull: world.enclosures.iter().find(|e| e.object == i).map_or(0.0, |e| {
                    // A mirroring placement turns the winding over in base space.
                    let mirrored = o.placement.is_some_and(|p| p.to_base.matrix3.determinant() < 0.0);
                    if e.outward != mirrored { 1.0 } else { -1.0 }
                }),
            });
            boxes.push(aabb);
        }
        // The baked objects, in ascending triangle ids, while they fit under the cap.
        let mut grouped = Vec::new();
        let mut total = 0;
        // (A backdrop or an enclosure keeps its own instance: rays behind it skip it, rays
        // entering it pass its faces.)
        let mut by_id: Vec<usize> = (0..instances.len())
            .filter(|&k| instances[k].to_base.is_none() && instances[k].backdrop.is_none() && instances[k].cull == 0.0)
            .collect();
        by_id.sort_by_key(|&k| instances[k].first_triangle);
        for k in by_id {
            let n = self.blas[instances[k].blas as usize].tris.len();
            if total + n <= GROUP_CAP {
                total += n;
                grouped.push(k);
            }
        }
        let old = self.group.take();
        if grouped.len() >= 2 {
            let members: Vec<Instance> = grouped.iter().map(|&k| instances[k]).collect();
            self.group = Group::build(world, &self.blas, &members, old);
            if let Some(group) = &self.group {
                let mut out = vec![false; instances.len()];
                grouped.iter().for_each(|&k| out[k] = true);
                (instances, boxes) =
                    instances.into_iter().zip(boxes).zip(out).filter(|(_, out)| !out).map(|(pair, _)| pair).unzip();
                instances.push(Instance {
                    blas: GROUP,
                    object: GROUP,
                    first_triangle: 0,
                    to_base: None,
                    backdrop: None,
                    cull: 0.0,
                });
                boxes.push(group.blas.bounds);
            }
        }
        if instances.is_empty() {
            (self.tlas, self.instances) = (None, Vec::new());
            return;
        }
        let mut tlas = build_bvh2(&boxes, BUILD, &mut Duration::default());
        self.instances = tlas.primitive_indices.iter().map(|&i| instances[i as usize]).collect();
        tlas.primitive_indices = Vec::new();
        let pairs = Pairs::new(&tlas);
        self.tlas = Some((tlas, pairs));
    }

    /// After `World::set_vertices` on a small deformation (skinning, a wave): the BLAS of
    /// geometry `g` keeps its tree and refits its boxes to the new corners, O(triangles),
    /// then the TLAS is rebuilt. Falls back to `rebuild_mesh` when a triangle became or
    /// stopped being hittable, or when the BLAS is shared with other geometries of the same
    /// former content. Returns whether it refitted (false: rebuilt). Traversal slows as the
    /// tree fits the new shape worse: rebuild after large changes.
    pub fn refit_mesh(&mut self, world: &World, g: usize) -> bool {
        let Some(Some(b)) = self.geometry_blas.get(g).copied() else {
            self.rebuild_mesh(world, g);
            return false;
        };
        let shared = self.geometry_blas.iter().filter(|x| **x == Some(b)).count() > 1;
        let geometry = &world.geometries[g];
        if shared || !self.blas[b as usize].refit(geometry) {
            self.rebuild_mesh(world, g);
            return false;
        }
        self.blas[b as usize].key = content_key(geometry);
        self.update_instances(world);
        true
    }

    /// Builds the BLAS of geometry `g` anew from its current vertices (after
    /// `World::set_vertices` with a large change), then the TLAS.
    pub fn rebuild_mesh(&mut self, world: &World, g: usize) {
        let geometry = &world.geometries[g];
        let built = Blas::build(geometry, content_key(geometry));
        if self.geometry_blas.len() < world.geometries.len() {
            self.geometry_blas.resize(world.geometries.len(), None);
        }
        let old = self.geometry_blas[g];
        let shared = old.is_some() && self.geometry_blas.iter().filter(|x| **x == old).count() > 1;
        self.geometry_blas[g] = match (old, built) {
            (Some(b), Some(new)) if !shared => {
                self.blas[b as usize] = new;
                Some(b)
            }
            (_, Some(new)) => {
                self.blas.push(new);
                Some((self.blas.len() - 1) as u32)
            }
            (_, None) => None,
        };
        self.update_instances(world);
    }

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
            if inst.skipped_from(world.o) || inst.cull != 0.0 {
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
mod tests {
    use super::*;
    use crate::scene::World;
    use obvhs::bvh2::builder::build_bvh2_from_tris;

    /// `n` random triangles from `next` (uniform in -1..1): centres `spread` x a point of the
    /// cube, corners within `min_size` + up to 0.2 of them.
    fn soup(next: &mut impl FnMut() -> f32, n: usize, spread: f32, min_size: f32) -> Vec<Triangle> {
        (0..n)
            .map(|_| {
                let c = Vec3A::new(next(), next(), next()) * spread;
                let s = min_size + 0.2 * next().abs();
                let mut corner = || c + Vec3A::new(next(), next(), next()) * s;
                Triangle { v0: corner(), v1: corner(), v2: corner() }
            })
            .collect()
    }

    /// `build_tris` (PLOC, then our `collapse`) gives obvhs's `build_bvh2_from_tris` tree bit
    /// for bit (boxes, counts, indices, primitive order), on soups of several sizes (the small
    /// ones below the collapse's thresholds), clustered and coincident triangles included.
    #[test]
    fn our_collapse_builds_the_tree_obvhs_builds() {
        use crate::util::rng::{splitmix64, unit_f64};
        let mut state = 11u64;
        let mut next = || {
            state = splitmix64(state);
            unit_f64(state) as f32 * 2.0 - 1.0
        };
        for (n, spread) in
            [(1usize, 1.0), (2, 1.0), (8, 1.0), (17, 1.0), (18, 0.0), (400, 1.0), (5000, 1.0), (5000, 0.01)]
        {
            let mut tris = soup(&mut next, n, spread, 0.01);
            // Some exact copies (the collapse's same-primitive case needs equal boxes).
            for i in (0..n).step_by(7).skip(1) {
                tris[i] = tris[i - 1];
            }
            let theirs = build_bvh2_from_tris(&tris, BUILD, &mut Duration::default());
            let ours = build_tris(&tris);
            let bits = |b: &Bvh2| -> Vec<[u32; 8]> {
                b.nodes
                    .iter()
                    .map(|x| {
                        let (lo, hi) = (x.aabb().min, x.aabb().max);
                        let [a, b, c, d, e, f] = [lo.x, lo.y, lo.z, hi.x, hi.y, hi.z].map(f32::to_bits);
                        [a, b, c, d, e, f, x.prim_count, x.first_index]
                    })
                    .collect()
            };
            assert_eq!(bits(&ours), bits(&theirs), "{n} triangles");
            assert_eq!(ours.primitive_indices, theirs.primitive_indices, "{n} triangles");
            assert!(ours.nodes.iter().any(|x| x.prim_count > 1) || n < 20, "{n}: something collapsed");
            assert_eq!(ours.parents, theirs.parents);
            assert_eq!(ours.primitives_to_nodes, theirs.primitives_to_nodes);
            assert_eq!(ours.children_are_ordered_after_parents, theirs.children_are_ordered_after_parents);
            assert_eq!(ours.uses_spatial_splits, theirs.uses_spatial_splits);
            assert_eq!(ours.max_depth, theirs.max_depth);
        }
    }

    /// perf9: the pair layout's traversal reaches the same leaves in the same order as obvhs's
    /// `ray_traverse_dynamic`, with the same distances handed on, for closest hits (tmax
    /// lowered by each hit) and any-hit queries, on random triangle soups of several sizes
    /// (one triangle: a root leaf) and rays from inside and outside, axis-aligned ones included.
    #[test]
    fn pair_traversal_visits_the_leaves_obvhs_visits() {
        use crate::util::rng::{splitmix64, unit_f64};
        let mut state = 3u64;
        let mut next = || {
            state = splitmix64(state);
            unit_f64(state) as f32 * 2.0 - 1.0
        };
        for n in [1usize, 2, 3, 17, 400, 3000] {
            let tris = soup(&mut next, n, 1.0, 0.05);
            let bvh = build_bvh2_from_tris(&tris, BUILD, &mut Duration::default());
            let pairs = Pairs::new(&bvh);
            let sheared: Vec<Tri> = bvh
                .primitive_indices
                .iter()
                .map(|&i| {
                    let t = &tris[i as usize];
                    Tri { p: [t.v0.into(), t.v1.into(), t.v2.into()], id: i }
                })
                .collect();
            for r in 0..300 {
                let o = Vec3A::new(next(), next(), next()) * if r % 2 == 0 { 3.0 } else { 0.5 };
                let mut d = Vec3A::new(next(), next(), next());
                if r % 7 == 0 {
                    d = Vec3A::new(0.0, 0.0, if r % 2 == 0 { 1.0 } else { -1.0 });
                }
                let ray = LocalRay::new(o, d.normalize_or(Vec3A::Z));
                let t_of = |slot: usize| {
                    sheared[slot].intersect(&ray.sheared, 0.0, f32::INFINITY).map_or(f32::INFINITY, |h| h.0)
                };
                for any in [false, true] {
                    let (mut ours, mut theirs) = (Vec::new(), Vec::new());
                    let visit = |seen: &mut Vec<(u32, u32, u32)>, first: u32, count: u32, ray: &mut Ray| {
                        seen.push((first, count, ray.tmax.to_bits()));
                        for id in first..first + count {
                            let t = t_of(id as usize);
                            if t < ray.tmax {
                                if any {
                                    return false;
                                }
                                ray.tmax = t;
                            }
                        }
                        true
                    };
                    let start = Ray::new(ray.o, ray.d, 0.0, f32::INFINITY);
                    pairs.traverse(start, |f, c, r| visit(&mut ours, f, c, r));
                    let mut stack = obvhs::faststack::HeapStack::<u32>::new_with_capacity(256);
                    let mut hit = obvhs::ray::RayHit::none();
                    bvh.ray_traverse_dynamic(&mut stack, start, &mut hit, |node, r, _| {
                        visit(&mut theirs, node.first_index, node.prim_count, r)
                    });
                    assert_eq!(ours, theirs, "{n} triangles, ray {r}, any-hit {any}");
                }
            }
        }
    }

    fn world_of(tris: Vec<[Vec3; 3]>) -> World {
        World::from_triangles(&tris)
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
        assert_eq!(a.stored_triangles(), 12, "only the first box's triangles are built");
        assert!(a.blas[0].tris.iter().all(|t| t.id < 12));
        for dir in [Vec3::NEG_Z, Vec3::new(0.3, -0.5, -0.8).normalize(), Vec3::X] {
            let o = Vec3::new(0.1, 0.2, 0.3) - dir * 5.0;
            let h = a.closest(o, dir, 0.0, f32::INFINITY).unwrap();
            assert!(h.tri < 12, "a copy won: {h:?}");
            assert!(a.occluded(o, dir, 0.0, 10.0));
        }
    }

    /// A backdrop (`scene::backdrop`) has its subject's side only: a ray from below the floor
    /// passes through it to the box above, or to nothing; from above it lands on the floor; the
    /// same hits one by one and in packets, and for shadow rays.
    #[test]
    fn rays_from_behind_a_backdrop_pass_through_it() {
        use crate::scene::default::cuboid;
        use crate::scene::{Material, Object, Scene};
        use glam::{DMat4, DVec3};
        let mut s = Scene::default();
        s.materials.push(Material::default());
        s.meshes.push(cuboid("floor", Vec3::new(20.0, 0.01, 20.0), 0));
        s.meshes.push(cuboid("box", Vec3::ONE, 0));
        for (mesh, y) in [(0, -0.005), (1, 1.0)] {
            s.objects.push(Object {
                name: "o".into(),
                mesh,
                transform: DMat4::from_translation(DVec3::new(0.0, y, 0.0)),
            });
        }
        let world = World::new(&s);
        assert_eq!(world.backdrops.len(), 1);
        let accel = Accel::new(&world);
        let at = |x: f64, y: f64, z: f64| world.to_render.point(DVec3::new(x, y, z));
        let up = (at(0.0, 1.0, 0.0) - at(0.0, 0.0, 0.0)).normalize();
        // From below, under the box: the box's bottom face, not the floor's.
        let hit = accel.closest(at(0.0, -3.0, 0.0), up, 0.0, f32::INFINITY).expect("the box");
        assert_eq!(world.object_of(hit.tri), 1);
        // From below, beside the box: nothing.
        assert!(accel.closest(at(4.0, -3.0, 0.0), up, 0.0, f32::INFINITY).is_none());
        assert!(!accel.occluded(at(4.0, -3.0, 0.0), up, 0.0, f32::INFINITY));
        // From above, beside the box: the floor.
        let hit = accel.closest(at(4.0, 3.0, 0.0), -up, 0.0, f32::INFINITY).expect("the floor");
        assert_eq!(world.object_of(hit.tri), 0);
        assert!(accel.occluded(at(4.0, 3.0, 0.0), -up, 0.0, f32::INFINITY));
        // Packets mixing both sides: the same hits as one by one.
        let rays =
            [(at(0.0, -3.0, 0.0), up), (at(4.0, 3.0, 0.0), -up), (at(0.1, -3.0, 0.1), up), (at(4.1, -3.0, 0.1), up)];
        let alone: Vec<_> = rays.iter().map(|&(o, d)| accel.closest(o, d, 0.0, f32::INFINITY)).collect();
        assert_eq!(accel.closest4(&rays, 0.0, f32::INFINITY).to_vec(), alone);
        let below =
            [(at(0.0, -3.0, 0.0), up), (at(0.1, -3.0, 0.0), up), (at(0.0, -3.0, 0.1), up), (at(4.0, -3.0, 0.0), up)];
        let alone: Vec<_> = below.iter().map(|&(o, d)| accel.closest(o, d, 0.0, f32::INFINITY)).collect();
        assert_eq!(accel.closest4(&below, 0.0, f32::INFINITY).to_vec(), alone);
        assert!(alone[..3].iter().all(|h| h.is_some_and(|h| world.object_of(h.tri) == 1)) && alone[3].is_none());
    }

    /// An enclosure (`scene::enclosure`) has its inner side only: a ray from outside passes
    /// the wall it enters through and meets the ball inside, or the far wall from inside; a
    /// ray from inside meets the walls; placed by a mirroring transform too; shadow rays pass
    /// it; the same hits one by one and in packets.
    #[test]
    fn rays_entering_an_enclosure_pass_its_near_walls() {
        use crate::scene::default::{cuboid, ellipsoid};
        use crate::scene::{Material, Object, Projection, Scene, SceneCamera};
        use glam::{DMat4, DVec3};
        for mirror in [1.0, -1.0] {
            let mut s = Scene::default();
            s.materials.push(Material::default());
            s.meshes.push(cuboid("room", Vec3::new(10.0, 5.0, 10.0), 0));
            s.meshes.push(ellipsoid("ball", Vec3::splat(0.5), 12, 24, 0));
            let room =
                DMat4::from_translation(DVec3::new(0.0, 2.5, 0.0)) * DMat4::from_scale(DVec3::new(mirror, 1.0, 1.0));
            // A first room far off bakes the mesh, so the room around the camera is a placed
            // copy, mirrored in base space when `mirror` is -1.
            let far_off = DMat4::from_translation(DVec3::new(40.0, 2.5, 0.0));
            s.objects.push(Object { name: "far room".into(), mesh: 0, transform: far_off });
            s.objects.push(Object { name: "room".into(), mesh: 0, transform: room });
            s.objects.push(Object {
                name: "ball".into(),
                mesh: 1,
                transform: DMat4::from_translation(DVec3::new(0.0, 0.5, -2.0)),
            });
            s.camera = Some(SceneCamera {
                position: DVec3::new(0.0, 1.6, 4.0),
                forward: DVec3::NEG_Z,
                up: DVec3::Y,
                projection: Projection::Perspective { yfov: 1.0 },
                focus_distance: None,
            });
            let world = World::new(&s);
            assert_eq!(world.enclosures.iter().map(|e| e.object).collect::<Vec<_>>(), vec![1], "mirror {mirror}");
            assert!(world.objects[1].placement.is_some(), "a placed copy");
            let accel = Accel::new(&world);
            let at = |x: f64, y: f64, z: f64| world.to_render.point(DVec3::new(x, y, z));
            let toward = |a: Vec3, b: Vec3| (b - a).normalize();
            // From outside, in front of the room, at the ball: the ball, through the wall.
            let (o, d) = (at(0.0, 0.5, 20.0), toward(at(0.0, 0.5, 20.0), at(0.0, 0.5, -2.0)));
            assert_eq!(world.object_of(accel.closest(o, d, 0.0, f32::INFINITY).expect("the ball").tri), 2);
            // From outside beside the ball: the far wall, from inside (beyond the room's middle).
            let o2 = at(3.0, 2.0, 20.0);
            let d2 = toward(o2, at(3.0, 2.0, 0.0));
            let far = accel.closest(o2, d2, 0.0, f32::INFINITY).expect("the far wall");
            assert_eq!(world.object_of(far.tri), 1);
            assert!((o2 + d2 * far.t - at(3.0, 2.0, -5.0)).length() < 1e-3, "mirror {mirror}");
            // From inside (the camera): the wall ahead.
            let o3 = at(3.0, 2.0, 4.0);
            let near = accel.closest(o3, d2, 0.0, f32::INFINITY).expect("the wall ahead");
            assert!((o3 + d2 * near.t - at(3.0, 2.0, -5.0)).length() < 1e-3);
            // Shadow rays pass the walls, not the ball.
            assert!(!accel.occluded(o3, d2, 0.0, f32::INFINITY));
            assert!(accel.occluded(o, d, 0.0, f32::INFINITY));
            let rays = [(o, d), (o2, d2), (at(3.1, 2.0, 20.0), d2), (o3, d2)];
            let alone: Vec<_> = rays.iter().map(|&(o, d)| accel.closest(o, d, 0.0, f32::INFINITY)).collect();
            assert_eq!(accel.closest4(&rays, 0.0, f32::INFINITY).to_vec(), alone);
        }
    }
}
