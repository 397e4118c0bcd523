//! Million-triangle scenes: generates glTF scenes of 1M, 5M and 10M
//! triangles, then loads, builds and renders each at 1000 x 1000 with the default settings,
//! one child process per scene, printing the time of every stage and the peak resident
//! memory (VmHWM) against the limits. A bench printing markdown, not a timed test.
//!
//! Two kinds of scene at each size, because Blender scenes reach millions of triangles both
//! ways:
//! - `unique`: one subdivided surface holding every triangle (a bumpy sphere tessellated
//!   as finely as asked: long thin triangles at the poles, like CAD; worst case for the BVH
//!   build and for mesh saliency, which is computed for the whole mesh in view);
//! - `instanced`: a 1M-triangle surface placed N times by glTF nodes (collection instances,
//!   arrays, particles): one BVH and one saliency for all copies.
//!
//! `cargo bench --bench scale -- [--sizes 1,5,10] [--kinds unique,instanced] [--size 1000]
//! [--dir target/scale-scenes] [--runs 1]`. The scenes (up to ~250 MB each) are written once
//! to `--dir` and reused.

#[path = "common/mod.rs"]
mod common;
#[path = "../tests/common/gltf_builder.rs"]
#[allow(dead_code)]
mod gltf_builder;

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use cubist::pipeline::{MESH_SALIENCY_OVERLAPPED, Prepared, StageParams, process_cpu, render};
use cubist::progress::Progress;
use cubist::scene::{Scene, World};
use cubist::settings::Settings;
use glam::Vec3;
use serde_json::json;

/// Triangles of the surface the instanced scenes copy.
const INSTANCE_TRIANGLES: u64 = 1_000_000;

struct Args {
    sizes: Vec<u64>,
    kinds: Vec<String>,
    size: u32,
    dir: PathBuf,
    runs: usize,
    one: Option<PathBuf>,
}

fn parse_args() -> Args {
    let mut a = Args {
        sizes: vec![1, 5, 10],
        kinds: vec!["unique".into(), "instanced".into()],
        size: 1000,
        dir: Path::new(env!("CARGO_MANIFEST_DIR")).join("target/scale-scenes"),
        runs: 1,
        one: None,
    };
    let mut it = std::env::args().skip(1);
    while let Some(arg) = it.next() {
        let mut value = || it.next().unwrap_or_else(|| panic!("{arg} needs a value"));
        match arg.as_str() {
            "--sizes" => a.sizes = value().split(',').map(|s| s.parse().expect("--sizes 1,5,10 (millions)")).collect(),
            "--kinds" => a.kinds = value().split(',').map(str::to_string).collect(),
            "--size" => a.size = value().parse().expect("--size N"),
            "--dir" => a.dir = PathBuf::from(value()),
            "--runs" => a.runs = value().parse().expect("--runs N"),
            "--one" => a.one = Some(PathBuf::from(value())),
            "--quick" => a.sizes = vec![1],
            "--bench" => {}
            "--help" | "-h" => {
                println!(
                    "scale bench: [--sizes 1,5,10] [--kinds unique,instanced] [--size 1000] [--dir DIR] [--runs 1] [--quick: 1M only]"
                );
                std::process::exit(0);
            }
            other => panic!("unknown argument {other} (see --help)"),
        }
    }
    a
}

/// A closed bumpy surface of about `triangles` triangles: a UV sphere of n x 2n quads whose
/// radius varies smoothly (a few octaves of sines, `seed` shifting them), indexed, with
/// vertex normals.
fn surface(triangles: u64, seed: u32) -> (Vec<Vec3>, Vec<[u32; 3]>) {
    // 2n quads per row, n rows, two triangles per quad except at the poles: ~4 n^2.
    let n = ((triangles as f64 / 4.0).sqrt().round() as u32).max(4);
    let s = seed as f32;
    let mut positions = Vec::with_capacity(((n + 1) * 2 * n) as usize);
    for j in 0..=n {
        let th = std::f32::consts::PI * j as f32 / n as f32;
        for i in 0..2 * n {
            let ph = std::f32::consts::PI * i as f32 / n as f32;
            let d = Vec3::new(th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin());
            let bump = 0.08 * (5.0 * d.x + s).sin() * (4.0 * d.y).cos()
                + 0.03 * (13.0 * d.z + 2.0 * s).sin() * (11.0 * d.x).sin()
                + 0.01 * (41.0 * d.y + s).sin() * (37.0 * d.z).cos()
                + 0.003 * (130.0 * d.x).sin() * (127.0 * d.y + s).sin();
            positions.push(d * (1.0 + bump));
        }
    }
    let v = |i: u32, j: u32| j * 2 * n + i % (2 * n);
    let mut tris = Vec::with_capacity(4 * (n as usize).pow(2));
    for j in 0..n {
        for i in 0..2 * n {
            if j > 0 {
                tris.push([v(i, j), v(i + 1, j), v(i + 1, j + 1)]);
            }
            if j + 1 < n {
                tris.push([v(i, j), v(i + 1, j + 1), v(i, j + 1)]);
            }
        }
    }
    (positions, tris)
}

