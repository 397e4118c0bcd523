//! Bringing the BVHs up to a changed world: new content, moved objects, deformed meshes.

use super::*;

impl Accel {
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
            let backdrop = world.backdrops.iter().find(|b| b.object == i).copied();
            let enclosure = world.enclosures.iter().find(|e| e.object == i);
            instances.push(Instance {
                blas,
                object: i as u32,
                first_triangle: o.first_triangle,
                to_base: o.placement.map(|p| p.to_base),
                backdrop: backdrop.filter(|b| b.winding.is_none()),
                cull: {
                    // Rays from the side away from the subject pass: an enclosure's outside, a
                    // sweep's back. A mirroring placement turns the winding over in base space.
                    let away = enclosure.map(|e| e.outward).or(backdrop.and_then(|b| b.winding).map(|f| !f));
                    let mirrored = o.placement.is_some_and(|p| p.to_base.matrix3.determinant() < 0.0);
                    away.map_or(0.0, |away| if away != mirrored { 1.0 } else { -1.0 })
                },
                shadowless: enclosure.is_some(),
            });
            boxes.push(aabb);
        }
        // The baked objects, in ascending triangle ids, while they fit under the cap.
        let mut grouped = Vec::new();
        let mut total = 0;
        // (A backdrop or an enclosure keeps its own instance: rays behind it skip it, rays
        // entering it pass its faces.)
        let mut by_id: Vec<usize> = (0..instances.len())
            .filter(|&k| {
                let inst = &instances[k];
                inst.to_base.is_none() && inst.backdrop.is_none() && inst.cull == 0.0 && !inst.shadowless
            })
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
                    shadowless: false,
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
}
