//! Facet and imprecision stages, timed and measured (`cargo bench --bench facet_stages`).
//!
//! Table 1: total render time at 1000 x 1000 on venus_11k for each faceting method, split by
//! stage (pre-render, saliency, faceting, imprecision, re-trace), so each stage's cost shows.
//! Tables 2-3: on bunny_2k and venus_11k, the mean colour difference across facet borders
//! against discontinuity (User Study I's measurable side), and the mean saliency of the final
//! image's hit points for saliency / random / no re-aiming.
//!
//! Saliency: when the pipeline computed none (the mesh saliency stage is not in this build), a
//! synthetic saliency stands in, a bump of radius 0.5 (render units, scene radius ~1) around
//! the model's highest point (the head); the tables say which was used.
//!
//! Needs ../shared/models; prints a message and exits cleanly without it.
//! Options (after `--`): `--size N` (default 1000), `--quick` (one repetition, smaller figures).

use std::path::{Path, PathBuf};
use std::time::Duration;

use cubist::frame::Frame;
use cubist::pipeline::{Prepared, Rendered, render_with};
use cubist::progress::Progress;
use cubist::settings::{Faceting, Imprecision, Settings};
use glam::Vec3;

fn models() -> Option<PathBuf> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/models");
    dir.is_dir().then_some(dir)
}

fn hit_point(prep: &Prepared, tri: u32, u: f32, v: f32) -> Vec3 {
    let p = prep.world.positions[tri as usize];
    p[0] * (1.0 - u - v) + p[1] * u + p[2] * v
}

/// The synthetic saliency: 1 at the model's highest vertex falling to 0 at distance 0.5.
fn head_bump(prep: &Prepared) -> impl Fn(Vec3) -> f32 + Sync + '_ {
    let top = prep
        .world
        .positions
        .iter()
        .flatten()
        .fold(Vec3::splat(f32::NEG_INFINITY), |a, p| if p.y > a.y { *p } else { a });
    move |p: Vec3| (1.0 - (p - top).length_squared() / 0.25).max(0.0)
}

fn synthetic_map(prep: &Prepared, frame: &Frame, s: &dyn Fn(Vec3) -> f32) -> Vec<f32> {
    (0..frame.pixel_count())
        .map(|i| {
            let smp = frame.pixel_samples(i);
            smp.iter().filter(|h| h.is_hit()).map(|h| s(hit_point(prep, h.tri, h.u, h.v))).sum::<f32>()
                / smp.len() as f32
        })
        .collect()
}

/// Renders, filling in the synthetic saliency when the pipeline computed none; says which.
fn render(prep: &Prepared, s: &Settings) -> (Rendered, bool) {
    let bump = head_bump(prep);
    let synthetic = std::sync::atomic::AtomicBool::new(false);
    let r = render_with(prep, s, &Progress::silent(), &|p, f| {
        if f.saliency.is_none() && s.faceting != Faceting::None {
            f.saliency = Some(synthetic_map(p, f, &bump));
            synthetic.store(true, std::sync::atomic::Ordering::Relaxed);
        }
    })
    .expect("render");
    (r, synthetic.into_inner())
}

fn stage(r: &Rendered, name: &str) -> Duration {
    r.timings.0.iter().filter(|(n, _)| *n == name).map(|(_, t)| *t).sum()
}

fn ms(d: Duration) -> String {
    format!("{:.0}", d.as_secs_f64() * 1e3)
}

fn border_difference(r: &Rendered) -> f64 {
    let m = r.facets.as_ref().unwrap();
    let (w, h) = (m.width as usize, m.height as usize);
    let (mut sum, mut n) = (0.0, 0usize);
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            for j in [(x + 1 < w).then(|| i + 1), (y + 1 < h).then(|| i + w)].into_iter().flatten() {
                if m.ids[i] != m.ids[j] {
                    let d = (r.frame.color[i] - r.frame.color[j]).truncate().abs();
                    sum += (d.x + d.y + d.z) as f64;
                    n += 1;
                }
            }
        }
    }
    sum / n.max(1) as f64
}