/// Writes `name` into `dir` unless present: `copies` nodes placing one surface of
/// `triangles` (on a grid, each turned and scaled a little), a sun.
fn scene_file(dir: &Path, name: &str, triangles: u64, copies: u32) -> PathBuf {
    let path = dir.join(format!("{name}.glb"));
    if path.is_file() {
        return path;
    }
    std::fs::create_dir_all(dir).expect("scene directory");
    let t = Instant::now();
    let (p, tris) = surface(triangles, 1);
    let normals = cubist::scene::compute_normals(&p, &tris);
    let mut g = gltf_builder::Gltf::default();
    let flat = |v: &[Vec3]| v.iter().flat_map(|x| x.to_array()).collect::<Vec<f32>>();
    let pos = g.floats(&flat(&p), 3, true);
    let nrm = g.floats(&flat(&normals), 3, false);
    drop((p, normals));
    let idx: Vec<u32> = tris.iter().flatten().copied().collect();
    drop(tris);
    let idx = g.indices(&idx);
    g.materials
        .push(json!({"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.7, 0.55, 1.0], "roughnessFactor": 0.6}}));
    let mesh = g.mesh(json!({"POSITION": pos, "NORMAL": nrm}), Some(idx), 4, Some(0));
    let side = (copies as f64).sqrt().ceil() as u32;
    for c in 0..copies {
        let (x, z) = ((c % side) as f64 * 2.4, (c / side) as f64 * 2.4);
        let a = 0.7 * c as f64;
        let k = 1.0 - 0.03 * (c % 5) as f64;
        let node = g.node(json!({
            "mesh": mesh,
            "translation": [x, 0.0, z],
            "rotation": [0.0, (a / 2.0).sin(), 0.0, (a / 2.0).cos()],
            "scale": [k, k, k],
        }));
        g.scene_nodes.push(node);
    }
    g.lights.push(json!({"type": "directional", "intensity": 3.0}));
    let sun = g.node(json!({"extensions": {"KHR_lights_punctual": {"light": 0}}, "rotation": [-0.35, 0.3, 0.1, 0.88]}));
    g.scene_nodes.push(sun);
    std::fs::write(&path, g.to_glb()).expect("write scene");
    // On disk before any run: `write` syncs its PNG, so it also waits for whatever else is
    // still to reach the disk (these hundreds of MB, a build's output), not only for its own.
    std::fs::File::open(&path).and_then(|f| f.sync_all()).expect("sync scene");
    eprintln!("generated {} in {:.1} s", path.display(), t.elapsed().as_secs_f64());
    path
}

/// A /proc/self/status figure in MiB (VmHWM: peak resident; VmRSS: now).
fn status_mib(key: &str) -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with(key))
                .and_then(|l| l.split_whitespace().nth(1).and_then(|k| k.parse::<f64>().ok()))
        })
        .map_or(f64::NAN, |kb| kb / 1024.0)
}

