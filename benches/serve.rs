//! Issue 14's targets for `cubist serve`: how long a request takes when the session already
//! holds the previous request's outputs, at 1000x1000 on the built-in still life with the
//! default settings (preset `analytic`), each request changing one thing from the previous one
//! (so nothing is served from a cache the change should have invalidated).
//!
//! Measured in process on a `pipeline::Session`, the object the server keeps: the server adds
//! reading the request line and writing the output file (the PNG encode, measured apart; the
//! raw `.rgba` output the Blender viewport reads is a plain write to a temporary file, synced
//! and renamed). Each row: the median
//! (min-max) wall time of RUNS requests, and the CPU time they used (both cores count), which
//! holds up better than wall time on a shared machine; "limited by" names the steps that ran
//! and their share of the median request.
//!
//! `cargo bench --bench serve [-- --quick]`; `-- --only NAME [--runs N]` times only the rows
//! whose name starts with NAME (for profiling one kind of request), N requests each.

#[path = "common/mod.rs"]
mod common;

use std::time::{Duration, Instant};

use cubist::output::{write_atomic, write_png};
use cubist::pipeline::{Frame, PixelsKept, Session};
use cubist::progress::Progress;
use cubist::scene::Scene;
use cubist::settings::Settings;

const SIDE: u32 = 1000;

struct Row {
    what: &'static str,
    target_ms: f64,
    walls: Vec<f64>,
    cpu: Option<Duration>,
    /// The median run's steps.
    steps: Vec<(&'static str, Duration)>,
    reused: Vec<&'static str>,
    /// The median run's pixels kept and traced by the re-trace and the anti-aliasing.
    pixels: PixelsKept,
}

/// Runs `runs` requests, the i-th rendering `settings(i)`; the first request of the sequence
/// (`warm`) is not timed. None (nothing run) when `only` names other rows.
fn measure(
    only: &Option<String>,
    session: &mut Session,
    what: &'static str,
    target_ms: f64,
    runs: usize,
    warm: &Settings,
    settings: impl Fn(usize) -> Settings,
) -> Option<Row> {
    if only.as_ref().is_some_and(|o| !what.starts_with(o.as_str())) {
        return None;
    }
    session.render(warm, &Progress::silent()).unwrap();
    let mut frames: Vec<(f64, Frame)> = Vec::new();
    let c0 = common::cpu_time();
    for i in 0..runs {
        let s = settings(i);
        let t = Instant::now();
        let f = session.render(&s, &Progress::silent()).unwrap();
        frames.push((t.elapsed().as_secs_f64() * 1e3, f));
    }
    let cpu = common::cpu_time().zip(c0).map(|(a, b)| (a - b) / runs as u32);
    let mut walls: Vec<f64> = frames.iter().map(|(w, _)| *w).collect();
    walls.sort_by(f64::total_cmp);
    let median = walls[walls.len() / 2];
    let (_, f) = frames.iter().min_by(|a, b| (a.0 - median).abs().total_cmp(&(b.0 - median).abs())).unwrap();
    Some(Row {
        what,
        target_ms,
        walls,
        cpu,
        steps: f.timings.0.clone(),
        reused: f.reused.clone(),
        pixels: f.pixels_kept,
    })
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let quick = args.iter().any(|a| a == "--quick");
    let flag = |name: &str| args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).cloned();
    let only = flag("--only");
    let runs = flag("--runs").and_then(|n| n.parse().ok()).unwrap_or(if quick { 3 } else { 5 });
    let load_before = common::load_average();
    let full = Settings { width: SIDE, height: SIDE, ..Settings::default() };
    let quarter = Settings { width: SIDE / 4, height: SIDE / 4, ..Settings::default() };
    let paint =
        |s: &Settings, i: usize| Settings { border_width: if i.is_multiple_of(2) { 11.0 } else { 12.0 }, ..s.clone() };
    // The default faceting (Planes) makes its facets from `planes` and `plane_detail`: one
    // plane more or less redraws a few facets (most keep their pixels and aims, so most pixels
    // keep their re-trace and anti-aliasing); another detail redraws every facet. The Segment
    // faceting's `segments` are not read by Planes: the same facets come out.
    let facets = |s: &Settings, i: usize| Settings { planes: if i.is_multiple_of(2) { 151 } else { 150 }, ..s.clone() };
    let detail =
        |s: &Settings, i: usize| Settings { plane_detail: if i.is_multiple_of(2) { 5.5 } else { 5.0 }, ..s.clone() };
    let unread = |s: &Settings, i: usize| Settings {
        segments: if i.is_multiple_of(2) { vec![5, 31, 120] } else { vec![5, 30, 120] },
        ..s.clone()
    };
    let camera = |s: &Settings, i: usize| Settings {
        ambiguity: Some(if i.is_multiple_of(2) { 139.0 } else { 140.0 }),
        ..s.clone()
    };

