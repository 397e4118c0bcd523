//! The brushwork's own tests: a band's fragments, a row's span.

use super::layer::*;
use super::plan::*;
use super::*;
use crate::film::NO_HIT;
use glam::Vec3;

/// A stroke of the given shape at `centre` along `angle` (radians).
fn stroke(centre: Vec2, angle: f32, half_len: f32, half_wid: f32) -> Stroke {
    let dir = Vec2::from_angle(angle);
    Stroke {
        centre,
        dir,
        half_len,
        half_wid,
        region: 0,
        inv_half_len: 1.0 / half_len,
        inv_half_wid: 1.0 / half_wid,
        bristles: [1.0; BRISTLES + 1],
        key: 0,
        inv_dir: dir.recip(),
        samples: [u32::MAX; 3],
        jitter: 1.0,
        order: 0,
        opacity: 1.0,
        smooth: false,
    }
}

#[test]
fn a_band_lists_its_fragments_in_order_in_runs_of_one_stroke() {
    // Fragments pushed stroke after stroke (a stroke coming back after another starts a
    // new run) come back in the order pushed, each with its stroke.
    let pushed: Vec<(u32, u32)> = [(3, 5), (3, 6), (1, 0), (7, 2), (7, 3), (7, 4), (3, 9)].to_vec();
    let mut band = Band::default();
    for &(k, i) in &pushed {
        band.push(k, Fragment { pixel: i, alpha: i as f32, shade: k as f32 });
    }
    assert_eq!(band.runs.len(), 4);
    let back: Vec<(u32, u32)> = band.runs().flat_map(|(k, frags)| frags.iter().map(move |f| (k, f.pixel))).collect();
    assert_eq!(back, pushed);
    assert!(band.runs().all(|(k, frags)| frags.iter().all(|f| f.shade == k as f32 && f.alpha == f.pixel as f32)));
    assert_eq!(size_of::<Fragment>(), 12);
}

#[test]
fn span_holds_every_painted_pixel() {
    // Every pixel `shape` paints (tested on whole rows, far beyond the stroke) lies in its
    // row's span, at any angle (axis-parallel ones included), size and place; the span
    // is at most two pixels wider than a row's run of candidates (pixels passing the
    // rectangle tests), and about as many pixels are visited as there are candidates.
    let w = 9000usize;
    let mut visited = 0usize;
    let mut candidates = 0usize;
    for k in 0..4000u64 {
        let r = |j: u64| unit_f64(splitmix64(k * 16 + j)) as f32;
        let angle = match k % 8 {
            0 => 0.0,
            1 => std::f32::consts::FRAC_PI_2,
            2 => std::f32::consts::PI,
            3 => 0.004,
            _ => r(0) * std::f32::consts::TAU,
        };
        let centre = Vec2::new(20.0 + r(1) * (w as f32 - 40.0), 20.0 + r(2) * 8000.0);
        let s = stroke(centre, angle, 0.5 + r(3) * 30.0, 0.5 + r(4) * 8.0);
        let reach = (s.half_len + s.half_wid + 3.0).ceil() as i64;
        let cy = centre.y as i64;
        for y in (cy - reach).max(0)..cy + reach {
            let py = y as f32 + 0.5;
            let dy = py - s.centre.y;
            let dy_dir = (dy * s.dir.y, dy * s.dir.x);
            let sp = span(&s, py, 0, w);
            let (x_lo, x_hi) = ((centre.x as i64 - reach).max(0) as usize, (centre.x as i64 + reach) as usize);
            let mut run = 0;
            for x in x_lo..x_hi.min(w) {
                let dx = (x as f32 + 0.5) - s.centre.x;
                let u = dx * s.dir.x + dy_dir.0;
                let v = (dx * s.dir.y - dy_dir.1).abs();
                if u.abs() < s.half_len && v < s.half_wid + 0.5 {
                    run += 1;
                }
                if shape(&s, dx, dy_dir, 0, 1.0).is_some() {
                    let (a, b) = sp.unwrap_or_else(|| panic!("stroke {k} row {y}: no span, pixel {x} painted"));
                    assert!((a..b).contains(&x), "stroke {k} row {y}: pixel {x} painted outside {a}..{b}");
                }
            }
            candidates += run;
            visited += sp.map_or(0, |(a, b)| b - a);
            // (An axis within 0.01 of the rows does not bound the span: `span`.)
            if let Some((a, b)) = sp
                && run > 0
                && s.dir.x.abs() >= 0.01
                && s.dir.y.abs() >= 0.01
            {
                assert!(b - a <= run + 2, "stroke {k} row {y}: span {a}..{b} for {run} candidates");
            }
        }
    }
    assert!(candidates > 100_000);
    assert!((visited as f64) < 1.2 * candidates as f64, "{visited} visits for {candidates} candidates");
}

