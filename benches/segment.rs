//! Segment faceting, timed and measured (`cargo bench --bench segment`).
//!
//! Table 1: the whole Segment faceting (features, superpixels, region graph, eigenvectors, each
//! level's cut, selection and quads) of a 1000 x 1000 pre-render of the still life and of
//! venus_11k, split by step: the median of `--reps` runs, wall-clock, on the default rayon
//! pool and on one thread, with the process CPU time per run and the load average (this
//! machine's 2 cores are shared, so wall time under load overstates the cost; CPU time does
//! not).
//!
//! Table 2: time against quality. For a range of superpixel counts, each level's boundary
//! agreement with a fine reference (the same method with 8000 superpixels), where boundary
//! agreement is `facets::segment::quality::boundary_f_measure` with a 2-pixel tolerance: the
//! F-measure of boundary precision and recall, a boundary pixel counting as matched when a
//! boundary pixel of the other segmentation lies within 2 px (Euclidean). The last row, the
//! reference against itself with another seed, is the ceiling: how far two equally good
//! normalized cuts already differ.
//!
//! Saliency: the pipeline's mesh saliency map of the pre-render (as `cubist render` computes it).
//!
//! The still life needs nothing; venus needs ../shared/models (skipped with a message without).
//! Options (after `--`): `--size N` (default 1000), `--reps R` (default 5), `--quick` (2 reps,
//! fewer superpixel counts), `--timing` (table 1 only).

#[path = "common/mod.rs"]
mod common;

use std::path::{Path, PathBuf};
use std::time::Instant;

use cubist::facets::segment::{self, SegmentLevels, SegmentParams, quality::boundary_f_measure};
use cubist::film::Film;
use cubist::pipeline::{Prepared, StageParams, Timings, faceting_input};
use cubist::progress::Progress;
use cubist::settings::Settings;

fn models() -> Option<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/models");
    dir.is_dir().then_some(dir)
}