    let mut session = Session::new();
    session.set_scene(Scene::default_scene());
    let mut rows = vec![
        // A session records the brushwork's strokes and where they paint on the second chain
        // over the same film and facets (src/paint/brushwork.rs, `StrokePlan`): that request
        // (the first paint-only change after a new film or layout) costs more than those after
        // it, which the next row times. One request.
        measure(
            &only,
            &mut session,
            "first paint-only change on new facets (records the strokes)",
            f64::NAN,
            1,
            &full,
            |_| paint(&full, 0),
        ),
        measure(&only, &mut session, "paint-only change (border width)", 50.0, runs, &full, |i| paint(&full, i)),
        measure(&only, &mut session, "facet change (plane count)", 300.0, runs, &full, |i| facets(&full, i)),
        // Issue 14's facet target holds for any facet change: another detail redraws every facet.
        measure(&only, &mut session, "facet change, every facet redrawn (plane detail)", 300.0, runs, &full, |i| {
            detail(&full, i)
        }),
        measure(
            &only,
            &mut session,
            "facet setting Planes does not read (Segment segments)",
            f64::NAN,
            runs,
            &full,
            |i| unread(&full, i),
        ),
        measure(&only, &mut session, "camera change (convergence angle)", 600.0, runs, &full, |i| camera(&full, i)),
        measure(&only, &mut session, "unchanged (F12 again), before encoding", 100.0, runs, &full, |_| full.clone()),
        measure(&only, &mut session, "1/4 preview (250x250), paint change", 100.0, runs, &quarter, |i| {
            paint(&quarter, i)
        }),
        measure(&only, &mut session, "1/4 preview (250x250), facet change", 100.0, runs, &quarter, |i| {
            facets(&quarter, i)
        }),
        measure(&only, &mut session, "1/4 preview (250x250), camera change", 100.0, runs, &quarter, |i| {
            camera(&quarter, i)
        }),
    ]
    .into_iter()
    .flatten()
    .collect::<Vec<_>>();
    if only.is_some() {
        print_rows(&rows, runs, &load_before);
        return;
    }
    // A changed scene (an object moved): the BVH and everything traced, saliency of no mesh.
    let mut moved = Scene::default_scene();
    let c0 = common::cpu_time();
    let mut walls = Vec::new();
    let mut last = None;
    for i in 0..runs {
        moved.objects[1].transform.w_axis.y += if i.is_multiple_of(2) { 0.01 } else { -0.01 };
        let t = Instant::now();
        session.set_scene(moved.clone());
        let f = session.render(&full, &Progress::silent()).unwrap();
        walls.push(t.elapsed().as_secs_f64() * 1e3);
        last = Some(f);
    }
    let cpu = common::cpu_time().zip(c0).map(|(a, b)| (a - b) / runs as u32);
    walls.sort_by(f64::total_cmp);
    let f = last.unwrap();
    rows.push(Row {
        what: "scene changed (an object moved)",
        target_ms: f64::NAN,
        walls,
        cpu,
        steps: f.timings.0.clone(),
        reused: f.reused.clone(),
        pixels: f.pixels_kept,
    });