fn mean_hit_saliency(prep: &Prepared, r: &Rendered) -> f64 {
    let s = head_bump(prep);
    let (mut sum, mut n) = (0.0, 0usize);
    for h in r.frame.samples.iter().filter(|h| h.is_hit()) {
        sum += s(hit_point(prep, h.tri, h.u, h.v)) as f64;
        n += 1;
    }
    sum / n.max(1) as f64
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let size: u32 = args.iter().position(|a| a == "--size").and_then(|i| args.get(i + 1)?.parse().ok()).unwrap_or(1000);
    let quick = args.iter().any(|a| a == "--quick");
    let Some(dir) = models() else {
        println!("facet_stages: ../shared/models not found; skipped");
        return;
    };
    let tmp = std::env::temp_dir().join(format!("cubist-facet-bench-{}", std::process::id()));
    std::fs::create_dir_all(&tmp).unwrap();
    // A constant facet map: 12 x 9 flat rectangles, jittered, as a painter's tracing might be.
    let map_path = tmp.join("map.png");
    image::RgbImage::from_fn(240, 180, |x, y| {
        let (cx, cy) = ((x + (y * 7) % 13) / 20, (y + (x * 5) % 11) / 20);
        image::Rgb([cx as u8 * 20, cy as u8 * 25, 77])
    })
    .save(&map_path)
    .unwrap();

    let venus = Prepared::load(Some(&dir.join("venus_11k.glb"))).expect("venus_11k.glb");
    println!("## Stage times, venus_11k, {size}x{size}, spp 4, discontinuity 100, imprecision saliency (ms)\n");
    println!("| faceting | facets | moved px | pre-render | saliency | faceting | imprecision | re-trace | total |");
    println!("|---|---|---|---|---|---|---|---|---|");
    let mut synthetic_used = false;
    for faceting in [Faceting::None, Faceting::Constant, Faceting::Voronoi, Faceting::Patch] {
        let mut s = Settings::preset(cubist::settings::Preset::Plain);
        (s.width, s.height, s.spp) = (size, size, 4);
        s.faceting = faceting;
        s.facet_map = Some(map_path.clone());
        s.discontinuity = 100.0;
        let reps = if quick { 1 } else { 3 };
        // The fastest of `reps` runs, stage by stage (the machine is shared).
        let mut best: Option<Rendered> = None;
        for _ in 0..reps {
            let (r, synthetic) = render(&venus, &s);
            synthetic_used |= synthetic;
            let total = |r: &Rendered| r.timings.0.iter().map(|(_, t)| *t).sum::<Duration>();
            if best.as_ref().is_none_or(|b| total(&r) < total(b)) {
                best = Some(r);
            }
        }
        let r = best.unwrap();
        let m = r.facets.as_ref().unwrap();
        let moved = m.ids.iter().filter(|&&id| r.aims.get(id as usize).is_some_and(|a| a.moved())).count();
        let total: Duration = r.timings.0.iter().map(|(_, t)| *t).sum();
        println!(
            "| {faceting} | {} | {moved} | {} | {} | {} | {} | {} | {} |",
            m.used_facets(),
            ms(stage(&r, "pre-render")),
            ms(stage(&r, "saliency")),
            ms(stage(&r, "faceting")),
            ms(stage(&r, "imprecision")),
            ms(stage(&r, "re-trace")),
            ms(total)
        );
    }
    println!("\n(load + BVH of venus_11k: {} ms, not included)", ms(venus.build_time));

    let fig = if quick { 300 } else { 500 };
    let bunny = Prepared::load(Some(&dir.join("bunny_2k.glb"))).expect("bunny_2k.glb");
    println!("\n## Border colour difference vs discontinuity ({fig}x{fig}, spp 4, voronoi 150)\n");
    println!("| model | imprecision | 0 | 50 | 100 | 200 | 400 |");
    println!("|---|---|---|---|---|---|---|");
    for (name, prep) in [("bunny_2k", &bunny), ("venus_11k", &venus)] {
        for imprecision in [Imprecision::Saliency, Imprecision::Random] {
            let row: Vec<String> = [0.0, 50.0, 100.0, 200.0, 400.0]
                .iter()
                .map(|&d| {
                    let mut s = Settings::preset(cubist::settings::Preset::Plain);
                    (s.width, s.height, s.spp) = (fig, fig, 4);
                    s.faceting = Faceting::Voronoi;
                    s.imprecision = imprecision;
                    s.discontinuity = d;
                    let (r, synthetic) = render(prep, &s);
                    synthetic_used |= synthetic;
                    format!("{:.4}", border_difference(&r))
                })
                .collect();
            println!("| {name} | {imprecision} | {} |", row.join(" | "));
        }
    }
    println!("\n## Mean saliency of the final image's hit points ({fig}x{fig}, voronoi 150, discontinuity 100)\n");
    println!("| model | saliency | random | none |");
    println!("|---|---|---|---|");
    for (name, prep) in [("bunny_2k", &bunny), ("venus_11k", &venus)] {
        let row: Vec<String> = [Imprecision::Saliency, Imprecision::Random, Imprecision::None]
            .iter()
            .map(|&imprecision| {
                let mut s = Settings::preset(cubist::settings::Preset::Plain);
                (s.width, s.height, s.spp) = (fig, fig, 4);
                s.faceting = Faceting::Voronoi;
                s.imprecision = imprecision;
                s.discontinuity = 100.0;
                let (r, synthetic) = render(prep, &s);
                synthetic_used |= synthetic;
                format!("{:.4}", mean_hit_saliency(prep, &r))
            })
            .collect();
        println!("| {name} | {} |", row.join(" | "));
    }
    println!(
        "\nSaliency: {}",
        if synthetic_used {
            "SYNTHETIC (a bump around the model's highest point; no mesh saliency stage in this build)"
        } else {
            "mesh saliency computed by the pipeline"
        }
    );
    let _ = std::fs::remove_dir_all(&tmp);
}