/// The pre-render the Segment faceting sees, with the pipeline's saliency map.
fn prerender(prep: &Prepared, settings: &Settings) -> Film {
    let params = StageParams::new(settings);
    let pre = faceting_input(prep, &params, &Progress::silent(), &mut Timings::default()).expect("pre-render");
    assert!(pre.film.saliency.is_some(), "the pre-render computes the saliency map");
    pre.film
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Runs the faceting `reps` times: (median step times in ms, median total ms, CPU ms per run, last levels).
fn time_layout(film: &Film, s: &SegmentParams, reps: usize) -> (Vec<(String, f64)>, f64, Option<f64>, SegmentLevels) {
    let mut steps: Vec<(String, Vec<f64>)> = Vec::new();
    let mut totals = Vec::new();
    let mut last = None;
    let c0 = common::cpu_time();
    for _ in 0..reps {
        let t = Instant::now();
        let (_, levels) = segment::layout(film, s).expect("layout");
        totals.push(t.elapsed().as_secs_f64() * 1e3);
        if steps.is_empty() {
            steps = levels.timings.iter().map(|(n, _)| (n.clone(), Vec::new())).collect();
        }
        for (i, (_, d)) in levels.timings.iter().enumerate() {
            steps[i].1.push(d.as_secs_f64() * 1e3);
        }
        last = Some(levels);
    }
    let cpu = common::cpu_time().zip(c0).map(|(a, b)| common::ms(a - b) / reps as f64);
    (steps.into_iter().map(|(n, v)| (n, median(v))).collect(), median(totals), cpu, last.expect("reps > 0"))
}

fn one_thread<T: Send>(f: impl FnOnce() -> T + Send) -> T {
    rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("pool").install(f)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let arg = |name: &str| -> Option<u32> {
        args.iter().position(|a| a == name).and_then(|i| args.get(i + 1)).and_then(|v| v.parse().ok())
    };
    let quick = args.iter().any(|a| a == "--quick");
    let timing_only = args.iter().any(|a| a == "--timing");
    let size = arg("--size").unwrap_or(1000);
    let reps = arg("--reps").unwrap_or(if quick { 2 } else { 5 }) as usize;

    let mut scenes: Vec<(String, Option<PathBuf>)> = vec![("still life".into(), None)];
    match models() {
        Some(dir) => scenes.push(("venus_11k".into(), Some(dir.join("venus_11k.glb")))),
        None => println!("../shared/models not found: venus_11k skipped"),
    }
    let mut settings = Settings::default();
    (settings.width, settings.height) = (size, size);
    let params = StageParams::new(&settings).facets.segment;

    let mut frames = Vec::new();
    for (name, path) in &scenes {
        let prep = Prepared::load(path.as_deref()).expect("scene");
        frames.push((name.clone(), prerender(&prep, &settings)));
    }

    println!(
        "\n### Segment faceting at {size} x {size}, segments {:?}, thresholds {:?} (median of {reps}, ms)\n",
        settings.segments, settings.thresholds
    );
    println!("rayon threads: {}, load average before: {}\n", rayon::current_num_threads(), common::load_average());
    let mut header = false;
    let mut worst_wall: f64 = 0.0;
    for (name, film) in &frames {
        for threads in [0usize, 1] {
            let (steps, total, cpu, levels) = if threads == 1 {
                one_thread(|| time_layout(film, &params, reps))
            } else {
                time_layout(film, &params, reps)
            };
            if !header {
                let names: Vec<&str> = steps.iter().map(|(n, _)| n.as_str()).collect();
                println!("| scene | threads | superpixels | {} | total (wall) | CPU per run |", names.join(" | "));
                println!("|---|---|---|{}---|---|", "---|".repeat(names.len()));
                header = true;
            }
            let cells: Vec<String> = steps.iter().map(|(_, t)| format!("{t:.1}")).collect();
            if threads == 0 {
                worst_wall = worst_wall.max(total);
            }
            println!(
                "| {name} | {} | {} | {} | **{total:.0}** | {} |",
                if threads == 1 { "1".to_string() } else { rayon::current_num_threads().to_string() },
                levels.superpixel_count,
                cells.join(" | "),
                cpu.map(|c| format!("{c:.0}")).unwrap_or_else(|| "-".into()),
            );
        }
    }
    println!("\nload average after: {}", common::load_average());
    common::target(
        5,
        &format!(
            "whole Segment faceting at {size} x {size} on {} threads (median wall, worst scene)",
            rayon::current_num_threads()
        ),
        "< 0.5 s on 2 cores",
        &format!("{:.3} s", worst_wall / 1e3),
        Some(worst_wall < 500.0),
    );
    for (name, film) in &frames {
        let (_, levels) = segment::layout(film, &params).expect("layout");
        let sel: Vec<String> = levels
            .levels
            .iter()
            .map(|l| {
                format!(
                    "N={}: {} segments, {} selected",
                    l.requested,
                    l.count,
                    l.selected.iter().filter(|s| **s).count()
                )
            })
            .collect();
        println!("{name}: {}", sel.join("; "));
    }

    if timing_only {
        return;
    }
    println!("\n### Superpixel count against boundary agreement with a fine reference (8000 superpixels)\n");
    println!("F = boundary F-measure, 2 px tolerance, per level; time = whole faceting, median of {reps}, ms.\n");
    println!(
        "| scene | superpixels asked | made | time (ms) | F level 1 (N=5) | F level 2 (N=30) | F level 3 (N=120) |"
    );
    println!("|---|---|---|---|---|---|---|");
    let counts: &[u32] = if quick { &[500, 1667, 4000] } else { &[250, 500, 1000, 1667, 2500, 4000] };
    for (name, film) in &frames {
        let mut fine = params.clone();
        fine.superpixels = 8000;
        let t = Instant::now();
        let (_, reference) = segment::layout(film, &fine).expect("reference");
        let ref_ms = t.elapsed().as_secs_f64() * 1e3;
        let agreement = |levels: &SegmentLevels| -> Vec<String> {
            levels
                .levels
                .iter()
                .zip(&reference.levels)
                .map(|(a, b)| format!("{:.3}", boundary_f_measure(&a.labels, &b.labels, 2).unwrap_or(f64::NAN)))
                .collect()
        };
        for &count in counts {
            let mut s = params.clone();
            s.superpixels = count;
            let (_, total, _, levels) = time_layout(film, &s, reps.min(3));
            let auto = if count as usize == segment::auto_superpixels(size, size, 120) { " (auto)" } else { "" };
            println!(
                "| {name} | {count}{auto} | {} | {total:.0} | {} |",
                levels.superpixel_count,
                agreement(&levels).join(" | ")
            );
        }
        let mut other = fine.clone();
        other.seed = 1;
        let (_, reseeded) = segment::layout(film, &other).expect("reference, seed 1");
        println!(
            "| {name} | 8000, seed 1 (ceiling) | {} | {ref_ms:.0} (seed 0) | {} |",
            reseeded.superpixel_count,
            agreement(&reseeded).join(" | ")
        );
    }
}
