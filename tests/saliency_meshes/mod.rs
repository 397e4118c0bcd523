//! Hard meshes for mesh saliency, generated at any size: the tessellations users bring (Issue
//! 16), not only the uniform ones the shared models have. Used by `tests/saliency.rs` (small
//! sizes) and `benches/saliency.rs` (35K to 2M vertices), which includes this file by path.
//!
//! - `Uniform`: an equal-angle cube sphere with bumps and a ridge, near-constant density.
//! - `Adaptive`: the same surface remeshed as adaptive remeshers do, denser (x10 by area) where
//!   the features are: smooth density changes.
//! - `Scanned`: a tall figure-like body with scanner noise (constant in absolute size, so dense
//!   parts are noisy), a few holes, and dense patches where the scanner lingered (x49 density
//!   by area, abrupt edges): a few percent of the area holds about half the vertices.
//! - `Cad`: a turned shaft as CAD exporters tessellate it: every ring of 1K-8K segments, long
//!   thin triangles (aspect up to ~500:1) between rings, caps as fans around one centre vertex,
//!   fillets and a knurled band as dense stacks of rings. Vertices lie on circles, not on an
//!   area.
//!
//! Every mesh is deterministic (fixed seeds) and, for the cube spheres, conforming (shared
//! lattice points give bit-identical positions).

#![allow(dead_code)]

use std::collections::HashMap;
use std::f64::consts::{FRAC_PI_4, PI};

use cubist::scene::{Mesh, compute_normals};
use glam::{DVec3, Vec3};

/// The tessellation classes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Class {
    Uniform,
    Adaptive,
    Scanned,
    Cad,
}

impl Class {
    pub const ALL: [Class; 4] = [Class::Uniform, Class::Adaptive, Class::Scanned, Class::Cad];

    pub fn name(self) -> &'static str {
        match self {
            Class::Uniform => "uniform",
            Class::Adaptive => "adaptive",
            Class::Scanned => "scanned",
            Class::Cad => "cad",
        }
    }
}

/// A mesh of `class` with about `vertices` vertices (within a few percent).
pub fn generate(class: Class, vertices: usize) -> Mesh {
    let name = format!("{} {}", class.name(), human(vertices));
    match class {
        Class::Uniform => blob(&name, vertices, &[], 0.0, &[], DVec3::ONE),
        Class::Adaptive => {
            let warps: Vec<Warp> =
                BUMPS.iter().map(|b| Warp::Smooth { centre: b.0.normalize(), radius: 0.75, d: 0.32 }).collect();
            blob(&name, vertices, &warps, 0.0, &[], DVec3::ONE)
        }
        Class::Scanned => {
            // Three patches on a great circle, 7x denser (49x by area): 5% of the area holds
            // about half of the vertices.
            let warps = [(0.0, 1.2), (2.1, 1.0), (4.2, 0.9)].map(|(a, radius): (f64, f64)| Warp::Patch {
                centre: DVec3::new(a.cos(), 0.3, a.sin()).normalize(),
                radius,
                k: 7.0,
            });
            let holes = [
                (DVec3::new(0.0, -1.0, 0.05).normalize(), 0.12),
                (DVec3::new(-0.9, 0.2, -0.4).normalize(), 0.05),
                (DVec3::new(0.7, 0.5, -0.5).normalize(), 0.03),
            ];
            // A tall body (height 2, width 0.8, depth 0.6), scanner noise of 0.1% of the height.
            blob(&name, vertices, &warps, 0.002, &holes, DVec3::new(0.4, 1.0, 0.3))
        }
        Class::Cad => shaft(&name, vertices),
    }
}

/// "35K", "2M": for names.
pub fn human(n: usize) -> String {
    if n >= 1_000_000 { format!("{}M", (n as f64 / 1e6).round()) } else { format!("{}K", (n as f64 / 1e3).round()) }
}

