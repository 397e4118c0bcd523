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
    for (n, spread) in [(1usize, 1.0), (2, 1.0), (8, 1.0), (17, 1.0), (18, 0.0), (400, 1.0), (5000, 1.0), (5000, 0.01)]
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

/// The pair layout's traversal reaches the same leaves in the same order as obvhs's
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
            let t_of =
                |slot: usize| sheared[slot].intersect(&ray.sheared, 0.0, f32::INFINITY).map_or(f32::INFINITY, |h| h.0);
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
        s.objects.push(Object { name: "o".into(), mesh, transform: DMat4::from_translation(DVec3::new(0.0, y, 0.0)) });
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
    let rays = [(at(0.0, -3.0, 0.0), up), (at(4.0, 3.0, 0.0), -up), (at(0.1, -3.0, 0.1), up), (at(4.1, -3.0, 0.1), up)];
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
        let room = DMat4::from_translation(DVec3::new(0.0, 2.5, 0.0)) * DMat4::from_scale(DVec3::new(mirror, 1.0, 1.0));
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
