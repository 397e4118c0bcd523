//! The two-level BVH (`Accel`: a BVH per geometry, one over the placed objects) against one
//! BVH over the same triangles flattened into render space, and its updates (moved objects,
//! refitted or rebuilt meshes, a changed scene) against a BVH built from scratch.

use cubist::accel::{Accel, Hit};
use cubist::scene::{Mesh, Object, Scene, World, compute_normals};
use cubist::util::rng::{splitmix64, unit_f64};
use glam::{DMat4, DQuat, DVec3, Vec3};

/// A bumpy UV sphere of `n` x `2n` quads, seeded bumps (never two equal triangles).
fn blob(n: u32, seed: u64) -> Mesh {
    let mut positions = Vec::new();
    for j in 0..=n {
        for i in 0..2 * n {
            let (th, ph) = (std::f32::consts::PI * j as f32 / n as f32, std::f32::consts::PI * i as f32 / n as f32);
            let h = unit_f64(splitmix64(seed ^ (j as u64 * 7919 + i as u64))) as f32;
            let r = 1.0 + 0.15 * h;
            positions.push(Vec3::new(r * th.sin() * ph.cos(), r * th.cos(), r * th.sin() * ph.sin()));
        }
    }
    let mut triangles = Vec::new();
    let v = |i: u32, j: u32| j * 2 * n + i % (2 * n);
    for j in 0..n {
        for i in 0..2 * n {
            if j > 0 {
                triangles.push([v(i, j), v(i + 1, j), v(i + 1, j + 1)]);
            }
            if j + 1 < n {
                triangles.push([v(i, j), v(i + 1, j + 1), v(i, j + 1)]);
            }
        }
    }
    Mesh {
        name: format!("blob {seed}"),
        normals: compute_normals(&positions, &triangles),
        positions,
        uvs: None,
        colors: None,
        triangles,
        material: None,
    }
}

fn place(mesh: usize, t: DMat4) -> Object {
    Object { name: format!("m{mesh}"), mesh, transform: t }
}

/// Two meshes; the first placed by five objects (translated, rotated, scaled unevenly,
/// mirrored), the second once.
fn instanced_scene() -> Scene {
    let r = |a: f64, b: f64| DQuat::from_euler(glam::EulerRot::XYZ, a, b, 0.3 * a);
    let srt = |s: DVec3, q: DQuat, t: DVec3| DMat4::from_scale_rotation_translation(s, q, t);
    Scene {
        meshes: vec![blob(24, 1), blob(16, 2)],
        objects: vec![
            place(0, DMat4::from_translation(DVec3::new(-3.0, 0.0, 0.0))),
            place(0, srt(DVec3::splat(0.5), r(0.7, 0.2), DVec3::new(0.0, 1.5, 0.5))),
            place(1, srt(DVec3::ONE, r(0.1, 0.9), DVec3::new(2.5, 0.0, -0.5))),
            place(0, srt(DVec3::new(1.0, 2.0, 0.4), r(-0.4, 1.1), DVec3::new(0.5, -1.5, 1.0))),
            place(0, srt(DVec3::new(-1.0, 1.0, 1.0), r(2.0, 0.0), DVec3::new(-1.0, 2.0, -2.0))),
            place(0, DMat4::from_translation(DVec3::new(1.2, 0.3, 2.2))),
        ],
        ..Scene::default()
    }
}

/// Every placed triangle of `world` as one flattened list (ids kept).
fn flattened(world: &World) -> World {
    let tris: Vec<[Vec3; 3]> = (0..world.triangle_count() as u32).map(|t| world.triangle(t)).collect();
    World::from_triangles(&tris)
}

/// Rays from a sphere of radius 3 around the scene towards random points near its centre.
fn rays(n: usize, seed: u64) -> Vec<(Vec3, Vec3)> {
    let f = |k: u64| unit_f64(splitmix64(seed ^ k)) as f32;
    (0..n as u64)
        .map(|i| {
            let o = Vec3::new(f(6 * i) - 0.5, f(6 * i + 1) - 0.5, f(6 * i + 2) - 0.5).normalize() * 3.0;
            let target = Vec3::new(f(6 * i + 3) - 0.5, f(6 * i + 4) - 0.5, f(6 * i + 5) - 0.5) * 1.6;
            (o, (target - o).normalize())
        })
        .collect()
}

