//! Mesh saliency: run time against error. Exact saliency on the shared models (full and
//! decimated) and on a 1.25M-vertex mesh (bunny_full refined by PN triangles, 36 sub-triangles
//! each), then the clustered approximation at several cluster sizes with its error against
//! exact (max and mean absolute difference of the final [0, 1] saliency).
//!
//! `cargo bench --bench saliency` (everything; exact on the 1.25M mesh takes minutes), or
//! `cargo bench --bench saliency -- --quick` to skip the exact sums on the huge mesh.
//! Prints a markdown table. Needs ../shared/models; without it only the generated meshes run.

#[path = "common/mod.rs"]
mod common;

use std::path::Path;
use std::time::Instant;

use cubist::saliency::{SaliencyMethod, analyse, approx, cache, content_key, levels};
use cubist::scene::{Mesh, Scene};

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

/// This process's CPU time (user + system), seconds: on a shared machine wall time also
/// counts other processes' load, CPU time does not. NaN where /proc is unavailable.
fn cpu_seconds() -> f64 {
    let Ok(stat) = std::fs::read_to_string("/proc/self/stat") else { return f64::NAN };
    let Some(rest) = stat.rsplit(')').next() else { return f64::NAN };
    let f: Vec<&str> = rest.split_whitespace().collect();
    // Fields 14 and 15 of stat (utime, stime) are the 12th and 13th after the ")".
    match (f.get(11).and_then(|x| x.parse::<f64>().ok()), f.get(12).and_then(|x| x.parse::<f64>().ok())) {
        (Some(u), Some(s)) => (u + s) / 100.0,
        _ => f64::NAN,
    }
}

/// Saliency per vertex (mesh order) by the exact sums or by clusters of side sigma / beta;
/// returns (values, wall seconds, CPU seconds).
fn run(m: &Mesh, beta: Option<f64>) -> (Vec<f32>, f64, f64) {
    let c = cpu_seconds();
    let t = Instant::now();
    let a = analyse(&m.positions, &m.triangles);
    let sigmas = levels::SIGMA_SCALES.map(|s| s * a.eps);
    let means = match beta {
        None => levels::gaussian_means(&a.surface.positions, &a.h, &sigmas),
        Some(b) => approx::clustered_means(&a.surface.positions, &a.h, &sigmas, b),
    };
    let s = levels::combine(&a.surface.positions, &a.adjacency, &a.h, &means, a.eps);
    let out = a.to_mesh_order(&s);
    (out, t.elapsed().as_secs_f64(), cpu_seconds() - c)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let quick = args.iter().any(|a| a == "--quick");
    let models = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/models");
    let mut meshes: Vec<Mesh> = Vec::new();
    for name in ["sphere_1280", "bunny_2k", "venus_11k", "venus_full", "bunny_full"] {
        let path = models.join(format!("{name}.glb"));
        match Scene::load(&path) {
            Ok(mut s) => {
                let mut m = s.meshes.remove(0);
                m.name = name.into();
                meshes.push(m);
            }
            Err(_) => eprintln!("skipped {name}: {} not found", path.display()),
        }
    }
    let huge_base = meshes.iter().find(|m| m.name == "bunny_full").cloned();
    if let Some(b) = huge_base {
        let t = Instant::now();
        let h = pn_refine(&b, 6);
        eprintln!("generated {} ({} vertices) in {:.1} s", h.name, h.positions.len(), t.elapsed().as_secs_f64());
        meshes.push(h);
    }
    let store = Path::new(env!("CARGO_MANIFEST_DIR")).join("target/saliency-bench");
    println!(
        "rayon threads: {}, load average before: {}; wall = one run, CPU = this process's, all threads.\n",
        rayon::current_num_threads(),
        common::load_average()
    );
    let mut bunny_exact = None;
    let mut huge_figures = Vec::new();
    println!("| mesh | vertices | method | wall (s) | CPU (s) | max abs err | mean abs err | auto picks |");
    println!("|---|---|---|---|---|---|---|---|");
    for m in &meshes {
        let a = analyse(&m.positions, &m.triangles);
        let auto = if a.uses_exact(SaliencyMethod::Auto) { "exact" } else { "clustered" };
        let n = a.surface.len();
        let huge = n > 500_000;
        // Exact results of the huge mesh are kept (target/saliency-bench) so `--quick` can still
        // report the approximation's error.
        let key = content_key(m, SaliencyMethod::Exact);
        let times = store.join(format!("{key:032x}.time"));
        let exact = if huge && quick {
            let cached = cache::load(&store, key, m.positions.len());
            let t = std::fs::read_to_string(&times).unwrap_or_default();
            if cached.is_some() {
                println!("| {} | {n} | exact (earlier full run) | {} | - | - | {auto} |", m.name, t.trim());
                // The file holds "wall | CPU", the table's two columns.
                let (wall, cpu) = t.trim().split_once(" | ").unwrap_or((t.trim(), "?"));
                huge_figures.push(format!("exact {wall} s wall, {cpu} s CPU (earlier full run)"));
            }
            cached
        } else {
            let (s, t, c) = run(m, None);
            println!("| {} | {n} | exact | {t:.3} | {c:.2} | - | - | {auto} |", m.name);
            if m.name == "bunny_full" {
                bunny_exact = Some((t, c));
            }
            if huge {
                huge_figures.push(format!("exact {t:.0} s"));
            }
            if huge {
                let _ = cache::store(&store, key, &s);
                let _ = std::fs::write(&times, format!("{t:.3} | {c:.2}"));
            }
            Some(s)
        };
        for beta in [3.0, 4.0, 6.0] {
            let (s, t, c) = run(m, Some(beta));
            let (max, mean) = match &exact {
                Some(e) => {
                    let d: Vec<f64> = e.iter().zip(&s).map(|(a, b)| (a - b).abs() as f64).collect();
                    let max = d.iter().cloned().fold(0.0, f64::max);
                    (format!("{max:.4}"), format!("{:.5}", d.iter().sum::<f64>() / d.len() as f64))
                }
                None => ("n/a".into(), "n/a".into()),
            };
            let mark = if beta == approx::BETA { " (default)" } else { "" };
            if huge && beta == approx::BETA {
                huge_figures
                    .push(format!("clustered (default) {t:.2} s wall, {c:.2} s CPU, max err {max}, mean err {mean}"));
            }
            println!("| {} | {n} | clustered, cell sigma/{beta}{mark} | {t:.3} | {c:.2} | {max} | {mean} | |", m.name);
        }
    }
    println!("\nload average after: {}", common::load_average());
    if let Some((t, c)) = bunny_exact {
        common::target(
            3,
            &format!("bunny_full exact saliency (35K vertices), {} threads", rayon::current_num_threads()),
            "< 0.5 s",
            &format!("{t:.3} s wall, {c:.2} s CPU"),
            Some(t < 0.5),
        );
    }
    if !huge_figures.is_empty() {
        common::target(
            3,
            "1.25M-vertex mesh (bunny_full PN x36) saliency",
            "figure asked",
            &huge_figures.join("; "),
            None,
        );
    }
}
