//! A bottom-level BVH per geometry (obvhs PLOC, collapsed to small leaves) and its queries.

use super::*;

/// obvhs's medium preset without reinsertion (PLOC search distance 14; 6, the fast preset's,
/// measured on the 1M-triangle scene: no faster to build, 5% slower to trace): reinsertion's branch-and-bound search cannot
/// prune among heavily overlapping triangles and turns quadratic there (30,000 overlapping
/// boxes, 360K triangles: 38 s; 100,000: over 2 min). Without it the same scenes build in
/// well under a second, and primary rays on the test meshes trace as fast (BENCHMARKS.md).
pub(super) const BUILD: BvhBuildParams = BvhBuildParams {
    reinsertion_batch_ratio: 0.0,
    post_collapse_reinsertion_batch_ratio_multiplier: 0.0,
    ..BvhBuildParams::medium_build()
};

/// What `build_bvh2_from_tris(tris, BUILD, ..)` builds, node for node and index for index
/// (tested): obvhs's PLOC, then `collapse` in place of obvhs's leaf collapse (BUILD has no
/// reinsertion, so nothing else runs).
pub(super) fn build_tris(tris: &[Triangle]) -> Bvh2 {
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
pub(super) fn collapse(bvh: &mut Bvh2, max_prims: u32, traversal_cost: f32) {
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

/// A bottom-level BVH: one geometry's triangles in their base space.
pub(super) struct Blas {
    pub(super) bvh: Bvh2,
    /// `bvh` laid out for traversal.
    pub(super) pairs: Pairs,
    /// Triangles in leaf order (leaves index them directly).
    pub(super) tris: Vec<Tri>,
    /// Bounds of the triangles, base space.
    pub(super) bounds: Aabb,
    /// Content key: a hash of the geometry's positions and triangles (`content_key`).
    pub(super) key: u128,
}

/// The key a geometry's BLAS is shared and reused by: its base-space positions and
/// triangles, bit for bit (checked in full on a key match, see `same_content`).
pub(super) fn content_key(g: &Geometry) -> u128 {
    let mut h = xxhash_rust::xxh3::Xxh3::new();
    // Each number's little-endian bytes in turn, fed in bulk.
    update_words(&mut h, &g.positions);
    h.update(&[0xff]);
    update_words(&mut h, &g.triangles);
    h.digest128()
}

pub(super) fn same_content(a: &Geometry, b: &Geometry) -> bool {
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
    pub(super) fn build(g: &Geometry, key: u128) -> Option<Blas> {
        // Exact copies found by sorting (hash of the corner set, id) in parallel: the same
        // triangles kept as a serial hash set gave (the lowest id of each corner set), at a
        // fraction of its cost on million-triangle meshes.
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

    /// The closest hit in this BLAS better than `best` (nearer, or as near with a lower
    /// triangle id), for the ray `o + t d` (base space) with `tmin <= t <= tmax`, reported as
    /// `owner`'s.
    #[inline(always)]
    pub(super) fn closest(&self, ray: &LocalRay, tmin: f32, tmax: f32, owner: Owner, best: &mut Option<Hit>) {
        with_axes!(ray.sheared.k, |KX, KY, KZ| self.closest_axes::<KX, KY, KZ>(ray, tmin, tmax, owner, best))
    }

    /// `closest` with the ray's axes as constants (`Tri::intersect_axes`).
    #[inline(always)]
    pub(super) fn closest_axes<const KX: usize, const KY: usize, const KZ: usize>(
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
    pub(super) fn closest4(
        &self,
        rays: &[LocalRay; 4],
        tmin: f32,
        tmax: Vec4,
        owner: Owner,
        best: &mut [Option<Hit>; 4],
    ) {
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
    pub(super) fn any_hit(&self, ray: &LocalRay, tmin: f32, tmax: f32) -> Option<f32> {
        with_axes!(ray.sheared.k, |KX, KY, KZ| self.any_hit_axes::<KX, KY, KZ>(ray, tmin, tmax))
    }

    /// `any_hit` with the ray's axes as constants (`Tri::intersect_axes`).
    #[inline(always)]
    pub(super) fn any_hit_axes<const KX: usize, const KY: usize, const KZ: usize>(
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