fn closest(a: &Accel, (o, d): (Vec3, Vec3)) -> Option<Hit> {
    a.closest(o, d, 0.0, f32::INFINITY)
}

/// Without instancing, every object's geometry is baked for it: the two levels answer bit for
/// bit as one BVH over the flattened triangles.
#[test]
fn without_instancing_hits_are_those_of_the_flat_bvh_bit_for_bit() {
    let scene = Scene {
        meshes: vec![blob(20, 3), blob(12, 4), blob(16, 5)],
        objects: vec![
            place(0, DMat4::from_translation(DVec3::new(-1.0, 0.0, 0.0))),
            place(1, DMat4::from_scale(DVec3::splat(0.7))),
            place(2, DMat4::from_rotation_y(0.8) * DMat4::from_translation(DVec3::new(1.0, 0.5, 0.0))),
        ],
        ..Scene::default()
    };
    let world = World::new(&scene);
    assert!(world.objects.iter().all(|o| o.placement.is_none()));
    let (two, flat) = (Accel::new(&world), Accel::new(&flattened(&world)));
    assert_eq!(two.grouped_objects(), 3, "small baked objects are traced as one BLAS");
    assert_same_as_flat(&world, &two, &flat);
}

/// `two` answers bit for bit as `flat` (the same triangles in one BVH), with each hit's object.
fn assert_same_as_flat(world: &World, two: &Accel, flat: &Accel) {
    let mut hits = 0;
    for r in rays(20_000, 11) {
        let (a, b) = (closest(two, r), closest(flat, r));
        assert_eq!(a.map(|h| (h.tri, h.t, h.u, h.v)), b.map(|h| (h.tri, h.t, h.u, h.v)), "{r:?}");
        if let Some(h) = a {
            hits += 1;
            assert_eq!(h.object, world.object_of(h.tri));
        }
        for tmax in [0.5f32, 2.0, 4.0] {
            assert_eq!(two.occluded(r.0, r.1, 0.0, tmax), flat.occluded(r.0, r.1, 0.0, tmax));
        }
    }
    assert!(hits > 5_000, "{hits} hits: the rays must mostly hit");
}

/// Instances trace a ray carried into their base space by an f32 map: the same triangle as
/// the flattened scene except for rays within rounding of an edge, at the same distance to
/// rounding.
#[test]
fn instances_hit_what_the_flattened_scene_hits() {
    let world = World::new(&instanced_scene());
    assert_eq!(world.geometries.len(), 2);
    assert!(world.stored_triangle_count() * 2 < world.triangle_count());
    let (two, flat) = (Accel::new(&world), Accel::new(&flattened(&world)));
    assert_eq!(two.stored_triangles(), world.stored_triangle_count());
    let (mut hits, mut differ) = (0, 0);
    let all = rays(20_000, 12);
    for &r in &all {
        match (closest(&two, r), closest(&flat, r)) {
            (None, None) => {}
            (Some(a), Some(b)) => {
                hits += 1;
                assert!((a.t - b.t).abs() <= 1e-5 * b.t, "{r:?}: {a:?} {b:?}");
                assert_eq!(a.object, world.object_of(a.tri));
                if a.tri != b.tri {
                    differ += 1;
                    // Only where the flat hit is on an edge of its triangle (to rounding).
                    let edge = b.u.min(b.v).min(1.0 - b.u - b.v);
                    assert!(edge < 1e-4, "{r:?}: {a:?} {b:?}");
                }
            }
            (a, b) => {
                differ += 1;
                // A hit on one side only: grazing a silhouette.
                let h = a.or(b).unwrap();
                let edge = h.u.min(h.v).min(1.0 - h.u - h.v);
                assert!(edge < 1e-4, "{r:?}: {a:?} {b:?}");
            }
        }
        assert!(two.occluded(r.0, r.1, 0.0, 6.0) == flat.occluded(r.0, r.1, 0.0, 6.0) || differ > 0);
    }
    assert!(hits > 5_000, "{hits}");
    assert!(differ * 1000 <= all.len(), "{differ} of {} rays differ", all.len());
}

