//! Time and time-against-error tables for BENCHMARKS.md (run through `bash scripts/bench.sh`;
//! `cargo bench --bench pipeline -- --help` for options). A bench binary printing markdown,
//! not a timed test: nothing here can fail on a slow machine.
//!
//! 1. Primary rays: Mrays/s through the spherical and perspective cameras, traced
//!    by the render loop (`Tracer::render`, no shading: `Accel::closest` plus the per-sample
//!    hit records) against a bare obvhs traversal of the same rays (`Accel::bare_traversal`),
//!    and the loop's overhead in percent (target: at most 30%).
//! 2. Samples per pixel against error (issues 2 and 8): the full `render` at 1, 2, 4, 8, 16
//!    spp, time and PSNR of the 8-bit image against a 64 spp reference.
//! 3. Stage by stage: the full default pipeline (preset `analytic`: pre-render, saliency,
//!    Segment faceting, imprecision, re-trace of the moved facets, painterly effects, encode)
//!    at the same size on the scene and on the built-in still life, each run from a freshly
//!    prepared scene so mesh saliency is computed as in a single `cubist render`.
//!
//! The other tables BENCHMARKS.md asks for come from the per-stage benches, which
//! `scripts/bench.sh` runs too: mesh saliency exact against clustered (`benches/saliency.rs`),
//! Segment superpixels against boundary agreement (`benches/segment.rs`), each faceting
//! method's stages and the facet figures (`benches/facet_stages.rs`), painterly effects
//! (`benches/paint.rs`).

#[path = "common/mod.rs"]
mod common;

use std::path::PathBuf;
use std::time::{Duration, Instant};

use cubist::film::Film;
use cubist::framing::frame_camera;
use cubist::pipeline::{Prepared, Rendered, params, render};
use cubist::progress::Progress;
use cubist::scene::Scene;
use cubist::settings::{CameraKind, Framing, Preset, Settings};
use cubist::trace::{Tracer, screen_point};
use glam::DVec2;
use rayon::prelude::*;

struct Args {
    scene: Option<PathBuf>,
    size: u32,
    repeat: usize,
    spps: Vec<u32>,
    reference_spp: u32,
    /// Runs of each full default render (stage table).
    pipeline_runs: usize,
}

fn parse_args() -> Args {
    let mut a = Args {
        scene: Some(PathBuf::from("../shared/models/venus_11k.glb")),
        size: 1000,
        repeat: 5,
        spps: vec![1, 2, 4, 8, 16],
        reference_spp: 64,
        pipeline_runs: 3,
    };
    let mut it = std::env::args().skip(1);
    while let Some(arg) = it.next() {
        let mut value = || it.next().unwrap_or_else(|| panic!("{arg} needs a value"));
        match arg.as_str() {
            "--scene" => a.scene = Some(PathBuf::from(value())),
            "--default-scene" => a.scene = None,
            "--size" => a.size = value().parse().expect("--size N"),
            "--repeat" => a.repeat = value().parse().expect("--repeat N"),
            "--spp" => a.spps = value().split(',').map(|s| s.parse().expect("--spp 1,2,4")).collect(),
            "--reference-spp" => a.reference_spp = value().parse().expect("--reference-spp N"),
            "--quick" => (a.repeat, a.pipeline_runs) = (2, 1),
            "--bench" => {} // cargo bench passes it
            "--help" | "-h" => {
                println!(
                    "pipeline bench: [--scene FILE | --default-scene] [--size 1000] [--repeat 5] [--spp 1,2,4,8,16] [--reference-spp 64] [--quick: 2 runs of each timing, 1 of each full render]"
                );
                std::process::exit(0);
            }
            other => panic!("unknown argument {other} (see --help)"),
        }
    }
    a
}

/// CPU time used so far by every thread of this process, from /proc/self/task/*/schedstat
/// (nanoseconds on the CPU; Linux only). Unlike wall time it does not count the time other
/// processes hold the cores, so it stays comparable on a shared machine.
fn cpu_ns() -> Option<u64> {
    let mut total = 0;
    for task in std::fs::read_dir("/proc/self/task").ok()? {
        let stat = std::fs::read_to_string(task.ok()?.path().join("schedstat")).ok()?;
        total += stat.split_whitespace().next()?.parse::<u64>().ok()?;
    }
    Some(total)
}

