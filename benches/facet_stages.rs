//! Facets and spatial imprecision, timed and measured through the real pipeline:
//! mesh saliency as `cubist render` computes it (`cargo bench --bench facet_stages`).
//!
//! Table 1: each faceting method's stages at `--size` (1000) on venus_11k: the `analytic`
//! preset with that faceting (spp 4, discontinuity 200, saliency imprecision, painterly
//! effects), the fastest of 3 renders, each from a freshly prepared scene so mesh saliency is
//! computed every time.
//! Table 2: discontinuity 0 / 50 / 100 / 200 (pixels at 1000 px) against the mean colour
//! difference across facet borders of the final image, for Segment and Voronoi facets; the
//! painterly effects are off so the difference is the re-aimed views' alone.
//! Table 3: mean saliency of the final image's hit points (every sample that hit geometry,
//! its mesh saliency interpolated at the hit) for saliency / random / no re-aiming, Segment
//! (and Voronoi) facets, discontinuity 200, several seeds (each seed changes sampling, facets
//! and random aims).
//! Table 4: ambiguity against visible faces (distinct triangles among the final image's
//! samples, Table 4.1's measure), facets off and on (Segment, discontinuity 200, mean of the
//! seeds).
//!
//! Scenes: bunny_2k and venus_11k (from ../shared/models, skipped with a message when absent)
//! and the built-in still life. Options (after `--`): `--size N` (default 1000), `--quick`
//! (one run per timing, fewer seeds, spp 1 in table 2, Segment only in tables 2-3, 500 px in
//! table 4).

#[path = "common/mod.rs"]
mod common;

use std::time::Duration;

use cubist::eval::count_visible;
use cubist::film::Film;
use cubist::pipeline::{Prepared, Rendered, render, visible_faces};
use cubist::progress::Progress;
use cubist::saliency::{MeshSaliency, SaliencyMethod, cached_mesh_saliency};
use cubist::scene::Scene;
use cubist::settings::{Faceting, Imprecision, Palette, Settings};

/// The default (`analytic`) settings without painterly effects: the rendered colours, facets
/// and re-aims of the default pipeline.
fn unpainted(size: u32) -> Settings {
    let mut s = Settings::default();
    (s.width, s.height) = (size, size);
    (s.border_width, s.silhouette_width, s.gradients, s.chiaroscuro, s.colors) = (0.0, 0.0, 0.0, 0.0, 0);
    s.palette = Palette::None;
    s
}

fn stage(r: &Rendered, name: &str) -> Duration {
    r.timings.0.iter().filter(|(n, _)| *n == name).map(|(_, t)| *t).sum()
}

fn total(r: &Rendered) -> Duration {
    r.timings.0.iter().map(|(_, t)| *t).sum()
}

/// Mean absolute difference (8-bit sRGB, per channel) between 4-neighbours of the final image
/// that lie in different facets, and between those in the same facet; only pairs where at least
/// one pixel shows geometry count (the background is the same colour in every facet).
fn neighbour_differences(r: &Rendered) -> (f64, f64) {
    let m = &r.facets;
    let (w, h) = (m.width as usize, m.height as usize);
    let img = r.image.as_raw();
    let covered = |i: usize| r.film.color[i].w > 0.0;
    let (mut across, mut within) = ((0.0, 0u64), (0.0, 0u64));
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            for j in [(x + 1 < w).then(|| i + 1), (y + 1 < h).then(|| i + w)].into_iter().flatten() {
                if !covered(i) && !covered(j) {
                    continue;
                }
                let d: f64 = (0..3).map(|c| (img[4 * i + c] as f64 - img[4 * j + c] as f64).abs()).sum::<f64>() / 3.0;
                let acc = if m.ids[i] != m.ids[j] { &mut across } else { &mut within };
                acc.0 += d;
                acc.1 += 1;
            }
        }
    }
    (across.0 / across.1.max(1) as f64, within.0 / within.1.max(1) as f64)
}

/// Every mesh's saliency (computed once per prepared scene, then from its memo).
fn all_mesh_saliency(prep: &Prepared) -> MeshSaliency {
    let per_mesh = prep
        .scene
        .meshes
        .iter()
        .map(|m| Some(cached_mesh_saliency(m, SaliencyMethod::Auto, Some(&prep.saliency), None).expect("saliency")))
        .collect();
    MeshSaliency::new(&prep.scene, per_mesh)
}