fn hash3(seed: u64, k: [u32; 3]) -> f64 {
    let mut h = cubist::util::rng::splitmix64(seed);
    for c in k {
        h = cubist::util::rng::splitmix64(h ^ c as u64);
    }
    cubist::util::rng::unit_f64(h)
}

/// Where an adaptive remesher or a scanner put more vertices, as a bijection of the unit
/// sphere moving points towards `centre` within `radius` (radians).
enum Warp {
    /// Adaptive: angle t -> t (d + (1 - d) t / radius), a smooth rise of the linear density to
    /// 1/d at the centre (area density 1/d^2).
    Smooth { centre: DVec3, radius: f64, d: f64 },
    /// A scanned patch: the input cap of angle `k` radius * 3/4 is squeezed into radius / 8,
    /// a plateau of area density k^2 with an abrupt edge, the rest of the cap thinned out.
    Patch { centre: DVec3, radius: f64, k: f64 },
}

impl Warp {
    fn apply(&self, s: DVec3) -> DVec3 {
        let (centre, radius) = match *self {
            Warp::Smooth { centre, radius, .. } | Warp::Patch { centre, radius, .. } => (centre, radius),
        };
        let t = s.dot(centre).clamp(-1.0, 1.0).acos();
        if t >= radius || t < 1e-12 {
            return s;
        }
        let t2 = match *self {
            Warp::Smooth { d, .. } => t * (d + (1.0 - d) * t / radius),
            Warp::Patch { k, .. } => {
                let core = radius / 8.0;
                if t < k * core { t / k } else { core + (t - k * core) * (radius - core) / (radius - k * core) }
            }
        };
        let side = (s - centre * t.cos()).normalize();
        centre * t2.cos() + side * t2.sin()
    }
}

/// Bumps and dents (direction, angular width, height): detail at several scales.
const BUMPS: [(DVec3, f64, f64); 5] = [
    (DVec3::new(0.3, 0.8, 0.5), 0.15, 0.2),
    (DVec3::new(-0.7, 0.1, 0.7), 0.3, -0.1),
    (DVec3::new(0.0, 0.0, 1.0), 0.06, 0.06),
    (DVec3::new(0.6, -0.6, -0.5), 0.1, 0.12),
    (DVec3::new(-0.4, -0.8, -0.2), 0.04, 0.03),
];

fn radius_at(s: DVec3) -> f64 {
    let mut r = 1.0;
    for (c, w, h) in BUMPS {
        let d = (s - c.normalize()).length();
        r += h * (-d * d / (2.0 * w * w)).exp();
    }
    // A ridge running round the body and a gentle wave.
    r += 0.04 * (-(s.y - 0.2 * s.x).powi(2) / (2.0 * 0.03f64.powi(2))).exp();
    r + 0.02 * (5.0 * s.x).sin() * (4.0 * s.z).cos()
}

