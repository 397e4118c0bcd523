//! Cost of each painterly effect and of the whole chain on a 1000x1000 render of the built-in
//! still life by the default pipeline (preset `analytic` without its painterly effects: Segment
//! facets, re-aimed; target: whole chain < 100 ms on 2 cores).
//!
//! `cargo bench --bench paint` prints the table; `-- --save DIR` also writes each effect's
//! picture there (for looking at them); `-- --only NAME` runs only the rows starting with NAME. Each row is the median of several runs of the chain
//! with only that effect on (so it includes the canvas conversion the chain does once).

#[path = "common/mod.rs"]
mod common;

use std::path::PathBuf;
use std::time::Instant;

use cubist::film::Film;
use cubist::output::{encode, write_png};
use cubist::paint::chiaroscuro::ViewAxes;
use cubist::paint::{Lighting, Painter};
use cubist::pipeline::{Prepared, params, render};
use cubist::progress::Progress;
use cubist::scene::Scene;
use cubist::settings::{BorderStyle, Palette, Preset, Settings};
use cubist::shading::LightRig;
use cubist::util::rng::{splitmix64, unit_f64};

const SIDE: u32 = 1000;
const RUNS: usize = 9;

fn painting_like(w: u32, h: u32) -> image::RgbImage {
    image::RgbImage::from_fn(w, h, |x, y| {
        let plane = ((x / 37) * 7 + (y / 53) * 3) % 5;
        let base: [f32; 3] = match plane {
            0 => [120.0, 90.0, 54.0],
            1 => [60.0, 44.0, 28.0],
            2 => [168.0, 132.0, 79.0],
            3 => [110.0, 125.0, 140.0],
            _ => [225.0, 210.0, 175.0],
        };
        let n = unit_f64(splitmix64(((y as u64) << 32) | x as u64)) as f32 * 40.0 - 20.0;
        image::Rgb(base.map(|c| (c + n).clamp(0.0, 255.0) as u8))
    })
}