/// Runs `f` `n` times; (best wall time, mean CPU time per run if known).
fn measure(n: usize, mut f: impl FnMut()) -> (Duration, Option<Duration>) {
    let mut walls = Vec::new();
    let c0 = cpu_ns();
    for _ in 0..n {
        let t = Instant::now();
        f();
        walls.push(t.elapsed());
    }
    let cpu = match (c0, cpu_ns()) {
        (Some(a), Some(b)) => Some(Duration::from_nanos((b - a) / n as u64)),
        _ => None,
    };
    (best(walls), cpu)
}

/// The best of several runs: on a shared machine the minimum is the closest estimate of the
/// intrinsic cost (every disturbance only adds time).
fn best(v: Vec<Duration>) -> Duration {
    v.into_iter().min().expect("at least one run")
}

fn ms(d: Duration) -> f64 {
    d.as_secs_f64() * 1e3
}

fn settings(kind: CameraKind, size: u32, spp: u32) -> Settings {
    let mut s = Settings::preset(Preset::Plain);
    s.camera = kind;
    s.width = size;
    s.height = size;
    s.spp = spp;
    s
}

/// PSNR in dB of two RGBA8 images over their RGB channels (infinite when identical), over the
/// pixels `mask` selects.
fn psnr(a: &image::RgbaImage, b: &image::RgbaImage, mask: impl Fn(usize) -> bool) -> f64 {
    let mut se = 0f64;
    let mut n = 0u64;
    for (i, (p, q)) in a.pixels().zip(b.pixels()).enumerate() {
        if !mask(i) {
            continue;
        }
        for c in 0..3 {
            let d = p.0[c] as f64 - q.0[c] as f64;
            se += d * d;
            n += 1;
        }
    }
    let mse = se / n.max(1) as f64;
    if mse == 0.0 { f64::INFINITY } else { 10.0 * (255.0 * 255.0 / mse).log10() }
}

/// Timings of one way of tracing the primary rays: best wall time, mean CPU time.
struct Timed {
    wall: Duration,
    cpu: Option<Duration>,
}

impl Timed {
    /// The CPU time when known (stable on a shared machine), else the wall time.
    fn cost(&self) -> Duration {
        self.cpu.unwrap_or(self.wall)
    }
}

/// Times tracing one ray through each pixel centre: the render loop without shading against
/// a bare traversal of the same rays, alternating the two. Returns (bare, loop, hit fraction).
fn primary_rays(prep: &Prepared, s: &Settings, repeat: usize) -> (Timed, Timed, f64) {
    let framed = frame_camera(&params::framing(s), &prep.world, &prep.accel).expect("camera");
    let (w, h) = (s.width, s.height);
    let centre = DVec2::splat(0.5);
    let bare = || -> usize {
        (0..h)
            .into_par_iter()
            .map(|y| {
                (0..w)
                    .filter(|&x| {
                        let r = framed.camera.ray(screen_point(x, y, centre, w, h));
                        prep.accel.bare_traversal(r.origin, r.dir)
                    })
                    .count()
            })
            .sum()
    };
    let tracer =
        Tracer { world: &prep.world, accel: &prep.accel, rig: None, background: glam::Vec3::ZERO, seed: s.seed };
    let mut film = Film::new(w, h, 1);
    // Warm up (page in the buffers, spin up rayon's threads), then alternate the two.
    let mut hits = bare();
    tracer.render(&mut film, &|_, p| framed.camera.ray(p), None, None, &Progress::silent());
    let (mut bw, mut lw) = (Vec::new(), Vec::new());
    let (mut bc, mut lc) = (Some(Duration::ZERO), Some(Duration::ZERO));
    for _ in 0..repeat {
        let (wall, cpu) = measure(1, || hits = bare());
        bw.push(wall);
        bc = bc.zip(cpu).map(|(a, b)| a + b);
        let (wall, cpu) =
            measure(1, || tracer.render(&mut film, &|_, p| framed.camera.ray(p), None, None, &Progress::silent()));
        lw.push(wall);
        lc = lc.zip(cpu).map(|(a, b)| a + b);
    }
    let loop_hits = film.hits.iter().filter(|h| h.is_hit()).count();
    assert_eq!(hits, loop_hits, "the bare traversal and the render loop disagree on which rays hit");
    let n = repeat as u32;
    (
        Timed { wall: best(bw), cpu: bc.map(|c| c / n) },
        Timed { wall: best(lw), cpu: lc.map(|c| c / n) },
        hits as f64 / (w as f64 * h as f64),
    )
}