/// The child: one scene loaded, built and rendered as `cubist render` does, each step timed.
/// Prints one line: `ROW|name=value|...`.
fn run_one(path: &Path, size: u32) {
    let cpu0 = common::cpu_time();
    let t0 = Instant::now();
    let mut row: Vec<(String, String)> = Vec::new();
    let mut time = |name: &str, d: Duration, cpu: Option<Duration>| {
        row.push((name.into(), format!("{:.0}", common::ms(d))));
        if let Some(c) = cpu {
            row.push((format!("cpu:{name}"), format!("{:.0}", common::ms(c))));
        }
    };
    let cpu_since = |c: Option<Duration>| c.zip(process_cpu()).map(|(a, b)| b.saturating_sub(a));
    let (t, c) = (Instant::now(), process_cpu());
    let scene = Scene::load(path).expect("load");
    time("load", t.elapsed(), cpu_since(c));
    let (t, c) = (Instant::now(), process_cpu());
    let world = World::new(&scene);
    time("world", t.elapsed(), cpu_since(c));
    // As `cubist render` does: mesh saliency beside the BVH build (its CPU is in `bvh`'s).
    let settings = Settings { width: size, height: size, ..Settings::default() };
    let params = StageParams::new(&settings);
    let (t, c) = (Instant::now(), process_cpu());
    let (prep, mesh_time) = Prepared::build_with_saliency(scene, world, &params.saliency);
    time("bvh", t.elapsed(), cpu_since(c));
    time(MESH_SALIENCY_OVERLAPPED, mesh_time, None);
    let rss_built = status_mib("VmRSS:");
    let r = render(&prep, &settings, &Progress::silent()).expect("render");
    for (i, (stage, d)) in r.timings.0.iter().enumerate() {
        if *stage == MESH_SALIENCY_OVERLAPPED {
            // Found done beside the BVH build: only the memo's look-ups left.
            continue;
        }
        time(stage, *d, r.timings.cpu(i));
    }
    let t = Instant::now();
    let out = std::env::temp_dir().join(format!("cubist-scale-{}.png", std::process::id()));
    cubist::output::write_png(&out, &r.image).expect("write");
    let _ = std::fs::remove_file(&out);
    time("write", t.elapsed(), None);
    time("total", t0.elapsed(), None);
    let cpu = match (cpu0, common::cpu_time()) {
        (Some(a), Some(b)) => format!("{:.1}", (b - a).as_secs_f64()),
        _ => "?".into(),
    };
    row.push(("cpu".into(), cpu));
    row.push(("placed".into(), prep.world.triangle_count().to_string()));
    row.push(("stored".into(), prep.accel.stored_triangles().to_string()));
    row.push(("objects".into(), prep.world.objects.len().to_string()));
    row.push(("bvh_mib".into(), format!("{:.0}", prep.accel.memory_bytes() as f64 / 1048576.0)));
    row.push(("rss_built".into(), format!("{rss_built:.0}")));
    row.push(("peak".into(), format!("{:.0}", status_mib("VmHWM:"))));
    let line: Vec<String> = row.iter().map(|(k, v)| format!("{k}={v}")).collect();
    println!("ROW|{}", line.join("|"));
}