/// Mean mesh saliency at the frame's hit points (every sample that hit), interpolated from the
/// hit triangle's corners by the barycentrics, as the saliency map does.
fn mean_hit_saliency(prep: &Prepared, sal: &MeshSaliency, film: &Film) -> f64 {
    let (mut sum, mut n) = (0.0f64, 0u64);
    for s in film.samples.iter().filter(|s| s.is_hit()) {
        let (o, local) = prep.world.local_triangle(s.tri);
        let mesh = prep.world.objects[o as usize].mesh;
        let c = sal.corners[mesh].as_ref().expect("every mesh computed")[local as usize];
        sum += ((1.0 - s.u - s.v) * c[0] + s.u * c[1] + s.v * c[2]) as f64;
        n += 1;
    }
    sum / n.max(1) as f64
}

fn is_increasing(v: &[f64]) -> bool {
    v.windows(2).all(|p| p[1] > p[0])
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let size: u32 = args.iter().position(|a| a == "--size").and_then(|i| args.get(i + 1)?.parse().ok()).unwrap_or(1000);
    let quick = args.iter().any(|a| a == "--quick");
    let tmp = std::env::temp_dir().join(format!("cubist-facet-bench-{}", std::process::id()));
    std::fs::create_dir_all(&tmp).unwrap();

    let mut scenes: Vec<(String, Scene)> = Vec::new();
    for name in ["bunny_2k", "venus_11k"] {
        match common::model(name) {
            Some(p) => scenes.push((name.into(), Scene::load(&p).expect("model"))),
            None => println!("{name}: ../shared/models/{name}.glb not found, skipped\n"),
        }
    }
    scenes.push(("still life".into(), Scene::default_scene()));
    println!(
        "rayon threads: {}; load average before: {}; saliency: the pipeline's mesh saliency (SaliencyMethod::Auto)\n",
        rayon::current_num_threads(),
        common::load_average()
    );

    // ---- Table 1: stages of each faceting method.
    if let Some((_, venus)) = scenes.iter().find(|(n, _)| n == "venus_11k") {
        // A constant facet map: 12 x 9 jittered rectangles, as a painter's tracing might be.
        let map_path = tmp.join("map.png");
        image::RgbImage::from_fn(240, 180, |x, y| {
            let (cx, cy) = ((x + (y * 7) % 13) / 20, (y + (x * 5) % 11) / 20);
            image::Rgb([cx as u8 * 20, cy as u8 * 25, 77])
        })
        .save(&map_path)
        .unwrap();
        let runs = if quick { 1 } else { 3 };
        println!(
            "### Stages of each faceting method: venus_11k, {size} x {size}, preset `analytic` (spp 4, discontinuity 200, imprecision saliency, painterly effects), ms\n"
        );
        println!(
            "Fastest of {runs} renders by total, each from a freshly prepared scene (mesh saliency computed every time); CPU = mean per render, all threads.\n"
        );
        println!(
            "| faceting | facets | pixels re-traced | pre-render | saliency | faceting | imprecision | re-trace | paint | encode | total | CPU |"
        );
        println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
        for faceting in [
            Faceting::None,
            Faceting::Constant,
            Faceting::Voronoi,
            Faceting::Patch,
            Faceting::Segment,
            Faceting::Planes,
        ] {
            let mut s = Settings::default();
            (s.width, s.height) = (size, size);
            s.faceting = faceting;
            s.facet_map = Some(map_path.clone());
            let mut best: Option<Rendered> = None;
            let c0 = common::cpu_time();
            for _ in 0..runs {
                let prep = Prepared::new(venus.clone());
                let r = render(&prep, &s, &Progress::silent()).expect("render");
                if best.as_ref().is_none_or(|b| total(&r) < total(b)) {
                    best = Some(r);
                }
            }
            let cpu = common::cpu_time().zip(c0).map(|(a, b)| (a - b) / runs as u32);
            let r = best.unwrap();
            let m = &r.facets;
            let moved = m.ids.iter().filter(|&&id| r.aims.get(id as usize).is_some_and(|a| a.moved())).count();
            let f = |name: &str| format!("{:.0}", common::ms(stage(&r, name)));
            println!(
                "| {faceting} | {} | {:.0}% | {} | {} | {} | {} | {} | {} | {} | **{:.0}** | {} |",
                m.used_facets(),
                100.0 * moved as f64 / m.ids.len() as f64,
                f("pre-render"),
                f("saliency"),
                f("faceting"),
                f("imprecision"),
                f("re-trace"),
                f("paint"),
                f("encode"),
                common::ms(total(&r)),
                cpu.map(|c| format!("{:.0}", common::ms(c))).unwrap_or_else(|| "-".into())
            );
        }
        println!(
            "\n(`none`: no facets, so no saliency, imprecision or re-trace; paint without facet borders. Loading and BVH not included.)\n"
        );
    } else {
        println!("(venus_11k absent: no stage table)\n");
    }

    let preps: Vec<(String, Prepared)> = scenes.iter().map(|(n, s)| (n.clone(), Prepared::new(s.clone()))).collect();

    // ---- Table 2: discontinuity against border colour difference.
    let discs = [0.0, 50.0, 100.0, 200.0];
    let spp2 = if quick { 1 } else { 4 };
    let facetings: &[Faceting] = if quick { &[Faceting::Segment] } else { &[Faceting::Segment, Faceting::Voronoi] };
    let mut rows: Vec<(Faceting, Imprecision)> = facetings.iter().map(|&f| (f, Imprecision::Saliency)).collect();
    if !quick {
        rows.push((Faceting::Segment, Imprecision::Random));
    }
    println!(
        "### Discontinuity against the colour difference across facet borders ({size} x {size}, spp {spp2}, no painterly effects)\n"
    );
    println!(
        "Mean absolute difference of 4-neighbour pixels in different facets (8-bit sRGB, per channel; pairs showing only background left out); in brackets, that over the mean difference of neighbours within a facet of the same image. Discontinuity in pixels at 1000 px.\n"
    );
    println!("| scene | faceting | imprecision | facets | 0 | 50 | 100 | 200 |");
    println!("|---|---|---|---|---|---|---|---|");
    let (mut rising, mut rows_done, mut first_step) = (0, 0, f64::INFINITY);
    for (name, prep) in &preps {
        for &(faceting, imprecision) in &rows {
            let mut cells = Vec::new();
            let mut values = Vec::new();
            let mut facets = 0;
            for &d in &discs {
                let mut s = unpainted(size);
                s.spp = spp2;
                s.faceting = faceting;
                s.imprecision = imprecision;
                s.discontinuity = d;
                let r = render(prep, &s, &Progress::silent()).expect("render");
                let (across, within) = neighbour_differences(&r);
                facets = r.facets.used_facets();
                values.push(across);
                cells.push(format!("{across:.2} ({:.1}x)", across / within.max(1e-9)));
            }
            rows_done += 1;
            rising += values.windows(2).all(|p| p[1] >= p[0] * 0.99) as usize;
            first_step = first_step.min(values[1] / values[0].max(1e-9));
            println!("| {name} | {faceting} | {imprecision} | {facets} | {} |", cells.join(" | "));
        }
    }
    println!(
        "\nAt discontinuity 0 converging facets are the unfaceted picture. With saliency imprecision a facet stops moving once its saliency centre is within reach (and, with the spherical camera, an aim point on the background is the facet's own focal point: no turn), so the difference levels off; where neighbouring facets are drawn to the same salient point, they come to show similar views and it can fall."
    );
    common::target(
        4,
        "discontinuity 0 -> 50 -> 100 -> 200: mean colour difference across facet borders rises",
        "rises (never falls by more than 1%)",
        &format!("0 -> 50: x{first_step:.1} or more in every row; never falls in {rising} of {rows_done} rows"),
        Some(rising == rows_done),
    );

    // ---- Table 3: saliency > random > none.
    let seeds: Vec<u64> = if quick { vec![0, 1] } else { vec![0, 1, 2] };
    println!(
        "\n### Mean saliency of the final image's hit points ({size} x {size}, spp 1, discontinuity 200, seeds {seeds:?})\n"
    );
    println!(
        "Mean over the seeds, [min, max] in brackets; last columns: in how many seeds saliency > random, saliency > none and random > none. Segment is the default faceting; Voronoi (150 convex facets) for comparison.\n"
    );
    println!("| scene | faceting | saliency | random | none | sal > random | sal > none | random > none |");
    println!("|---|---|---|---|---|---|---|---|");
    let (mut above_random, mut above_none, mut cases) = (0, 0, 0);
    for (name, prep) in &preps {
        let sal = all_mesh_saliency(prep);
        for &faceting in facetings {
            let modes = [Imprecision::Saliency, Imprecision::Random, Imprecision::None];
            let mut per_mode: Vec<Vec<f64>> = vec![Vec::new(); modes.len()];
            for &seed in &seeds {
                for (k, &mode) in modes.iter().enumerate() {
                    let mut s = unpainted(size);
                    s.spp = 1;
                    s.seed = seed;
                    s.faceting = faceting;
                    s.imprecision = mode;
                    let r = render(prep, &s, &Progress::silent()).expect("render");
                    per_mode[k].push(mean_hit_saliency(prep, &sal, &r.film));
                }
            }
            let wins = |a: usize, b: usize| (0..seeds.len()).filter(|&i| per_mode[a][i] > per_mode[b][i]).count();
            let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
            cases += 1;
            above_random += (mean(&per_mode[0]) > mean(&per_mode[1])) as usize;
            above_none += (mean(&per_mode[0]) > mean(&per_mode[2])) as usize;
            let cell = |v: &[f64]| {
                let (lo, hi) = v.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| (a.min(*x), b.max(*x)));
                format!("{:.4} [{lo:.4}, {hi:.4}]", v.iter().sum::<f64>() / v.len() as f64)
            };
            let n = seeds.len();
            println!(
                "| {name} | {faceting} | {} | {} | {} | {} of {n} | {} of {n} | {} of {n} |",
                cell(&per_mode[0]),
                cell(&per_mode[1]),
                cell(&per_mode[2]),
                wins(0, 1),
                wins(0, 2),
                wins(1, 2)
            );
        }
    }
    common::target(
        4,
        "mean saliency of the final image's hit points: saliency > random > none",
        "saliency above both, mean of the seeds",
        &format!(
            "above random in {above_random} of {cases} scene x faceting rows, above none in {above_none} of {cases}"
        ),
        Some(above_random == cases && above_none == cases),
    );

    // ---- Table 4: ambiguity against visible faces.
    let size4 = if quick { size.min(500) } else { size };
    let angles = [60.0, 90.0, 120.0, 150.0, 180.0];
    println!(
        "\n### Ambiguity against visible faces ({size4} x {size4}, spp 1, default camera; facets on: Segment, discontinuity 200, imprecision saliency, mean of seeds {seeds:?})\n"
    );
    println!(
        "Distinct triangles among the final image's samples, percent of the scene's; facets off = the plain cubist view (the same for every seed at spp 1).\n"
    );
    println!(
        "| scene | camera | facets | {} |",
        angles.iter().map(|a| format!("{a} deg")).collect::<Vec<_>>().join(" | ")
    );
    println!("|---|---|---|{}", "---|".repeat(angles.len()));
    let (mut rises_on, mut rises_off) = (Vec::new(), Vec::new());
    for (name, prep) in &preps {
        let total_faces = prep.world.triangle_count();
        let mut camera = String::new();
        let (mut off, mut on) = (Vec::new(), Vec::new());
        for &a in &angles {
            let mut s = unpainted(size4);
            s.spp = 1;
            s.ambiguity = Some(a);
            let mut sum = 0.0;
            for &seed in &seeds {
                s.seed = seed;
                let r = render(prep, &s, &Progress::silent()).expect("render");
                camera = r.camera.split(',').next().unwrap_or("").replace(" camera", "");
                sum += count_visible(&r.film, total_faces).visible as f64;
            }
            on.push(sum / seeds.len() as f64);
            s.faceting = Faceting::None;
            s.seed = 0;
            off.push(visible_faces(prep, &s).expect("faces").visible as f64);
        }
        let row = |v: &[f64]| {
            v.iter().map(|f| format!("{f:.0} ({:.1}%)", 100.0 * f / total_faces as f64)).collect::<Vec<_>>().join(" | ")
        };
        if is_increasing(&on) {
            rises_on.push(name.as_str());
        }
        if is_increasing(&off) {
            rises_off.push(name.as_str());
        }
        println!("| {name} | {camera} | off | {} |", row(&off));
        println!("| {name} | {camera} | on | {} |", row(&on));
    }
    common::target(
        4,
        "ambiguity 60 -> 180 deg: visible faces rise with facets on",
        "rises",
        &format!(
            "rises with facets on for {} of {} scenes ({}); with facets off for {}",
            rises_on.len(),
            preps.len(),
            rises_on.join(", "),
            rises_off.join(", ")
        ),
        Some(rises_on.len() == preps.len()),
    );
    println!("\nload average after: {}", common::load_average());
    let _ = std::fs::remove_dir_all(&tmp);
}