fn main() {
    let args = parse_args();
    let scene_name = match &args.scene {
        Some(p) if p.exists() => p.display().to_string(),
        Some(p) => {
            eprintln!("{} is absent: using the built-in still life", p.display());
            "built-in still life".into()
        }
        None => "built-in still life".into(),
    };
    let t = Instant::now();
    let prep = Prepared::load(args.scene.as_deref().filter(|p| p.exists())).expect("scene");
    let load = t.elapsed();
    let size = args.size;
    let threads = rayon::current_num_threads();
    println!(
        "Scene: `{scene_name}` ({} triangles), {size} x {size} pixels, {threads} rayon threads; \
         {} runs of each timing; wall times are the best run, CPU times (all threads, from \
         /proc/self/task/*/schedstat) the mean: on a shared machine CPU time is the stable measure.\n",
        prep.world.triangle_count(),
        args.repeat
    );
    println!(
        "Loading the scene (glTF, flatten, BVH): {:.1} ms, of which flatten + BVH {:.1} ms.\n",
        ms(load),
        ms(prep.build_time)
    );

    println!("### Primary rays (one per pixel centre, no shading)\n");
    println!(
        "Bare: `Accel::bare_traversal` of each camera ray (obvhs BVH2 traversal + our triangle test). \
         Render loop: `Tracer::render` with no light rig, i.e. `Accel::closest` (deterministic \
         tie-break), the hit's surface attributes and the per-pixel and per-sample hit buffers.\n"
    );
    println!(
        "| camera | rays hitting | bare: wall ms (best) | CPU ms | Mrays/s per core | render loop: wall ms (best) | CPU ms | Mrays/s per core | loop overhead (CPU) |"
    );
    println!("|---|---|---|---|---|---|---|---|---|");
    let mut worst_overhead = f64::NEG_INFINITY;
    for (kind, framing) in [
        (CameraKind::Spherical, Framing::Fit),
        (CameraKind::Spherical, Framing::Centre),
        (CameraKind::Perspective, Framing::Fit),
    ] {
        let mut s = settings(kind, size, 1);
        s.framing = framing;
        let (bare, traced, hit) = primary_rays(&prep, &s, args.repeat);
        let rays = size as f64 * size as f64;
        let what = if kind == CameraKind::Perspective { String::new() } else { format!(", framing {framing}") };
        let cpu = |t: &Timed| t.cpu.map(|c| format!("{:.1}", ms(c))).unwrap_or_else(|| "-".into());
        let overhead = (traced.cost().as_secs_f64() / bare.cost().as_secs_f64() - 1.0) * 100.0;
        worst_overhead = worst_overhead.max(overhead);
        println!(
            "| {kind} ({:.0} deg{what}) | {:.1}% | {:.1} | {} | {:.2} | {:.1} | {} | {:.2} | {:+.1}% |",
            params::framing(&s).angle_deg(params::camera_kind(kind), None),
            hit * 100.0,
            ms(bare.wall),
            cpu(&bare),
            rays / bare.cost().as_secs_f64() / 1e6,
            ms(traced.wall),
            cpu(&traced),
            rays / traced.cost().as_secs_f64() / 1e6,
            overhead
        );
    }
    common::target(
        2,
        "render loop overhead over a bare BVH traversal, primary rays (worst camera above)",
        "<= 30%",
        &format!("{worst_overhead:+.1}%"),
        Some(worst_overhead <= 30.0),
    );
    // What part of the loop's fixed cost per pixel is only memory: writing the buffers it
    // must fill (colour, pixel hit, sample hit) with no tracing at all.
    let mut film = Film::new(size, size, 1);
    let wu = size as usize;
    let fill = |film: &mut Film| {
        film.color.par_chunks_mut(wu).zip(film.hits.par_chunks_mut(wu)).zip(film.samples.par_chunks_mut(wu)).for_each(
            |((c, h), s)| {
                for x in 0..wu {
                    c[x] = glam::Vec4::new(x as f32, 0.0, 0.0, 1.0);
                    h[x] = cubist::film::PixelHit { tri: x as u32, ..cubist::film::PixelHit::MISS };
                    s[x] = cubist::film::SampleHit { tri: x as u32, u: 0.0, v: 0.0 };
                }
            },
        )
    };
    fill(&mut film);
    let (wall, cpu) = measure(args.repeat, || fill(&mut film));
    let per_pixel = std::mem::size_of::<glam::Vec4>()
        + std::mem::size_of::<cubist::film::PixelHit>()
        + std::mem::size_of::<cubist::film::SampleHit>();
    println!(
        "\nWriting the loop's buffers alone ({per_pixel} bytes per pixel, no tracing): {:.1} ms wall (best), {} ms CPU.",
        ms(wall),
        cpu.map(|c| format!("{:.1}", ms(c))).unwrap_or_else(|| "-".into())
    );

    println!("\n### Samples per pixel against error (full `render`, spherical camera, shadows on)\n");
    let reference_settings = settings(CameraKind::Spherical, size, args.reference_spp);
    let t = Instant::now();
    let reference = render(&prep, &reference_settings, &Progress::silent()).expect("reference render");
    let reference_time = t.elapsed();
    println!("Reference: {} spp, rendered once in {:.0} ms.\n", args.reference_spp, ms(reference_time));
    // Pixels any reference sample saw geometry in: the background is exact at any spp.
    let covered: Vec<bool> = reference.film.color.iter().map(|c| c.w > 0.0).collect();
    println!(
        "{:.1}% of the pixels show geometry; PSNR is given over the whole image and over those pixels.\n",
        100.0 * covered.iter().filter(|c| **c).count() as f64 / covered.len() as f64
    );
    println!(
        "| spp | render ms | ms per spp | PSNR vs {} spp, image (dB) | PSNR, geometry pixels (dB) |",
        args.reference_spp
    );
    println!("|---|---|---|---|---|");
    for &spp in &args.spps {
        let s = settings(CameraKind::Spherical, size, spp);
        let runs = if spp <= 4 { args.repeat.min(3) } else { 1 };
        let mut times = Vec::new();
        let mut last = None;
        for _ in 0..runs {
            let t = Instant::now();
            let r = render(&prep, &s, &Progress::silent()).expect("render");
            times.push(t.elapsed());
            last = Some(r);
        }
        let r = last.expect("at least one run");
        let t = best(times);
        println!(
            "| {spp} | {:.0} | {:.0} | {:.2} | {:.2} |",
            ms(t),
            ms(t) / spp as f64,
            psnr(&r.image, &reference.image, |_| true),
            psnr(&r.image, &reference.image, |i| covered[i])
        );
    }

    println!("\n### Stage by stage: the full default pipeline (preset `analytic`, {size} x {size}, 4 spp)\n");
    let still_life = Scene::default_scene();
    let mut scenes: Vec<(String, &Scene)> = Vec::new();
    if args.scene.as_deref().is_some_and(|p| p.exists()) {
        scenes.push((scene_name.rsplit('/').next().unwrap_or(&scene_name).to_string(), &prep.scene));
    }
    scenes.push(("built-in still life".into(), &still_life));
    let runs: Vec<(DefaultRun, DefaultRun)> =
        scenes.iter().map(|(_, s)| default_pipeline(s, size, args.pipeline_runs)).collect();
    println!(
        "`cubist render SCENE --width {size} --height {size}` with every other setting at its default: \
         `Rendered::timings` of the fastest of {} runs, each from a freshly prepared scene (mesh saliency \
         computed, as in one `cubist render`; CPU time includes the BVH build); the next frame of an animation rendered from the same \
         prepared scene finds the meshes' saliency in memory (last rows). Stages overlap nothing: \
         the total is their sum.\n",
        args.pipeline_runs
    );
    let names: Vec<&str> = scenes.iter().map(|(n, _)| n.as_str()).collect();
    println!("| stage | {} |", names.iter().map(|n| format!("{n}, ms")).collect::<Vec<_>>().join(" | "));
    println!("|---|{}", "---|".repeat(names.len()));
    println!(
        "| (load: flatten + BVH) | {} |",
        runs.iter().map(|(r, _)| format!("{:.1}", common::ms(r.build))).collect::<Vec<_>>().join(" | ")
    );
    let mut stages: Vec<&'static str> = Vec::new();
    for (r, _) in &runs {
        for (n, _) in &r.rendered.timings.0 {
            if !stages.contains(n) {
                stages.push(n);
            }
        }
    }
    let stage_ms = |r: &Rendered, n: &str| -> f64 {
        r.timings.0.iter().filter(|(m, _)| *m == n).map(|(_, t)| common::ms(*t)).sum()
    };
    for n in &stages {
        println!(
            "| {n} | {} |",
            runs.iter().map(|(r, _)| format!("{:.1}", stage_ms(&r.rendered, n))).collect::<Vec<_>>().join(" | ")
        );
    }
    let total = |r: &Rendered| -> Duration { r.timings.sequential_total() };
    println!(
        "| **total** | {} |",
        runs.iter().map(|(r, _)| format!("**{:.0}**", common::ms(total(&r.rendered)))).collect::<Vec<_>>().join(" | ")
    );
    println!(
        "| CPU, all threads (mean of the runs) | {} |",
        runs.iter()
            .map(|(r, _)| r.cpu.map(|c| format!("{:.0}", common::ms(c))).unwrap_or_else(|| "-".into()))
            .collect::<Vec<_>>()
            .join(" | ")
    );
    println!(
        "| next frame: saliency (memo) | {} |",
        runs.iter().map(|(_, n)| format!("{:.1}", stage_ms(&n.rendered, "saliency"))).collect::<Vec<_>>().join(" | ")
    );
    println!(
        "| next frame: total | {} |",
        runs.iter().map(|(_, n)| format!("{:.0}", common::ms(total(&n.rendered)))).collect::<Vec<_>>().join(" | ")
    );
    println!();
    for ((name, _), (r, _)) in scenes.iter().zip(&runs) {
        let m = &r.rendered.facets;
        let moved = m.ids.iter().filter(|&&id| r.rendered.aims.get(id as usize).is_some_and(|a| a.moved())).count();
        println!(
            "- {name}: {}; {} facets, {:.0}% of the pixels re-traced.",
            r.rendered.camera,
            m.used_facets(),
            100.0 * moved as f64 / m.ids.len() as f64
        );
    }
}