/// A cube sphere of about `vertices` vertices displaced by `radius_at`, warped by `warps`,
/// with radial noise of amplitude `noise`, triangles near `holes` (direction, angle) removed,
/// then scaled by `scale`.
fn blob(name: &str, vertices: usize, warps: &[Warp], noise: f64, holes: &[(DVec3, f64)], scale: DVec3) -> Mesh {
    let n = (((vertices.max(8) - 2) as f64 / 6.0).sqrt().round() as u32).max(1);
    let mut index: HashMap<[u32; 3], u32> = HashMap::with_capacity(6 * (n as usize + 1).pow(2));
    let mut positions: Vec<Vec3> = Vec::with_capacity(6 * (n as usize + 1).pow(2));
    let mut dirs: Vec<DVec3> = Vec::with_capacity(positions.capacity());
    let mut vertex = |k: [u32; 3], positions: &mut Vec<Vec3>, dirs: &mut Vec<DVec3>| -> u32 {
        *index.entry(k).or_insert_with(|| {
            let q = DVec3::new(k[0] as f64, k[1] as f64, k[2] as f64) * (2.0 / n as f64) - 1.0;
            let q = DVec3::new((FRAC_PI_4 * q.x).tan(), (FRAC_PI_4 * q.y).tan(), (FRAC_PI_4 * q.z).tan());
            let mut s = q.normalize();
            for w in warps {
                s = w.apply(s);
            }
            let r = radius_at(s) + noise * (hash3(7, k) - 0.5) * 2.0;
            positions.push((s * r * scale).as_vec3());
            dirs.push(s);
            (positions.len() - 1) as u32
        })
    };
    let mut triangles = Vec::with_capacity(12 * (n as usize).pow(2));
    for axis in 0..3 {
        for side in [0, n] {
            let at = |a: u32, b: u32| {
                let mut k = [0u32; 3];
                k[axis] = side;
                k[(axis + 1) % 3] = a;
                k[(axis + 2) % 3] = b;
                k
            };
            // (axis+1, axis+2) is right-handed about +axis: counter-clockwise seen from outside
            // on the far side, clockwise on the near one.
            let outward = side == n;
            for b in 0..n {
                for a in 0..n {
                    let q = [at(a, b), at(a + 1, b), at(a + 1, b + 1), at(a, b + 1)]
                        .map(|k| vertex(k, &mut positions, &mut dirs));
                    // Alternate diagonals, as quad-dominant exporters do.
                    let (t1, t2) = if (a + b) % 2 == 0 {
                        ([q[0], q[1], q[2]], [q[0], q[2], q[3]])
                    } else {
                        ([q[0], q[1], q[3]], [q[1], q[2], q[3]])
                    };
                    for t in [t1, t2] {
                        triangles.push(if outward { t } else { [t[0], t[2], t[1]] });
                    }
                }
            }
        }
    }
    if !holes.is_empty() {
        triangles.retain(|t| {
            let c = (dirs[t[0] as usize] + dirs[t[1] as usize] + dirs[t[2] as usize]).normalize();
            holes.iter().all(|(h, angle)| c.dot(*h) < angle.cos())
        });
    }
    finish(name, positions, triangles)
}

/// Drops unused vertices (holes) and computes normals.
fn finish(name: &str, positions: Vec<Vec3>, triangles: Vec<[u32; 3]>) -> Mesh {
    let mut map = vec![u32::MAX; positions.len()];
    let mut kept = Vec::with_capacity(positions.len());
    let mut tris = triangles;
    for t in &mut tris {
        for i in t.iter_mut() {
            if map[*i as usize] == u32::MAX {
                map[*i as usize] = kept.len() as u32;
                kept.push(positions[*i as usize]);
            }
            *i = map[*i as usize];
        }
    }
    let normals = compute_normals(&kept, &tris);
    Mesh { name: name.into(), positions: kept, normals, uvs: None, colors: None, triangles: tris, material: None }
}