    // Encoding the unchanged request's image to PNG, which the server then writes.
    let frame = session.render(&full, &Progress::silent()).unwrap();
    let dir = std::env::temp_dir().join(format!("cubist-bench-serve-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let mut png = Vec::new();
    let mut raw = Vec::new();
    for _ in 0..runs {
        let t = Instant::now();
        write_png(&dir.join("f12.png"), &frame.image).unwrap();
        png.push(t.elapsed().as_secs_f64() * 1e3);
        let t = Instant::now();
        // As the server writes it: a temporary file, synced, renamed (all or nothing).
        write_atomic(&dir.join("f12.rgba"), |tmp| std::fs::write(tmp, frame.image.as_raw()).map_err(|e| e.to_string()))
            .unwrap();
        raw.push(t.elapsed().as_secs_f64() * 1e3);
    }
    let _ = std::fs::remove_dir_all(&dir);
    png.sort_by(f64::total_cmp);
    raw.sort_by(f64::total_cmp);

    print_rows(&rows, runs, &load_before);
    println!();
    println!(
        "Writing the unchanged request's image: PNG (encode and write) {:.0} ms median ({:.0}-{:.0}); raw RGBA \
         (what the Blender viewport reads) {:.1} ms.",
        png[png.len() / 2],
        png[0],
        png[png.len() - 1],
        raw[raw.len() / 2]
    );
    for r in rows.iter().filter(|r| !r.target_ms.is_nan()) {
        let median = r.walls[r.walls.len() / 2];
        let what = format!("serve: {}", r.what);
        let cpu = r.cpu.map(|c| format!(", CPU {:.0} ms", common::ms(c))).unwrap_or_default();
        common::target(
            14,
            &what,
            &format!("<= {:.0} ms", r.target_ms),
            &format!("{median:.0} ms{cpu}"),
            Some(median <= r.target_ms),
        );
    }
}

/// The table of `rows`.
fn print_rows(rows: &[Row], runs: usize, load_before: &str) {
    println!(
        "Requests to one session, {SIDE}x{SIDE}, built-in still life, default settings, {runs} requests each \
     (load average before: {load_before}; after: {}). Wall: median (min-max) ms; CPU: ms per request, \
     both cores counted.",
        common::load_average()
    );
    println!();
    println!("| request | wall ms | CPU ms | target | steps run (share of the median request) | kept |");
    println!("|---|---|---|---|---|---|");
    for r in rows {
        let median = r.walls[r.walls.len() / 2];
        let total: f64 = r.steps.iter().map(|(_, d)| d.as_secs_f64()).sum::<f64>().max(1e-9);
        let mut steps: Vec<_> = r.steps.iter().collect();
        steps.sort_by_key(|s| std::cmp::Reverse(s.1));
        let steps: Vec<String> = steps
            .iter()
            .filter(|(_, d)| d.as_secs_f64() / total > 0.02)
            .map(|(n, d)| format!("{n} {:.0}%", d.as_secs_f64() / total * 100.0))
            .collect();
        let target = if r.target_ms.is_nan() { "-".into() } else { format!("{:.0} ms", r.target_ms) };
        let cpu = r.cpu.map(|c| format!("{:.0}", common::ms(c))).unwrap_or_else(|| "-".into());
        println!(
            "| {} | {:.0} ({:.0}-{:.0}) | {cpu} | {target} | {} | {} |",
            r.what,
            median,
            r.walls[0],
            r.walls[r.walls.len() - 1],
            if steps.is_empty() { "nothing".into() } else { steps.join(", ") },
            r.reused.join(", ")
        );
        let p = r.pixels;
        if p.retrace_kept + p.retrace_traced + p.antialiasing_kept + p.antialiasing_traced > 0 {
            println!(
                "|  | pixels kept/traced: re-trace {}/{}, anti-aliasing {}/{} | | | | |",
                p.retrace_kept, p.retrace_traced, p.antialiasing_kept, p.antialiasing_traced
            );
        }
    }
}