/// A carried stroke's sample between pixel centres: the pixel's colour at its centre, the
/// mean halfway to its neighbour, and only the pixels of the stroke's region.
#[test]
fn a_sample_between_pixels_blends_the_pixels_of_its_region() {
    let source: Vec<Vec4> = (0..8).map(|i| Vec4::new(i as f32, 0.0, 0.0, 1.0)).collect();
    // Two rows of four: region 0 on the left half, region 1 on the right.
    let regions: Vec<Region> = (0..8).map(|i| ((i % 4) / 2) as Region).collect();
    let surface = Surface { w: 4, h: 2, regions: &regions, coverage: crate::paint::Coverage(None), ground: None };
    let at = |x: f32, y: f32, r: Region| bilinear(&source, &surface, r, Vec2::new(x, y)).map(|c| c.x);
    assert_eq!(at(0.5, 0.5, 0), Some(0.0));
    assert_eq!(at(1.0, 0.5, 0), Some(0.5));
    assert_eq!(at(1.0, 1.0, 0), Some(2.5));
    // Across the regions' edge: region 0's pixel alone, region 1's alone.
    assert_eq!(at(2.0, 0.5, 0), Some(1.0));
    assert_eq!(at(2.0, 0.5, 1), Some(2.0));
    // Past the picture's corner: the corner pixel; no pixel of the region: none.
    assert_eq!(at(0.1, 0.1, 0), Some(0.0));
    assert_eq!(at(0.5, 0.5, 7), None);
}

#[test]
fn hatching_puts_strokes_on_parallel_rows_and_shares_a_dabs_value() {
    // A still's strokes move across their plane's direction, by at most half a row, onto
    // rows a fixed distance apart; strokes of one dab (same row, a stroke-long stretch) differ
    // in value only by their own share.
    let hatch = Hatching { row: 8.4, length: 30.0, seed: 11 };
    let dir = Vec2::from_angle(0.6);
    let across = dir.perp();
    let mut rows = Vec::new();
    for k in 0..500u64 {
        let r = |j: u64| unit_f64(splitmix64(k * 8 + j)) as f32;
        let centre = Vec2::new(400.0 * r(1), 300.0 * r(2));
        let own = 2.0 * r(3) - 1.0;
        let (moved, shade) = hatch.place(centre, dir, 3, own);
        assert!((moved - centre).dot(dir).abs() < 1e-3, "moved along its direction");
        assert!((moved - centre).length() <= 0.5 * hatch.row + 1e-3);
        assert!((-1.0..=1.0).contains(&shade));
        assert_eq!(hatch.place(centre, dir, 3, own), (moved, shade));
        rows.push(moved.dot(across) / hatch.row);
    }
    // Every moved stroke lies on a row: the rows' offsets agree to a small fraction of a row.
    let phase = rows[0] - rows[0].round();
    assert!(rows.iter().all(|a| ((a - a.round()) - phase).abs() < 1e-3), "{rows:?}");
    // Two strokes of the same dab share their dab's value: only their own parts differ.
    let c = Vec2::new(200.0, 150.0);
    let (p, a) = hatch.place(c, dir, 3, 1.0);
    let (_, b) = hatch.place(p + dir * 0.01, dir, 3, -1.0);
    assert!(((a - b) - 2.0 * (1.0 - DAB_SHARE)).abs() < 1e-4, "{a} {b}");
}

/// A source mixing the two kinds of seeds, as an animation frame's (`strokes::surface`).
struct Mixed(Vec<crate::strokes::StrokeSeed>);