fn main() {
    let args = parse_args();
    if let Some(p) = &args.one {
        run_one(p, args.size);
        return;
    }
    let cores = rayon::current_num_threads();
    println!("### Million-triangle scenes (`benches/scale.rs`)\n");
    println!(
        "Each scene loaded (glTF), placed in render space (world), its two-level BVH built (with the meshes' saliency computed beside it), and rendered at {0} x {0} with the default settings (preset `analytic`), as one `cubist render`, in a process of its own; {1} rayon threads; load average before: {2}. Times in ms (the fastest of {3} run(s) by total), wall; CPU = the process's CPU time, s; peak = VmHWM, MiB; BVH = the BVHs and their triangles, MiB. `unique`: one subdivided surface of every triangle; `instanced`: a {4}-triangle surface placed by N nodes.\n",
        args.size,
        cores,
        common::load_average(),
        args.runs,
        INSTANCE_TRIANGLES
    );
    let stages = [
        "load",
        "world",
        "bvh",
        // Its wall time, beside the BVH build (not in the total's sum).
        MESH_SALIENCY_OVERLAPPED,
        "framing",
        "pre-render",
        "saliency",
        "faceting",
        "imprecision",
        // The pixels the re-trace keeps, shaded after the aims (a one-off render's deferred
        // pre-render).
        "shading",
        "re-trace",
        "anti-aliasing",
        "paint",
        "encode",
        "write",
    ];
    println!(
        "| scene | triangles (placed / stored) | {} | total | CPU s | peak MiB | BVH MiB | limit: time, memory | met |",
        stages.join(" | ")
    );
    println!("|---|---|{}---|---|---|---|---|---|", "---|".repeat(stages.len()));
    let exe = std::env::current_exe().expect("own path");
    let mut cpu_rows: Vec<String> = Vec::new();
    for &m in &args.sizes {
        let (limit_s, limit_gb) = match m {
            0..=1 => (3.0, 2.0),
            2..=5 => (10.0, 6.0),
            _ => (20.0, 12.0),
        };
        for kind in &args.kinds {
            let total = m * 1_000_000;
            let (name, file) = match kind.as_str() {
                "unique" => (format!("{m}M unique"), scene_file(&args.dir, &format!("unique_{m}m"), total, 1)),
                "instanced" => {
                    let copies = (total / INSTANCE_TRIANGLES).max(1) as u32;
                    (
                        format!("{m}M instanced ({copies} copies)"),
                        scene_file(&args.dir, &format!("instanced_{m}m"), INSTANCE_TRIANGLES, copies),
                    )
                }
                other => panic!("unknown kind {other}"),
            };
            let mut best: Option<Vec<(String, String)>> = None;
            for _ in 0..args.runs {
                let out = std::process::Command::new(&exe)
                    .args(["--one", file.to_str().unwrap(), "--size", &args.size.to_string()])
                    .output()
                    .expect("run child");
                let text = String::from_utf8_lossy(&out.stdout);
                let Some(line) = text.lines().find(|l| l.starts_with("ROW|")) else {
                    println!(
                        "| {name} | failed: {} |",
                        String::from_utf8_lossy(&out.stderr).lines().last().unwrap_or("")
                    );
                    break;
                };
                let row: Vec<(String, String)> = line[4..]
                    .split('|')
                    .filter_map(|kv| kv.split_once('=').map(|(k, v)| (k.to_string(), v.to_string())))
                    .collect();
                let total = |r: &[(String, String)]| {
                    r.iter()
                        .find(|(k, _)| k == "total")
                        .map_or(f64::INFINITY, |(_, v)| v.parse().unwrap_or(f64::INFINITY))
                };
                if best.as_ref().is_none_or(|b| total(&row) < total(b)) {
                    best = Some(row);
                }
            }
            let Some(row) = best else { continue };
            let cpu_of = |k: &str| {
                row.iter().find(|(key, _)| *key == format!("cpu:{k}")).map_or("-".to_string(), |(_, v)| v.clone())
            };
            let process = row.iter().find(|(k, _)| k == "cpu").map_or("-".to_string(), |(_, v)| v.clone());
            let cells: Vec<String> = stages[..stages.len() - 1].iter().map(|s| cpu_of(s)).collect();
            cpu_rows.push(format!("| {name} | {} | {process} |", cells.join(" | ")));
            let get = |k: &str| row.iter().find(|(key, _)| key == k).map_or("-".to_string(), |(_, v)| v.clone());
            let cells: Vec<String> = stages.iter().map(|s| get(s)).collect();
            let (t_ms, peak): (f64, f64) =
                (get("total").parse().unwrap_or(f64::NAN), get("peak").parse().unwrap_or(f64::NAN));
            let met = t_ms <= limit_s * 1e3 && peak <= limit_gb * 1024.0;
            println!(
                "| {name} | {} / {} | {} | **{}** | {} | {} | {} | {} s, {} GB | {} |",
                get("placed"),
                get("stored"),
                cells.join(" | "),
                get("total"),
                get("cpu"),
                get("peak"),
                get("bvh_mib"),
                limit_s,
                limit_gb,
                if met { "yes" } else { "**no**" }
            );
            common::target(
                16,
                &format!("{name} at {0}x{0}, defaults: time, peak memory", args.size),
                &format!("<= {limit_s} s, <= {limit_gb} GB"),
                &format!("{:.2} s wall ({} s CPU), {:.2} GB", t_ms / 1e3, get("cpu"), peak / 1024.0),
                Some(met),
            );
        }
    }
    // CPU time per stage (all threads): what holds on a shared machine.
    println!("\nCPU ms per stage (all threads; the same runs):\n");
    println!("| scene | {} | process CPU s |", stages[..stages.len() - 1].join(" | "));
    println!("|---|{}---|", "---|".repeat(stages.len() - 1));
    for r in &cpu_rows {
        println!("{r}");
    }
    println!("\nload average after: {}", common::load_average());
}
