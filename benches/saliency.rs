//! Mesh saliency: cost and error against exact, per mesh class and size (Issue 16, item 1).
//!
//! Meshes: the generated classes of `tests/saliency_meshes` (uniform, adaptive, scanned-like,
//! CAD-like) at 35K, 62K, 134K, 300K and 2M vertices; the shared models (../shared/models)
//! and the largest mesh of some glTF samples (../shared/gltf-samples); bunny_full refined by
//! PN triangles to 139K, 313K and 2.2M vertices. For each: the exact sums' work counted on
//! the mesh (what `auto` decides by) beside the estimate `auto` used before (vertices and
//! area, assuming uniform density); the method `auto` picks; wall and CPU time of the whole
//! per-mesh computation (weld, curvature, means, levels; median of 3 runs on a 2-thread
//! pool); the error of the final [0, 1] saliency against the exact method (max and mean over
//! the vertices). Exact results are kept in target/saliency-bench (by content) for later
//! runs. Where the exact sums would take too long (more than `EXACT_LIMIT` candidate pairs,
//! minutes), the error is estimated on 1000 sampled vertices: their exact Gaussian means put in
//! place of the approximate ones before the (exact) rest of the definition; this measures the
//! means' error, not that of the normalisations (validated against the full error where both
//! exist: the `sampled` columns).
//!
//! `cargo bench --bench saliency` (everything, with a parameter sweep; exact sums up to
//! `EXACT_LIMIT`, some minutes the first time), `-- --quick` (no sweep; exact sums only up to
//! `QUICK_EXACT_LIMIT` or from an earlier run's store; otherwise sampled). Prints markdown.

#[path = "common/mod.rs"]
mod common;
#[path = "../tests/saliency_meshes/mod.rs"]
mod saliency_meshes;

use std::path::Path;
use std::time::Instant;

use cubist::saliency::{Analysed, SaliencyMethod, analyse, approx, cache, content_key, levels, neighbourhood::Grid};
use cubist::scene::{Mesh, Scene};
use saliency_meshes::Class;

/// Exact sums are computed (once, then read from the store) up to this many candidate pairs.
const EXACT_LIMIT: u64 = 2_000_000_000;
const QUICK_EXACT_LIMIT: u64 = 300_000_000;
/// Vertices sampled for the error estimate.
const SAMPLES: usize = 1000;