impl SeedSource for Mixed {
    fn seeds(&self, _: u64, _: u64, _: f32, _: usize, _: usize) -> Vec<crate::strokes::StrokeSeed> {
        self.0.clone()
    }
}

#[test]
fn seeds_fixed_on_the_canvas_are_hatched_and_carried_ones_keep_their_place() {
    // One plane over the whole picture: a fixed seed goes onto its row, exactly along the
    // plane's direction; a carried seed at the same place stays there and reads between pixels.
    let (w, h) = (64, 64);
    let regions: Vec<Region> = vec![0; w * h];
    let surface = Surface { w, h, regions: &regions, coverage: crate::paint::Coverage(None), ground: None };
    let brush = Brushwork { opacity: 1.0, length: 12.0, width: 4.0, seed: 5 };
    let angle = [Vec2::from_angle(0.4)];
    let seed = |carried: bool| crate::strokes::StrokeSeed {
        pos: Vec2::new(31.3, 30.2),
        id: 77,
        plane: None,
        opacity: 1.0,
        carried,
        laid: None,
        ground: false,
    };
    let strokes =
        brush.strokes(0, (12.0, 4.0), &surface, (&angle, &[]), &Mixed(vec![seed(false), seed(true)]), None, &|_| 0.0);
    let (fixed, carried) = (&strokes[0], &strokes[1]);
    let hatch = Hatching { row: 4.0 * HATCH_ROW, length: 12.0, seed: sub_seed(5, SALT ^ 1) };
    assert_eq!(fixed.centre, hatch.place(seed(false).pos, angle[0], 0, 0.0).0);
    assert_ne!(fixed.centre, seed(false).pos, "the fixed seed stayed off its row");
    assert_eq!((fixed.dir, fixed.smooth), (angle[0], false));
    assert_eq!((carried.centre, carried.smooth), (seed(true).pos, true));
}

#[test]
fn carried_seeds_are_hatched_where_laid_and_move_with_their_surface() {
    // A carried seed laid at the fixed seed's place with the identity map is hatched as the
    // fixed one is; moved by a surface's translation it keeps its row and value, moved by the
    // same amount; turned with the surface, its stroke turns too; grown far beyond the rows'
    // scale, it keeps its place.
    let (w, h) = (64, 64);
    let regions: Vec<Region> = vec![0; w * h];
    let surface = Surface { w, h, regions: &regions, coverage: crate::paint::Coverage(None), ground: None };
    let brush = Brushwork { opacity: 1.0, length: 12.0, width: 4.0, seed: 5 };
    let angle = [Vec2::from_angle(0.4)];
    let at = Vec2::new(31.3, 30.2);
    let seed = |pos: Vec2, laid: Option<crate::strokes::Laid>| crate::strokes::StrokeSeed {
        pos,
        id: 77,
        plane: None,
        opacity: 1.0,
        carried: laid.is_some(),
        laid,
        ground: false,
    };
    let laid = |to_frame: glam::Mat2| Some(crate::strokes::Laid { at, to_frame });
    let shift = Vec2::new(3.7, -2.2);
    let turn = glam::Mat2::from_angle(0.3);
    let seeds = vec![
        seed(at, None),
        seed(at, laid(glam::Mat2::IDENTITY)),
        seed(at + shift, laid(glam::Mat2::IDENTITY)),
        seed(at, laid(turn)),
        seed(at, laid(glam::Mat2::from_diagonal(Vec2::splat(3.0)))),
    ];
    let strokes = brush.strokes(0, (12.0, 4.0), &surface, (&angle, &[]), &Mixed(seeds), None, &|_| 0.0);
    let (fixed, here, moved, turned) = (&strokes[0], &strokes[1], &strokes[2], &strokes[3]);
    // A surface three times as large as where its rows were laid: the stroke stays at its seed.
    assert_eq!(strokes[4].centre, at);
    assert_ne!(fixed.centre, at, "the fixed seed stayed off its row");
    assert!((here.centre - fixed.centre).length() < 1e-5, "{:?} {:?}", here.centre, fixed.centre);
    assert!((here.dir - fixed.dir).length() < 1e-6 && here.jitter == fixed.jitter);
    assert!((moved.centre - (fixed.centre + shift)).length() < 1e-4, "{:?}", moved.centre);
    assert!(moved.jitter == fixed.jitter && moved.smooth && !fixed.smooth);
    assert!((turned.dir - turn * angle[0]).length() < 1e-5, "{:?}", turned.dir);
    assert!((turned.centre - (at + turn * (fixed.centre - at))).length() < 1e-4);
}