/// Moving objects: `update_instances` (no BLAS touched) answers as a BVH built from scratch.
#[test]
fn moved_objects_need_only_the_top_level() {
    let scene = instanced_scene();
    let mut world = World::new(&scene);
    let mut accel = Accel::new(&world);
    let moves = [
        (0, DMat4::from_translation(DVec3::new(-2.0, 0.5, 0.0))),
        (2, DMat4::from_rotation_x(0.5)),
        // Onto the first instance's base: identity placement again.
        (3, scene.objects[0].transform),
    ];
    assert!(world.set_transforms(&scene, &moves).unwrap().is_empty());
    let stored = accel.stored_triangles();
    accel.update_instances(&world);
    assert_eq!(accel.stored_triangles(), stored);
    let fresh = Accel::new(&world);
    for r in rays(5_000, 13) {
        assert_eq!(closest(&accel, r), closest(&fresh, r), "{r:?}");
    }
}

/// A changed scene: `update` rebuilds only geometries whose content changed.
#[test]
fn update_reuses_unchanged_meshes() {
    let mut scene = instanced_scene();
    let world = World::new(&scene);
    let mut accel = Accel::new(&world);
    scene.meshes[1] = blob(18, 9);
    scene.objects[1].transform = DMat4::from_translation(DVec3::new(0.0, -2.0, 0.0));
    let changed = World::in_space(&scene, world.to_render);
    let stats = accel.update(&changed);
    assert_eq!((stats.built, stats.reused), (1, 1));
    let fresh = Accel::new(&changed);
    for r in rays(5_000, 16) {
        assert_eq!(closest(&accel, r), closest(&fresh, r), "{r:?}");
    }
}

/// Thousands of coincident copies of an instanced mesh are traced as one (PLOC turns
/// quadratic on equal boxes, and each would be visited).
#[test]
fn coincident_instances_are_built_once() {
    let t = DMat4::from_translation(DVec3::new(1.0, 0.0, 0.0));
    let mut objects = vec![place(0, DMat4::IDENTITY)];
    objects.extend((0..20_000).map(|_| place(0, t)));
    let scene = Scene { meshes: vec![blob(6, 1)], objects, ..Scene::default() };
    let world = World::new(&scene);
    let accel = Accel::new(&world);
    assert_eq!(accel.instance_count(), 2, "one instance per distinct placement");
    let hit = closest(&accel, (Vec3::new(0.0, 0.0, 5.0), Vec3::NEG_Z)).expect("a hit");
    assert!(hit.object <= 1, "the first copy wins the tie: {hit:?}");
}

/// The group of small baked objects (one BLAS over them all): an object above its cap keeps
/// its own BLAS, one that moves leaves the group; the hits stay those of the flat BVH, with
/// their objects.
#[test]
fn the_group_of_baked_objects_answers_as_the_flat_bvh() {
    let big = 190; // 190 x 380 quads: about 144K triangles, over the group's cap.
    let scene = Scene {
        meshes: vec![blob(16, 6), blob(big, 7), blob(12, 8), blob(10, 9)],
        objects: vec![
            place(0, DMat4::from_translation(DVec3::new(-1.2, 0.0, 0.0))),
            place(1, DMat4::from_scale(DVec3::splat(0.6))),
            place(2, DMat4::from_translation(DVec3::new(1.0, 0.6, 0.3))),
            place(3, DMat4::from_translation(DVec3::new(0.3, -1.0, 0.8))),
        ],
        ..Scene::default()
    };
    let mut world = World::new(&scene);
    let mut accel = Accel::new(&world);
    assert_eq!(accel.grouped_objects(), 3, "all but the big mesh");
    assert_eq!(accel.instance_count(), 4);
    assert_same_as_flat(&world, &accel, &Accel::new(&flattened(&world)));
    // Object 2 moves: it is placed (no longer baked) and leaves the group.
    let moves = [(2, DMat4::from_translation(DVec3::new(0.8, 0.9, -0.2)))];
    assert!(world.set_transforms(&scene, &moves).unwrap().is_empty());
    assert!(world.objects[2].placement.is_some());
    accel.update_instances(&world);
    assert_eq!(accel.grouped_objects(), 2);
    assert_eq!(accel.instance_count(), 4);
    let fresh = Accel::new(&world);
    let mut on_moved = 0;
    for r in rays(5_000, 17) {
        let (a, b) = (closest(&accel, r), closest(&fresh, r));
        assert_eq!(a, b, "{r:?}");
        if let Some(h) = a {
            assert_eq!(h.object, world.object_of(h.tri));
            on_moved += (h.object == 2) as u32;
        }
    }
    assert!(on_moved > 100, "{on_moved} hits on the moved object");
}