/// Refines every triangle into k^2 along the PN-triangle cubic patch (Vlachos et al. 2001)
/// built from the vertex normals, sharing edge points between neighbours: a smooth,
/// crack-free mesh of V + (k-1) E + (k-1)(k-2)/2 F vertices.
fn pn_refine(m: &Mesh, k: u32) -> Mesh {
    let p = &m.positions;
    let nrm = &m.normals;
    let ctrl = |a: usize, b: usize| (2.0 * p[a] + p[b] - (p[b] - p[a]).dot(nrm[a]) * nrm[a]) / 3.0;
    let mut positions = p.clone();
    let mut edges = std::collections::HashMap::new();
    for t in &m.triangles {
        for e in 0..3 {
            let (a, b) = (t[e].min(t[(e + 1) % 3]) as usize, t[e].max(t[(e + 1) % 3]) as usize);
            edges.entry((a, b)).or_insert_with(|| {
                let (c0, c1) = (ctrl(a, b), ctrl(b, a));
                let first = positions.len() as u32;
                for i in 1..k {
                    let s = i as f32 / k as f32;
                    let r = 1.0 - s;
                    positions.push(p[a] * r * r * r + 3.0 * c0 * r * r * s + 3.0 * c1 * r * s * s + p[b] * s * s * s);
                }
                first
            });
        }
    }
    // The i-th interior point (1..k-1) from a towards b.
    let edge_point = |a: u32, b: u32, i: u32| -> u32 {
        if a < b { edges[&(a as usize, b as usize)] + i - 1 } else { edges[&(b as usize, a as usize)] + (k - i) - 1 }
    };
    let mut triangles = Vec::with_capacity(m.triangles.len() * (k * k) as usize);
    let mut ids = vec![0u32; ((k + 1) * (k + 1)) as usize];
    for t in &m.triangles {
        let [i1, i2, i3] = t.map(|x| x as usize);
        let (p1, p2, p3) = (p[i1], p[i2], p[i3]);
        let (b210, b120, b021, b012, b102, b201) =
            (ctrl(i1, i2), ctrl(i2, i1), ctrl(i2, i3), ctrl(i3, i2), ctrl(i3, i1), ctrl(i1, i3));
        let e = (b210 + b120 + b021 + b012 + b102 + b201) / 6.0;
        let b111 = e + (e - (p1 + p2 + p3) / 3.0) / 2.0;
        let at = |a: u32, b: u32| ((b * (k + 1)) + a) as usize;
        for b in 0..=k {
            for a in 0..=k - b {
                let id = if a == 0 && b == 0 {
                    t[0]
                } else if a == k {
                    t[1]
                } else if b == k {
                    t[2]
                } else if b == 0 {
                    edge_point(t[0], t[1], a)
                } else if a + b == k {
                    edge_point(t[1], t[2], b)
                } else if a == 0 {
                    edge_point(t[0], t[2], b)
                } else {
                    let (u, v) = (a as f32 / k as f32, b as f32 / k as f32);
                    let w = 1.0 - u - v;
                    positions.push(
                        p1 * w * w * w
                            + p2 * u * u * u
                            + p3 * v * v * v
                            + 3.0 * (b210 * w * w * u + b120 * w * u * u + b201 * w * w * v)
                            + 3.0 * (b021 * u * u * v + b102 * w * v * v + b012 * u * v * v)
                            + 6.0 * b111 * w * u * v,
                    );
                    positions.len() as u32 - 1
                };
                ids[at(a, b)] = id;
            }
        }
        for b in 0..k {
            for a in 0..k - b {
                triangles.push([ids[at(a, b)], ids[at(a + 1, b)], ids[at(a, b + 1)]]);
                if a + b + 1 < k {
                    triangles.push([ids[at(a + 1, b)], ids[at(a + 1, b + 1)], ids[at(a, b + 1)]]);
                }
            }
        }
    }
    let normals = cubist::scene::compute_normals(&positions, &triangles);
    Mesh {
        name: format!("{} PN x{}", m.name, k * k),
        positions,
        normals,
        triangles,
        uvs: None,
        colors: None,
        material: None,
    }
}