#[test]
fn a_ground_seed_under_the_subject_paints_its_planes_ground_alone() {
    // Plane 1's ground on the left, the subject (object 0) on the right half of plane 1. A
    // ground seed on the subject paints the ground of its plane, never the subject; with all
    // of its samples under the subject it takes its ground's mean; with no ground known for
    // its plane it has no stroke.
    let (w, h) = (64, 64);
    let ground_region: Region = (1 << 32) | NO_HIT as u64;
    let subject_region: Region = 1 << 32;
    let regions: Vec<Region> = (0..w * h).map(|i| if i % w < 28 { ground_region } else { subject_region }).collect();
    let ground = std::collections::HashMap::from([(1u32, ground_region)]);
    let surface = Surface { w, h, regions: &regions, coverage: crate::paint::Coverage(None), ground: Some(&ground) };
    let brush = Brushwork { opacity: 1.0, length: 12.0, width: 4.0, seed: 5 };
    let angle = [Vec2::X, Vec2::X];
    let seed = |x: f32, plane: u32| crate::strokes::StrokeSeed {
        pos: Vec2::new(x, 30.5),
        id: 77 + x as u64,
        plane: Some(plane),
        opacity: 1.0,
        carried: false,
        laid: None,
        ground: true,
    };
    // Beside the outline (its ends reach the ground), deep in the subject, and on plane 0.
    let seeds = Mixed(vec![seed(31.0, 1), seed(50.0, 1), seed(50.0, 0)]);
    let strokes = brush.strokes(0, (12.0, 4.0), &surface, (&angle, &[]), &seeds, None, &|_| 0.0);
    assert_eq!(strokes.len(), 2, "the seed of plane 0, whose ground is not known, has a stroke");
    assert!(strokes.iter().all(|s| s.region == ground_region));
    let mut px: Vec<Vec4> = vec![Vec4::new(0.5, 0.45, 0.4, 1.0); w * h];
    let picture = px.clone();
    let means = RegionMeans::from([(ground_region, Vec3::new(0.6, 0.5, 0.4))]);
    let layer = StrokeLayer::new(strokes, h);
    let tints = layer.tints(&picture, &means, &surface);
    composite(&layer, &tints, &mut px, &surface, 1.0);
    for (i, (p, q)) in px.iter().zip(&picture).enumerate() {
        if regions[i] == subject_region {
            assert_eq!(p, q, "a ground stroke painted the subject at {i}");
        }
    }
    assert!(px.iter().zip(&picture).any(|(p, q)| p != q), "the ground beside the outline was not painted");
    // The stroke deep in the subject has no sample on the ground: its ground's mean (before
    // its value jitter); the other reads the ground beside the outline too.
    let deep = layer.strokes.iter().position(|s| s.centre.x > 40.0).unwrap();
    let mean = tints[deep].colour / layer.strokes[deep].jitter;
    assert!((mean - Vec3::new(0.6, 0.5, 0.4)).length() < 1e-5, "{mean}");
    let near = tints[1 - deep].colour / layer.strokes[1 - deep].jitter;
    assert!((near - Vec3::new(0.6, 0.5, 0.4)).length() > 0.01, "{near}");
}

#[test]
fn a_planes_strokes_are_sized_by_the_plane_against_the_median() {
    let plane = |pixels: u64| Plane {
        pixels,
        centre: Vec2::ZERO,
        long_axis: Vec2::X,
        elongation: 0.0,
        dark: Vec2::Y,
        span: (0.0, 1.0),
    };
    let planes: Vec<Plane> = [0, 100, 100, 400, 25, 150].into_iter().map(plane).collect();
    // The median of the sizes that are not 0 (25, 100, 100, 150, 400) is 100.
    let (lo, hi) = PLANE_SIZE_RANGE;
    let s = plane_scales(&planes, None);
    assert_eq!(&s[..5], &[1.0, 1.0, 1.0, hi, lo]);
    assert!((s[5] - 1.5f32.powf(PLANE_SIZE_POWER)).abs() < 1e-6);
    // A sequence's median (the layout frame's) is used as given.
    let held = plane_scales(&planes, Some(150.0));
    assert!((held[1] - (100.0f32 / 150.0).powf(PLANE_SIZE_POWER)).abs() < 1e-6 && held[5] == 1.0);
    assert_eq!(median_size([0u64, 0].into_iter()), None);
}