/// A turned shaft, length 4 along z, tessellated as CAD exporters do (see the module doc).
fn shaft(name: &str, vertices: usize) -> Mesh {
    // Segments per ring: about 8 sqrt(n), a power of two, so rings ~ sqrt(n) / 8.
    let segments = (8.0 * (vertices as f64).sqrt()).log2().round().exp2().clamp(64.0, 16384.0) as u32;
    let rings_wanted = ((vertices as f64 - 2.0) / segments as f64).round().max(12.0) as usize;
    // The profile: (z, r) key rings joined by long straight sections; dense parts are added
    // between them: two fillets (quarter circles) and a knurled band.
    let key = 9usize;
    let dense = rings_wanted.saturating_sub(key).max(3);
    let (f1, f2) = (dense / 4, dense / 4);
    let knurl = dense - f1 - f2;
    let mut profile: Vec<(f64, f64)> = vec![(-2.0, 0.6), (-1.0, 0.6)];
    // Fillet from radius 0.6 at z = -1 up to 0.9 at z = -0.7 (centre (-0.7, 0.6), radius 0.3).
    for i in 1..=f1 {
        let a = PI / 2.0 * i as f64 / (f1 + 1) as f64;
        profile.push((-0.7 - 0.3 * a.cos(), 0.6 + 0.3 * a.sin()));
    }
    profile.extend([(-0.7, 0.9), (-0.2, 0.9), (-0.2, 0.8), (0.0, 0.8), (0.0, 0.9)]);
    // Knurled band: ripples of amplitude 0.01 over z in [0.3, 0.9].
    for i in 0..knurl {
        let z = 0.3 + 0.6 * i as f64 / (knurl.max(2) - 1) as f64;
        profile.push((z, 0.9 + 0.01 * (z * 80.0).sin()));
    }
    profile.push((1.2, 0.9));
    // Fillet down from 0.9 at z = 1.2 to 0.7 at z = 1.4 (centre (1.4, 0.9), radius 0.2).
    for i in 1..=f2 {
        let a = PI / 2.0 * i as f64 / (f2 + 1) as f64;
        profile.push((1.2 + 0.2 * a.sin(), 0.9 - 0.2 * (1.0 - a.cos())));
    }
    profile.extend([(1.4, 0.7), (2.0, 0.7)]);
    let m = segments as usize;
    let mut positions = Vec::with_capacity(profile.len() * m + 2);
    for &(z, r) in &profile {
        for s in 0..m {
            let a = 2.0 * PI * s as f64 / m as f64;
            positions.push(Vec3::new((r * a.cos()) as f32, (r * a.sin()) as f32, z as f32));
        }
    }
    let mut triangles = Vec::with_capacity(2 * profile.len() * m);
    let id = |ring: usize, s: usize| (ring * m + s % m) as u32;
    for ring in 0..profile.len() - 1 {
        for s in 0..m {
            let (a, b, c, d) = (id(ring, s), id(ring, s + 1), id(ring + 1, s + 1), id(ring + 1, s));
            triangles.extend([[a, b, c], [a, c, d]]);
        }
    }
    // Caps: fans around one centre vertex each.
    let (first, last) = (profile[0], profile[profile.len() - 1]);
    positions.push(Vec3::new(0.0, 0.0, first.0 as f32));
    let c0 = (positions.len() - 1) as u32;
    positions.push(Vec3::new(0.0, 0.0, last.0 as f32));
    let c1 = (positions.len() - 1) as u32;
    let lr = profile.len() - 1;
    for s in 0..m {
        triangles.push([c0, id(0, s + 1), id(0, s)]);
        triangles.push([c1, id(lr, s), id(lr, s + 1)]);
    }
    finish(name, positions, triangles)
}

/// The mesh's own size measures: (vertices, largest valence, longest edge / shortest altitude
/// over its triangles, the fraction of vertices in the densest 5% of the surface area).
pub fn describe(m: &Mesh) -> String {
    let mut valence = vec![0u32; m.positions.len()];
    let mut worst = 0.0f64;
    let mut areas: Vec<(f64, f64)> = vec![(0.0, 0.0); m.positions.len()];
    for t in &m.triangles {
        let [a, b, c] = t.map(|i| m.positions[i as usize].as_dvec3());
        let area = 0.5 * (b - a).cross(c - a).length();
        let longest = (b - a).length().max((c - b).length()).max((a - c).length());
        if area > 0.0 {
            worst = worst.max(longest * longest / (2.0 * area));
        }
        for &i in t {
            valence[i as usize] += 1;
            areas[i as usize].0 += area / 3.0;
        }
    }
    let total: f64 = areas.iter().map(|a| a.0).sum();
    let mut per: Vec<f64> = areas.iter().map(|a| a.0).filter(|a| *a > 0.0).collect();
    per.sort_by(f64::total_cmp);
    let (mut acc, mut count) = (0.0, 0usize);
    for a in &per {
        if acc + a > 0.05 * total {
            break;
        }
        acc += a;
        count += 1;
    }
    format!(
        "{} vertices, valence <= {}, aspect <= {:.0}, densest 5% of the area holds {:.0}% of the vertices",
        m.positions.len(),
        valence.iter().max().unwrap_or(&0),
        worst,
        100.0 * count as f64 / per.len().max(1) as f64
    )
}