/// Seconds of CPU this process has used.
fn cpu() -> f64 {
    common::cpu_time().map_or(f64::NAN, |d| d.as_secs_f64())
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// The estimate of the exact sums' pairs `auto` used before: every vertex's disk of radius
/// 24 eps on a surface of uniform density.
fn old_estimate(a: &Analysed) -> f64 {
    let n = a.surface.len() as f64;
    let area = a.surface.area();
    let r = 2.0 * levels::SIGMA_SCALES[7] * a.eps;
    if area > 0.0 { n * (n * std::f64::consts::PI * r * r / area).min(n) } else { 0.0 }
}

/// (max, mean) absolute difference.
fn error(a: &[f32], b: &[f32]) -> (f64, f64) {
    let d: Vec<f64> = a.iter().zip(b).map(|(x, y)| (x - y).abs() as f64).collect();
    (d.iter().cloned().fold(0.0, f64::max), d.iter().sum::<f64>() / d.len().max(1) as f64)
}

/// Means by the clustered method, for the canonical surface.
fn clustered(a: &Analysed, beta: f64, group: i64) -> Vec<f64> {
    let sigmas = levels::SIGMA_SCALES.map(|s| s * a.eps);
    approx::clustered_means_with(&a.surface.positions, &a.h, &sigmas, beta, group).0
}

/// The error of approximate `means` estimated on sampled vertices (module doc), as (max, mean).
fn sampled_error(a: &Analysed, means: &[f64]) -> (f64, f64) {
    let pts = &a.surface.positions;
    let n = pts.len();
    let sigmas = levels::SIGMA_SCALES.map(|s| s * a.eps);
    let approx_s = levels::combine(pts, &a.adjacency, &a.h, means, a.eps);
    let samples: Vec<usize> =
        (0..SAMPLES.min(n)).map(|i| (cubist::util::rng::splitmix64(i as u64 + 12345) % n as u64) as usize).collect();
    let rmax = 2.0 * sigmas[7];
    let grid = Grid::new(pts, rmax / 3.0);
    // The cell of each sampled vertex, and its candidates.
    let mut cell_of = vec![usize::MAX; n];
    for c in 0..grid.cell_count() {
        for &i in grid.cell_points(c) {
            cell_of[i as usize] = c;
        }
    }
    let mut mixed = means.to_vec();
    let mut cand = Vec::new();
    for &v in &samples {
        cand.clear();
        grid.candidates(cell_of[v], rmax, &mut cand);
        for (j, s) in sigmas.iter().enumerate() {
            let (mut num, mut den) = (0.0, 0.0);
            for &u in &cand {
                let d2 = cubist::saliency::neighbourhood::dist2(pts[u as usize], pts[v]);
                if d2 < 4.0 * s * s {
                    let w = (-d2 / (2.0 * s * s)).exp();
                    num += w * a.h[u as usize];
                    den += w;
                }
            }
            mixed[v * 8 + j] = num / den;
        }
    }
    let exact_s = levels::combine(pts, &a.adjacency, &a.h, &mixed, a.eps);
    let d: Vec<f64> = samples.iter().map(|&v| (exact_s[v] - approx_s[v]).abs()).collect();
    (d.iter().cloned().fold(0.0, f64::max), d.iter().sum::<f64>() / d.len() as f64)
}

struct Row {
    name: String,
    class: String,
    vertices: usize,
    work: u64,
    estimate: f64,
    auto_exact: bool,
    wall: f64,
    cpu: f64,
    /// Error of auto's result against exact, from the full exact run, if any.
    auto_err: Option<(f64, f64)>,
    /// Error of the clustered method: full, and estimated on samples.
    clustered_err: Option<(f64, f64)>,
    clustered_sampled: Option<(f64, f64)>,
}

fn fmt_err(e: Option<(f64, f64)>) -> (String, String) {
    match e {
        Some((max, mean)) => (format!("{max:.4}"), format!("{mean:.5}")),
        None => ("-".into(), "-".into()),
    }
}

fn measure(pool: &rayon::ThreadPool, m: &Mesh, class: &str, quick: bool, store: &Path) -> Row {
    let a = analyse(&m.positions, &m.triangles);
    let work = a.exact_work();
    let auto_exact = a.uses_exact(SaliencyMethod::Auto);
    let (mut walls, mut cpus) = (Vec::new(), Vec::new());
    let mut auto_values = Vec::new();
    for _ in 0..3 {
        let (c, t) = (cpu(), Instant::now());
        auto_values = pool.install(|| cubist::saliency::mesh_saliency_with(m, SaliencyMethod::Auto));
        walls.push(t.elapsed().as_secs_f64());
        cpus.push(cpu() - c);
    }
    // Exact values: from the store, else computed when affordable.
    let key = content_key(m, SaliencyMethod::Exact);
    let limit = if quick { QUICK_EXACT_LIMIT } else { EXACT_LIMIT };
    let exact = cache::load(store, key, m.positions.len()).or_else(|| {
        (work <= limit).then(|| {
            let t = Instant::now();
            let v = pool.install(|| cubist::saliency::mesh_saliency_with(m, SaliencyMethod::Exact));
            eprintln!("  exact sums of {} in {:.1} s", m.name, t.elapsed().as_secs_f64());
            let _ = cache::store(store, key, &v);
            v
        })
    });
    let means = pool.install(|| clustered(&a, approx::BETA, approx::GROUP));
    let clustered_values = a.to_mesh_order(&levels::combine(&a.surface.positions, &a.adjacency, &a.h, &means, a.eps));
    let sampled = pool.install(|| sampled_error(&a, &means));
    Row {
        name: m.name.clone(),
        class: class.into(),
        vertices: a.surface.len(),
        work,
        estimate: old_estimate(&a),
        auto_exact,
        wall: median(walls),
        cpu: median(cpus),
        auto_err: exact.as_ref().map(|e| error(e, &auto_values)),
        clustered_err: exact.as_ref().map(|e| error(e, &clustered_values)),
        clustered_sampled: Some(sampled),
    }
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let quick = args.iter().any(|a| a == "--quick");
    let pool = rayon::ThreadPoolBuilder::new().num_threads(2).build().expect("thread pool");
    let store = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/saliency-bench");
    println!(
        "2 threads; load average before: {}; wall and CPU: median of 3 runs of the whole per-mesh computation (CPU: this process, both threads).\n",
        common::load_average()
    );
    let mut meshes: Vec<(Mesh, String)> = Vec::new();
    for class in Class::ALL {
        for n in [35_000, 62_000, 134_000, 300_000, 2_000_000] {
            meshes.push((saliency_meshes::generate(class, n), class.name().to_string()));
        }
    }
    for name in ["bunny_2k", "venus_11k", "venus_full", "human", "bunny_full"] {
        if let Some(p) = common::model(name) {
            let mut m = Scene::load(&p).expect("shared model").meshes.remove(0);
            m.name = name.into();
            if name == "bunny_full" {
                for k in [2, 3, 8] {
                    meshes.push((pn_refine(&m, k), "scan, PN-refined".into()));
                }
            }
            meshes.push((m, "model".into()));
        } else {
            eprintln!("skipped {name}: ../shared/models is absent");
        }
    }
    let samples = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/gltf-samples");
    for name in ["CesiumMilkTruck", "Duck", "CesiumMan", "SheenCloth"] {
        match Scene::load(&samples.join(format!("{name}.glb"))) {
            Ok(s) => {
                let mut m = s.meshes.into_iter().max_by_key(|m| m.positions.len()).expect("a mesh");
                m.name = format!("{name} (largest mesh)");
                meshes.push((m, "glTF sample".into()));
            }
            Err(_) => eprintln!("skipped {name}: ../shared/gltf-samples is absent"),
        }
    }
    meshes.sort_by_key(|(m, _)| m.positions.len());
    println!(
        "| mesh | class | vertices | exact work (pairs, counted) | old estimate (x off) | auto picks | wall (s) | CPU (s) | auto: max err | auto: mean err | clustered: max err | clustered: mean err | clustered, sampled: max | sampled: mean |"
    );
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|");
    let mut rows = Vec::new();
    for (m, class) in &meshes {
        eprintln!("{} ({} vertices) ...", m.name, m.positions.len());
        let r = measure(&pool, m, class, quick, &store);
        let off = r.estimate / r.work.max(1) as f64;
        let off = if off >= 1.0 { format!("x{off:.1}") } else { format!("/{:.1}", 1.0 / off) };
        let (am, an) = fmt_err(if r.auto_exact { Some((0.0, 0.0)) } else { r.auto_err });
        let (cm, cn) = fmt_err(r.clustered_err);
        let (sm, sn) = fmt_err(r.clustered_sampled);
        println!(
            "| {} | {} | {} | {:.2e} | {:.2e} ({off}) | {} | {:.3} | {:.2} | {am} | {an} | {cm} | {cn} | {sm} | {sn} |",
            r.name,
            r.class,
            r.vertices,
            r.work as f64,
            r.estimate,
            if r.auto_exact { "exact" } else { "clustered" },
            r.wall,
            r.cpu
        );
        rows.push(r);
    }
    println!("\nload average after: {}", common::load_average());
    // Per class: the clustered method's error, largest over the sizes where it was measured.
    println!(
        "\nClustered method's error by mesh class (largest over the class's meshes with a full exact run; sampled estimate in brackets where there was none):\n"
    );
    println!("| class | max err | mean err |");
    println!("|---|---|---|");
    let mut classes: Vec<&str> = rows.iter().map(|r| r.class.as_str()).collect();
    classes.dedup();
    classes.sort();
    classes.dedup();
    for c in classes {
        let full: Vec<(f64, f64)> = rows.iter().filter(|r| r.class == c).filter_map(|r| r.clustered_err).collect();
        let sampled: Vec<(f64, f64)> = rows
            .iter()
            .filter(|r| r.class == c && r.clustered_err.is_none())
            .filter_map(|r| r.clustered_sampled)
            .collect();
        let worst = |v: &[(f64, f64)]| v.iter().fold((0.0f64, 0.0f64), |(a, b), (x, y)| (a.max(*x), b.max(*y)));
        let (fm, fa) = worst(&full);
        let (sm, sa) = worst(&sampled);
        let cell = |f: f64, s: f64, digits: usize| match (full.is_empty(), sampled.is_empty()) {
            (false, true) => format!("{f:.digits$}"),
            (false, false) => format!("{f:.digits$} [{s:.digits$}]"),
            (true, false) => format!("[{s:.digits$}]"),
            (true, true) => "-".into(),
        };
        println!("| {c} | {} | {} |", cell(fm, sm, 4), cell(fa, sa, 5));
    }
    if !quick {
        sweep(&pool, &meshes);
    }
    let small: Vec<&Row> = rows.iter().filter(|r| r.vertices <= 310_000).collect();
    let large: Vec<&Row> = rows.iter().filter(|r| r.vertices > 1_900_000).collect();
    let worst = |v: &[&Row]| {
        v.iter()
            .map(|r| (r.wall, r.cpu, r.name.clone()))
            .fold((0.0, 0.0, String::new()), |a, b| if b.0 > a.0 { b } else { a })
    };
    let (w, c, name) = worst(&small);
    common::target(
        16,
        "mesh saliency, any mesh up to 300K vertices, 2 cores (slowest mesh, median)",
        "<= 1 s",
        &format!("{w:.2} s wall, {c:.2} s CPU ({name})"),
        Some(w <= 1.0),
    );
    if !large.is_empty() {
        let (w, c, name) = worst(&large);
        common::target(
            16,
            "mesh saliency at 2M vertices, 2 cores (slowest mesh, median)",
            "<= 5 s",
            &format!("{w:.2} s wall, {c:.2} s CPU ({name})"),
            Some(w <= 5.0),
        );
    }
}

/// Cell size and target groups against time and error, on two meshes with exact results.
fn sweep(pool: &rayon::ThreadPool, meshes: &[(Mesh, String)]) {
    println!(
        "\nThe clustered method's parameters: cell side sigma / beta, target groups of g^3 cells (default beta {}, g {}); Gaussian means only, median of 3 runs:\n",
        approx::BETA,
        approx::GROUP
    );
    println!("| mesh | beta | g | means wall (s) | CPU (s) | max err | mean err |");
    println!("|---|---|---|---|---|---|---|");
    let store = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/saliency-bench");
    for (m, _) in
        meshes.iter().filter(|(m, _)| m.name == "uniform 300K" || m.name == "scanned 62K" || m.name == "bunny_full")
    {
        let Some(exact) = cache::load(&store, content_key(m, SaliencyMethod::Exact), m.positions.len()) else {
            continue;
        };
        let a = analyse(&m.positions, &m.triangles);
        for (beta, g) in [(3.0, 1), (4.0, 1), (4.0, 2), (5.0, 2), (6.0, 2)] {
            let (mut walls, mut cpus, mut means) = (Vec::new(), Vec::new(), Vec::new());
            for _ in 0..3 {
                let (c, t) = (cpu(), Instant::now());
                means = pool.install(|| clustered(&a, beta, g));
                walls.push(t.elapsed().as_secs_f64());
                cpus.push(cpu() - c);
            }
            let s = a.to_mesh_order(&levels::combine(&a.surface.positions, &a.adjacency, &a.h, &means, a.eps));
            let (max, mean) = error(&exact, &s);
            println!(
                "| {} | {beta} | {g} | {:.3} | {:.2} | {max:.4} | {mean:.5} |",
                m.name,
                median(walls),
                median(cpus)
            );
        }
    }
}