/// One timed render of the default pipeline.
struct DefaultRun {
    rendered: Rendered,
    /// Flattening and BVH of the freshly prepared scene.
    build: Duration,
    /// Mean CPU time per render (all threads).
    cpu: Option<Duration>,
}

/// The default settings (`analytic`) at `size` x `size`: the fastest of `runs` renders, each
/// from a freshly prepared `scene`, then the next frame rendered from the last prepared scene
/// (its meshes' saliency already in memory).
fn default_pipeline(scene: &Scene, size: u32, runs: usize) -> (DefaultRun, DefaultRun) {
    let mut s = Settings::default();
    (s.width, s.height) = (size, size);
    let mut best: Option<DefaultRun> = None;
    let mut last_prep = None;
    let c0 = common::cpu_time();
    for _ in 0..runs.max(1) {
        let prep = Prepared::new(scene.clone());
        let rendered = render(&prep, &s, &Progress::silent()).expect("default render");
        let total: Duration = rendered.timings.sequential_total();
        if best.as_ref().is_none_or(|b| total < b.rendered.timings.sequential_total()) {
            best = Some(DefaultRun { rendered, build: prep.build_time, cpu: None });
        }
        last_prep = Some(prep);
    }
    let cpu = common::cpu_time().zip(c0).map(|(a, b)| (a - b) / runs.max(1) as u32);
    let prep = last_prep.expect("at least one run");
    let next = render(&prep, &s, &Progress::silent()).expect("next frame");
    let mut best = best.expect("at least one run");
    best.cpu = cpu;
    (best, DefaultRun { rendered: next, build: Duration::ZERO, cpu: None })
}