/// `closest4` (up to four rays as one packet) answers as `closest` for each ray, bit for bit:
/// on instanced, baked and grouped objects; for neighbouring rays (a packet), rays in all
/// directions (lanes of different dominant axes), 1 to 4 lanes, and lanes with invalid rays.
#[test]
fn packets_answer_as_single_rays() {
    let bits = |h: Option<Hit>| h.map(|h| (h.tri, h.object, h.t.to_bits(), h.u.to_bits(), h.v.to_bits()));
    let grouped = Scene {
        meshes: vec![blob(16, 6), blob(12, 8), blob(10, 9)],
        objects: vec![
            place(0, DMat4::from_translation(DVec3::new(-1.2, 0.0, 0.0))),
            place(1, DMat4::from_translation(DVec3::new(1.0, 0.6, 0.3))),
            place(2, DMat4::from_translation(DVec3::new(0.3, -1.0, 0.8))),
        ],
        ..Scene::default()
    };
    let f = |k: u64| unit_f64(splitmix64(k)) as f32;
    for (name, scene) in [("instanced", instanced_scene()), ("grouped", grouped)] {
        let world = World::new(&scene);
        let accel = Accel::new(&world);
        let (mut hits, mut packets) = (0, 0);
        for (p, r) in rays(4_000, 21).into_iter().enumerate() {
            let k = p as u64 * 16;
            let lanes = 1 + p % 4;
            let packet: Vec<(Vec3, Vec3)> = (0..lanes as u64)
                .map(|l| match p % 5 {
                    // Unrelated rays: other dominant axes.
                    0 => rays(1, k + l)[0],
                    // An invalid lane.
                    1 if l == 1 => (r.0, Vec3::ZERO),
                    // Neighbours: the same origin, directions a pixel or so apart.
                    _ => (r.0, (r.1 + 0.004 * Vec3::new(f(k + l) - 0.5, f(k + l + 7) - 0.5, 0.0)).normalize()),
                })
                .collect();
            let got = accel.closest4(&packet, 0.0, f32::INFINITY);
            for (l, &ray) in packet.iter().enumerate() {
                let want = closest(&accel, ray);
                assert_eq!(bits(got[l]), bits(want), "{name}: packet {p}, lane {l}: {ray:?}");
                hits += want.is_some() as u32;
            }
            assert!(got[lanes..].iter().all(Option::is_none));
            packets += 1;
        }
        assert!(hits > 3_000 && packets == 4_000, "{name}: {hits} hits");
        // A bounded segment (tmax) and a tmin past the first surface.
        for r in rays(500, 22) {
            let packet = [r, (r.0, (r.1 + Vec3::splat(0.002)).normalize())];
            for (tmin, tmax) in [(0.0, 2.5), (2.6, f32::INFINITY)] {
                let got = accel.closest4(&packet, tmin, tmax);
                for (l, &(o, d)) in packet.iter().enumerate() {
                    assert_eq!(bits(got[l]), bits(accel.closest(o, d, tmin, tmax)), "{name}: {tmin} {tmax}");
                }
            }
        }
    }
}