#[test]
fn strokes_are_calmer_and_thinner_where_the_composition_is_calm() {
    // The same seeds laid where the composition is calm (1) and about the subject (0): their
    // value change is `CORNER_CALM` smaller and their opacity `CORNER_THIN` lower; their place,
    // direction and size are the same.
    let (w, h) = (64, 64);
    let regions: Vec<Region> = vec![0; w * h];
    let surface = Surface { w, h, regions: &regions, coverage: crate::paint::Coverage(None), ground: None };
    let brush = Brushwork { opacity: 1.0, length: 12.0, width: 4.0, seed: 5 };
    let angle = [Vec2::from_angle(0.4)];
    let seeds: Vec<crate::strokes::StrokeSeed> = (0..20)
        .map(|k| crate::strokes::StrokeSeed {
            pos: Vec2::new(10.0 + 2.3 * k as f32, 12.0 + 1.7 * k as f32),
            id: 100 + k,
            plane: None,
            opacity: 1.0,
            carried: false,
            laid: None,
            ground: false,
        })
        .collect();
    let seeds = Mixed(seeds);
    let busy = brush.strokes(0, (12.0, 4.0), &surface, (&angle, &[]), &seeds, None, &|_| 0.0);
    let calm = brush.strokes(0, (12.0, 4.0), &surface, (&angle, &[]), &seeds, None, &|_| 1.0);
    assert_eq!(busy.len(), 20);
    assert!(busy.iter().any(|s| (s.jitter - 1.0).abs() > 0.05), "no value change to calm");
    for (b, c) in busy.iter().zip(&calm) {
        assert_eq!((b.centre, b.dir, b.half_len, b.half_wid), (c.centre, c.dir, c.half_len, c.half_wid));
        assert!(((c.jitter - 1.0) - (1.0 - CORNER_CALM) * (b.jitter - 1.0)).abs() < 1e-6);
        assert!((b.opacity - 1.0).abs() < 1e-6 && (c.opacity - (1.0 - CORNER_THIN)).abs() < 1e-6);
    }
}

#[test]
fn a_fine_strokes_share_fades_it_and_none_drops_it() {
    // The fine layer's test answers a share (an animation fades a stroke across the
    // threshold): the stroke's opacity is its seed's times the share; a share of 0 paints none.
    let (w, h) = (64, 64);
    let regions: Vec<Region> = vec![0; w * h];
    let surface = Surface { w, h, regions: &regions, coverage: crate::paint::Coverage(None), ground: None };
    let brush = Brushwork { opacity: 1.0, length: 12.0, width: 4.0, seed: 5 };
    let angle = [Vec2::from_angle(0.4)];
    let seed = |x: f32| crate::strokes::StrokeSeed {
        pos: Vec2::new(x, 30.2),
        id: x as u64,
        plane: None,
        opacity: 0.8,
        carried: true,
        laid: None,
        ground: false,
    };
    let seeds = Mixed(vec![seed(10.5), seed(30.5), seed(50.5)]);
    let share = |p: Vec2| {
        if p.x < 20.0 {
            0.0
        } else if p.x < 40.0 {
            0.25
        } else {
            1.0
        }
    };
    let strokes = brush.strokes(1, (6.0, 2.0), &surface, (&angle, &[]), &seeds, Some(&share), &|_| 0.0);
    assert_eq!(strokes.len(), 2, "the stroke whose share is 0 is dropped");
    assert!((strokes[0].opacity - 0.8 * 0.25).abs() < 1e-6, "{}", strokes[0].opacity);
    assert!((strokes[1].opacity - 0.8).abs() < 1e-6, "{}", strokes[1].opacity);
}