fn median_ms(times: &mut [f64]) -> f64 {
    times.sort_by(f64::total_cmp);
    times[times.len() / 2]
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let save = args.iter().position(|a| a == "--save").and_then(|i| args.get(i + 1)).map(PathBuf::from);
    // `--only NAME`: just the rows whose name starts with NAME (for profiling one effect).
    let only_row = args.iter().position(|a| a == "--only").and_then(|i| args.get(i + 1)).cloned();
    // `--dump DIR`: each row's painted colour buffer as raw f32 (to compare two builds bit for bit).
    let dump = args.iter().position(|a| a == "--dump").and_then(|i| args.get(i + 1)).map(PathBuf::from);

    let prep = Prepared::new(Scene::default_scene());
    let mut base = Settings::preset(Preset::Plain);
    base.width = SIDE;
    base.height = SIDE;
    base.spp = 1;
    // The default pipeline's picture before painting: analytic preset, effects off.
    let mut unpainted = Settings::default();
    (unpainted.width, unpainted.height) = (SIDE, SIDE);
    (unpainted.border_width, unpainted.silhouette_width, unpainted.gradients) = (0.0, 0.0, 0.0);
    unpainted.contour_width = 0.0;
    (unpainted.palette, unpainted.colors, unpainted.chiaroscuro) = (Palette::None, 0, 0.0);
    (unpainted.plane_light, unpainted.brushwork, unpainted.canvas_grain) = (0.0, 0.0, 0.0);
    (unpainted.value_contrast, unpainted.value_lift, unpainted.ground_value) = (0.0, 1.0, 1.0);
    let rendered = render(&prep, &unpainted, &Progress::silent()).expect("render");
    let facets = rendered.facets;
    let film: Film = rendered.film;
    let framed = cubist::framing::frame_camera(&params::framing(&unpainted), &prep.world, &prep.accel).expect("camera");
    let rig = LightRig::new(&prep.world, &framed.frame, unpainted.shadows, unpainted.exposure);
    let f = &framed.frame;
    let view = ViewAxes { right: f.right.as_vec3(), up: f.up.as_vec3(), forward: f.forward.as_vec3() };
    let lighting = Lighting { world: &prep.world, rig: &rig, view };

    let dir = tempfile_dir();
    let painting = dir.join("painting.png");
    painting_like(1000, 750).save(&painting).expect("write the test painting");

    let analytic = Settings::preset(Preset::Analytic);
    let only = |f: &dyn Fn(&mut Settings)| {
        let mut s = base.clone();
        f(&mut s);
        s
    };
    let rows: Vec<(&str, Settings)> = vec![
        ("canvas only", base.clone()),
        ("chiaroscuro", only(&|s| s.chiaroscuro = 0.5)),
        (
            "silhouettes",
            only(&|s| {
                s.silhouette_width = analytic.silhouette_width;
                s.silhouette_strength = analytic.silhouette_strength
            }),
        ),
        (
            "borders",
            only(&|s| {
                s.border_width = analytic.border_width;
                s.border_strength = analytic.border_strength
            }),
        ),
        ("gradients", only(&|s| s.gradients = 0.3)),
        ("plane light", only(&|s| s.plane_light = analytic.plane_light)),
        (
            "plane light, smooth",
            only(&|s| {
                s.plane_light = analytic.plane_light;
                s.light_steps = 0
            }),
        ),
        (
            "passage",
            only(&|s| {
                s.border_style = BorderStyle::Passage;
                s.border_width = analytic.border_width;
                s.border_strength = analytic.border_strength
            }),
        ),
        ("brushwork", only(&|s| s.brushwork = analytic.brushwork)),
        (
            "contours",
            only(&|s| {
                s.contour_width = analytic.contour_width;
                s.contour_strength = analytic.contour_strength
            }),
        ),
        (
            "values",
            only(&|s| {
                s.value_contrast = analytic.value_contrast;
                s.value_lift = analytic.value_lift
            }),
        ),
        ("canvas grain", only(&|s| s.canvas_grain = analytic.canvas_grain)),
        ("palette (ochre)", only(&|s| s.palette = Palette::Ochre)),
        ("palette (image)", only(&|s| s.palette_image = Some(painting.clone()))),
        ("quantise (8)", only(&|s| s.colors = 8)),
        ("analytic preset chain (the default)", {
            let mut s = analytic.clone();
            (s.width, s.height) = (SIDE, SIDE);
            s
        }),
        (
            "whole chain",
            only(&|s| {
                Preset::Braque.apply(s);
                s.width = SIDE;
                s.height = SIDE;
                s.spp = 1;
                s.chiaroscuro = 0.5;
                s.gradients = 0.3;
            }),
        ),
    ];

    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!(
        "Painterly effects at {SIDE}x{SIDE} on the still life's default render ({} Segment facets), {} rayon threads, {RUNS} runs; load average {} \
         (wall times grow with other processes' load; CPU time summed over threads does much less). \
         \"whole chain\" = every effect at once (Braque preset + chiaroscuro 0.5 + gradients 0.3).\n",
        facets.used_facets(),
        rayon::current_num_threads(),
        load.split_whitespace().next().unwrap_or("?")
    );
    println!("| effect | setup ms | wall ms (median) | wall ms (min) | CPU ms (mean, all threads) |");
    println!("|---|---:|---:|---:|---:|");
    for (name, s) in &rows {
        if only_row.as_ref().is_some_and(|o| !name.starts_with(o.as_str())) {
            continue;
        }
        let t = Instant::now();
        let painter = if s.preset == Preset::Plain && Painter::new(&params::paint(s)).expect("painter").is_empty() {
            // The chain's fixed cost: turning the frame into a canvas and back.
            Painter::from_effects(vec![Box::new(Nothing)], s.background, s.transparent)
        } else {
            Painter::new(&params::paint(s)).expect("painter")
        };
        let setup = t.elapsed().as_secs_f64() * 1e3;
        let mut times = Vec::with_capacity(RUNS);
        let mut out = film.clone();
        let cpu0 = cpu_ms();
        for _ in 0..RUNS {
            // The effects change only the colour: restore it, keep the other buffers.
            out.color.copy_from_slice(&film.color);
            let t = Instant::now();
            painter.apply(&mut out, Some(&facets), Some(&lighting)).expect("paint");
            times.push(t.elapsed().as_secs_f64() * 1e3);
        }
        let cpu = (cpu_ms() - cpu0) / RUNS as f64;
        let min = times.iter().copied().fold(f64::INFINITY, f64::min);
        let median = median_ms(&mut times);
        println!("| {name} ({}) | {setup:.1} | {median:.1} | {min:.1} | {cpu:.0} |", painter.names().join(" + "));
        if *name == "brushwork" {
            common::target(
                13,
                &format!("brushwork (stroke layer) at {SIDE}x{SIDE} (median wall)"),
                "<= 150 ms on 2 cores",
                &format!("{median:.1} ms ({cpu:.0} ms CPU)"),
                Some(median <= 150.0),
            );
        }
        if name.starts_with("analytic") || *name == "whole chain" {
            common::target(
                6,
                &format!("painterly chain at {SIDE}x{SIDE}, {name} (median wall)"),
                "< 100 ms",
                &format!("{median:.1} ms"),
                Some(median < 100.0),
            );
        }
        if let Some(dir) = &dump {
            let file = name.replace([' ', '(', ')'], "_").replace("__", "_");
            std::fs::write(dir.join(format!("{}.f32", file.trim_matches('_'))), bytemuck::cast_slice(&out.color))
                .expect("dump");
        }
        if let Some(dir) = &save {
            let file = name.replace([' ', '(', ')'], "_").replace("__", "_");
            write_png(&dir.join(format!("{}.png", file.trim_matches('_'))), &encode(&out, s.background, s.transparent))
                .expect("save");
        }
    }
    if let Some(dir) = &save {
        write_png(&dir.join("unpainted.png"), &encode(&film, base.background, false)).expect("save");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

/// An effect that does nothing, to time the chain's own cost.
struct Nothing;
impl cubist::paint::Effect for Nothing {
    fn name(&self) -> &'static str {
        "none"
    }
    fn apply(&self, _: &mut cubist::paint::Canvas<'_>, _: &cubist::paint::PaintContext) -> cubist::Result<()> {
        Ok(())
    }
}

/// User + system CPU time of this process so far, ms (10 ms resolution: averaged over runs).
fn cpu_ms() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    // Fields after the command name (which may hold spaces) start after the last ')'.
    let rest = stat.rsplit_once(')').map_or("", |r| r.1);
    let f: Vec<f64> = rest.split_whitespace().filter_map(|x| x.parse().ok()).collect();
    // utime and stime are fields 14 and 15 of stat; here 11 and 12 after the state letter.
    if f.len() > 12 { (f[10] + f[11]) * 10.0 } else { f64::NAN }
}

fn tempfile_dir() -> PathBuf {
    let d = std::env::temp_dir().join(format!("cubist-paint-bench-{}", std::process::id()));
    std::fs::create_dir_all(&d).expect("temp dir");
    d
}
