//! The outline steps' tests: components, tracing, simplification, junctions, layers.

use std::collections::VecDeque;

use super::labels::components;
use super::simplify::merge_short;
use super::trace::{keep_seeded, lattice_row};
use super::*;
use crate::facets::planes::polygon::signed_area;
use crate::util::grid::Grid;

/// `components` by flood fill from each unvisited pixel in scan order: the definition, kept
/// as the tests' reference.
fn components_by_flood(labels: &[u32], w: usize, h: usize) -> (Vec<u32>, Vec<(u32, usize)>) {
    let grid = Grid { width: w, height: h };
    let mut comp = vec![u32::MAX; labels.len()];
    let mut info = Vec::new();
    let mut queue = VecDeque::new();
    for start in 0..labels.len() {
        if comp[start] != u32::MAX {
            continue;
        }
        let id = info.len() as u32;
        let value = labels[start];
        comp[start] = id;
        queue.push_back(start);
        let mut area = 0;
        while let Some(i) = queue.pop_front() {
            area += 1;
            let mut visit = |j: usize| {
                if comp[j] == u32::MAX && labels[j] == value {
                    comp[j] = id;
                    queue.push_back(j);
                }
            };
            grid.neighbours4(i).for_each(&mut visit);
        }
        info.push((value, area));
    }
    (comp, info)
}

fn area(rings: &[Vec<DVec2>]) -> f64 {
    rings.iter().map(|r| signed_area(r)).sum()
}

/// `trace`'s lattice edges as the loop over mask pixels made them before they were made
/// per vertex in parallel (perf7): the reference.
fn edges_by_pixel(mask: &[bool], w: usize, h: usize) -> Vec<u8> {
    let vw = w + 1;
    let at =
        |x: i64, y: i64| x >= 0 && y >= 0 && (x as usize) < w && (y as usize) < h && mask[y as usize * w + x as usize];
    let mut out = vec![0u8; vw * (h + 1)];
    let v = |x: i64, y: i64| y as usize * vw + x as usize;
    for y in 0..h as i64 {
        for x in 0..w as i64 {
            if !at(x, y) {
                continue;
            }
            if !at(x, y - 1) {
                out[v(x, y)] |= 1;
            }
            if !at(x + 1, y) {
                out[v(x + 1, y)] |= 2;
            }
            if !at(x, y + 1) {
                out[v(x + 1, y + 1)] |= 4;
            }
            if !at(x - 1, y) {
                out[v(x, y + 1)] |= 8;
            }
        }
    }
    out
}

/// Random label images: blobs of a few values with speckle, checkerboard saddles and
/// single-pixel rows and columns.
fn random_labels(w: usize, h: usize, values: u32, seed: u64) -> Vec<u32> {
    let mut state = seed;
    let mut next = || {
        state = crate::util::rng::splitmix64(state);
        state
    };
    let centres: Vec<(f64, f64, u32)> = (0..6)
        .map(|_| ((next() % 1000) as f64 / 1000.0, (next() % 1000) as f64 / 1000.0, (next() % values as u64) as u32))
        .collect();
    (0..w * h)
        .map(|i| {
            let (x, y) = ((i % w) as f64 / w as f64, (i / w) as f64 / h as f64);
            match next() % 23 {
                0 => (next() % values as u64) as u32,
                1 if (i % w + i / w).is_multiple_of(2) => BACKGROUND,
                _ => centres
                    .iter()
                    .min_by(|a, b| {
                        ((a.0 - x).powi(2) + (a.1 - y).powi(2)).total_cmp(&((b.0 - x).powi(2) + (b.1 - y).powi(2)))
                    })
                    .map_or(0, |c| c.2),
            }
        })
        .collect()
}

/// Components by runs (perf7) number and measure them as the flood fill does.
#[test]
fn components_by_runs_match_the_flood_fill() {
    for (k, (w, h, values)) in [(1usize, 1usize, 1u32), (1, 37, 2), (41, 1, 3), (64, 48, 3), (200, 90, 5), (13, 211, 2)]
        .into_iter()
        .enumerate()
    {
        for seed in 0..4u64 {
            let labels = random_labels(w, h, values, seed * 31 + k as u64);
            assert_eq!(components(&labels, w, h), components_by_flood(&labels, w, h), "{w}x{h} seed {seed}");
        }
    }
}

/// Rings traced within the mask's bounding box are those traced over the whole image,
/// with and without a seed: random masks, one pixel, none, touching every edge.
#[test]
fn rings_traced_within_the_box_are_those_of_the_whole_image() {
    for (w, h) in [(1usize, 1usize), (7, 1), (1, 9), (64, 48), (97, 33), (120, 130)] {
        for seed in 0..4u64 {
            let labels = random_labels(w, h, 3, seed + 11);
            for value in [0u32, 1, 2, BACKGROUND, 77] {
                let inside = |i: usize| labels[i] == value || (value == 1 && labels[i] == 2);
                let full: Vec<bool> = (0..w * h).map(inside).collect();
                assert_eq!(trace_within_box(w, h, &inside, None), trace(&full, w, h), "{w}x{h} {seed} {value}");
                let first = (0..w * h).find(|&i| labels[i] == value);
                let seeded = |i: usize| Some(i) == first;
                let mut kept = full.clone();
                keep_seeded(&mut kept, w, h, seeded);
                assert_eq!(trace_within_box(w, h, &inside, Some(&seeded)), trace(&kept, w, h), "{w}x{h} {seed}");
            }
        }
    }
    // A lone pixel and an empty mask.
    let lone: Vec<bool> = (0..20).map(|i| i == 13).collect();
    assert_eq!(trace_within_box(5, 4, &|i| i == 13, None), trace(&lone, 5, 4));
    assert!(trace_within_box(5, 4, &|_| false, None).is_empty());
}

/// The lattice edges made per vertex (perf7) are those made per mask pixel.
#[test]
fn lattice_edges_match_the_per_pixel_loop() {
    for (w, h) in [(1usize, 1usize), (5, 1), (1, 6), (64, 48), (97, 33)] {
        for seed in 0..3u64 {
            let mask: Vec<bool> = random_labels(w, h, 2, seed).iter().map(|&l| l == 1).collect();
            let vw = w + 1;
            let mut out = vec![0u8; vw * (h + 1)];
            let at = |x: i64, y: i64| {
                x >= 0 && y >= 0 && (x as usize) < w && (y as usize) < h && mask[y as usize * w + x as usize]
            };
            out.par_chunks_mut(vw).enumerate().for_each(|(y, row)| lattice_row(&at, y, row));
            assert_eq!(out, edges_by_pixel(&mask, w, h), "{w}x{h} seed {seed}");
        }
    }
}

#[test]
fn trace_a_square_with_a_hole() {
    let (w, h) = (8, 7);
    let mask: Vec<bool> = (0..w * h)
        .map(|i| (1..7).contains(&(i % w)) && (1..6).contains(&(i / w)) && !(i % w == 3 && i / w == 3))
        .collect();
    let rings = trace(&mask, w, h);
    assert_eq!(rings.len(), 2);
    // Outer 6 x 5 = 30 minus the one-pixel hole: signed areas add up.
    assert!((area(&rings).abs() - 29.0).abs() < 1e-12, "{}", area(&rings));
    assert_eq!(rings.iter().map(|r| r.len()).collect::<Vec<_>>(), vec![4, 4]);
}

#[test]
fn diagonal_pixels_are_separate_rings() {
    let mask = vec![true, false, false, true];
    let rings = trace(&mask, 2, 2);
    assert_eq!(rings.len(), 2);
    assert!((area(&rings).abs() - 2.0).abs() < 1e-12);
}

#[test]
fn short_edges_merge_and_corners_stay() {
    // A circle of 64 points (edges ~4.9 px): every edge ends at least 20 px long, and
    // every corner left is one of the circle's points.
    let circle: Vec<DVec2> = (0..64)
        .map(|k| {
            let t = std::f64::consts::TAU * k as f64 / 64.0;
            DVec2::new(100.0 + 50.0 * t.cos(), 100.0 + 50.0 * t.sin())
        })
        .collect();
    let merged = merge_short_edges(circle.clone(), 20.0);
    let n = merged.len();
    assert!((6..=16).contains(&n), "{n}");
    assert!((0..n).all(|k| (merged[(k + 1) % n] - merged[k]).length() >= 20.0), "{merged:?}");
    assert!(merged.iter().all(|p| circle.contains(p)));
    // A square with a 2 px notch in one side keeps its four corners.
    let square = vec![
        DVec2::new(0.0, 0.0),
        DVec2::new(50.0, 0.0),
        DVec2::new(51.0, 2.0),
        DVec2::new(52.0, 0.0),
        DVec2::new(100.0, 0.0),
        DVec2::new(100.0, 100.0),
        DVec2::new(0.0, 100.0),
    ];
    let merged = merge_short_edges(square, 10.0);
    assert_eq!(merged.len(), 5, "{merged:?}");
    for c in [DVec2::new(0.0, 0.0), DVec2::new(100.0, 0.0), DVec2::new(100.0, 100.0), DVec2::new(0.0, 100.0)] {
        assert!(merged.contains(&c), "{c} lost: {merged:?}");
    }
    // Nothing below a triangle.
    assert_eq!(merge_short_edges(vec![DVec2::ZERO, DVec2::X, DVec2::Y], 10.0).len(), 3);
}

#[test]
fn a_staircase_simplifies_to_a_straight_edge() {
    // A right triangle below the diagonal of a 40 x 40 image: its hypotenuse is a staircase.
    let n = 40;
    let mask: Vec<bool> = (0..n * n).map(|i| i % n <= i / n).collect();
    let rings = trace(&mask, n, n);
    assert_eq!(rings.len(), 1);
    assert!(rings[0].len() > 40);
    let s = simplify_ring(&rings[0], 1.0);
    assert!(s.len() <= 4, "{s:?}");
    assert!((signed_area(&s).abs() - 800.0).abs() < 45.0);
}

#[test]
fn specks_merge_into_their_surroundings() {
    let (w, h) = (10, 10);
    let mut labels = vec![BACKGROUND; w * h];
    for i in 0..w * h {
        if i % w < 5 {
            labels[i] = 1;
        }
    }
    labels[5 * w + 8] = 2; // a one-pixel speck of object 2 on the background
    labels[2 * w + 2] = BACKGROUND; // a pinhole in object 1
    clean_labels(&mut labels, w, h, 3, 0.0);
    assert_eq!(labels[5 * w + 8], BACKGROUND);
    assert_eq!(labels[2 * w + 2], 1);
}

#[test]
fn object_layers_go_far_to_near_and_include_what_is_in_front() {
    let (w, h) = (20, 10);
    let mut labels = vec![BACKGROUND; w * h];
    let mut depth = vec![f32::INFINITY; w * h];
    for y in 2..8 {
        for x in 2..12 {
            labels[y * w + x] = 7;
            depth[y * w + x] = 5.0;
        }
        for x in 10..16 {
            labels[y * w + x] = 3;
            depth[y * w + x] = 2.0;
        }
    }
    let l = layers(&labels, &depth, w, h, 10, 0.5, 0.0);
    assert_eq!(l.len(), 3);
    // The far object (7) with the near one in front of it: 14 x 6 pixels; the near one 6 x 6.
    assert!((area(&l[1].rings).abs() - 84.0).abs() < 1e-9, "{}", area(&l[1].rings));
    assert!((area(&l[2].rings).abs() - 36.0).abs() < 1e-9);
}

/// Three objects: C (farthest) a box at the left, A a slanted blob touching C, B (nearest)
/// a disc over A's right side; the background around them. Depth by label.
fn three_objects(w: usize, h: usize) -> (Vec<u32>, Vec<f32>) {
    let mut labels = vec![BACKGROUND; w * h];
    let mut depth = vec![f32::INFINITY; w * h];
    for y in 0..h {
        for x in 0..w {
            let (xf, yf) = (x as f64, y as f64);
            let i = y * w + x;
            let (l, t) = if (xf - 78.0).powi(2) + (yf - 40.0).powi(2) < 18.0f64.powi(2) {
                (2, 1.0)
            } else if yf > 12.0 + 0.3 * xf && yf < 70.0 - 0.2 * xf && xf > 20.0 && xf < 90.0 {
                (1, 2.0)
            } else if (6..24).contains(&x) && (18..62).contains(&y) {
                (0, 3.0)
            } else {
                continue;
            };
            labels[i] = l;
            depth[i] = t;
        }
    }
    (labels, depth)
}

fn segments(layer: &Layer) -> Vec<(DVec2, DVec2)> {
    layer.rings.iter().flat_map(|r| (0..r.len()).map(move |k| (r[k], r[(k + 1) % r.len()]))).collect()
}

/// Where two layers' outlines run together (A with B in front of it, and all geometry,
/// along their edge against the background), they are simplified alike: every edge of the
/// A-and-B layer away from C is an edge of layer 0, so the planes they cut meet on one
/// line. Simplified ring by ring (as before), the same stretch came out differently.
#[test]
fn layers_share_the_outline_they_run_along() {
    let (w, h) = (110, 80);
    let (labels, depth) = three_objects(w, h);
    let (tolerance, min_edge) = (1.5, 5.0);
    let l = layers(&labels, &depth, w, h, 50, tolerance, min_edge);
    // Layer 0, then far to near: C (with everything in front: all of it), A (with B), B.
    assert_eq!(l.len(), 4);
    let (all, a_and_b) = (segments(&l[0]), segments(&l[2]));
    let away_from_c = |p: DVec2| p.x > 24.0 + min_edge;
    let along: Vec<_> = a_and_b.iter().filter(|(p, q)| away_from_c(*p) && away_from_c(*q)).collect();
    assert!(along.len() >= 6, "{along:?}");
    for s in &along {
        assert!(all.contains(s), "{s:?} is not an edge of layer 0: {all:?}");
    }
    // The same rings simplified whole do not share their edges there.
    let whole = |inside: &dyn Fn(usize) -> bool| -> Vec<(DVec2, DVec2)> {
        let mask: Vec<bool> = (0..w * h).map(inside).collect();
        let rings =
            trace(&mask, w, h).iter().map(|r| merge_short_edges(simplify_ring(r, tolerance), min_edge)).collect();
        segments(&Layer { rings })
    };
    let (all, a_and_b) = (whole(&|i| labels[i] != BACKGROUND), whole(&|i| labels[i] == 1 || labels[i] == 2));
    let shared = a_and_b.iter().filter(|(p, q)| away_from_c(*p) && away_from_c(*q) && all.contains(&(*p, *q))).count();
    let along = a_and_b.iter().filter(|(p, q)| away_from_c(*p) && away_from_c(*q)).count();
    assert!(shared < along, "simplified whole, {shared} of {along} edges shared");
    // Every ring still encloses its mask's area within the tolerance.
    for (k, inside) in [
        (0usize, &(|l: u32| l != BACKGROUND) as &dyn Fn(u32) -> bool),
        (2, &|l: u32| l == 1 || l == 2),
        (3, &|l: u32| l == 2),
    ] {
        let pixels = labels.iter().filter(|&&l| inside(l)).count() as f64;
        let ring_area = area(&l[k].rings).abs();
        assert!((ring_area - pixels).abs() < 0.06 * pixels, "layer {k}: {ring_area} against {pixels}");
    }
}

/// Junctions a short boundary apart are one point (their boundary is no edge); farther
/// apart, or with a shorter reach, each keeps its own.
#[test]
fn junctions_a_short_boundary_apart_are_one() {
    // Background, object 1 on the left, object 2 a band in rows 3..5 from it to column 10:
    // the band's two corners on the left are junctions (1, 2, background) 2 apart, those on
    // the right plain corners; the image's edge meets object 1's boundary at two more.
    let (w, h) = (12, 8);
    let mut labels = vec![BACKGROUND; w * h];
    for y in 0..h {
        for x in 0..w {
            if x < 5 {
                labels[y * w + x] = 1;
            } else if (3..5).contains(&y) && x < 10 {
                labels[y * w + x] = 2;
            }
        }
    }
    let group = |j: &Junctions, x: i64, y: i64| j.group_at(x, y).unwrap_or_else(|| panic!("({x}, {y})"));
    let near = Junctions::new(&labels, w, h, 3.0);
    assert_eq!(group(&near, 5, 3), group(&near, 5, 5));
    assert_eq!(near.point[group(&near, 5, 3) as usize], DVec2::new(5.0, 4.0));
    assert_ne!(group(&near, 5, 3), group(&near, 5, 0), "3 steps, but a group within 3 x 3");
    assert_ne!(group(&near, 5, 0), group(&near, 5, 8), "8 steps along object 1: apart");
    assert!(near.group_at(8, 3).is_none() && near.group_at(10, 3).is_none() && near.group_at(2, 2).is_none());
    let short = Junctions::new(&labels, w, h, 1.0);
    assert_ne!(group(&short, 5, 3), group(&short, 5, 5));
    // The band's ring: its edges from the left junctions' one point to its right corners,
    // but no edge between the two junctions.
    let band: Vec<bool> = labels.iter().map(|&l| l == 2).collect();
    let rings = trace(&band, w, h);
    assert_eq!(rings.len(), 1);
    let ring = simplify_between(&rings[0], &near, 0.5, 1.0);
    assert!(ring.contains(&DVec2::new(5.0, 4.0)), "{ring:?}");
    assert!(!ring.contains(&DVec2::new(5.0, 3.0)) && !ring.contains(&DVec2::new(5.0, 5.0)), "{ring:?}");
    assert!(ring.contains(&DVec2::new(10.0, 3.0)) && ring.contains(&DVec2::new(10.0, 5.0)), "{ring:?}");
    assert_eq!(ring.len(), 3, "{ring:?}");
}

/// An open chain's short edges merge like a ring's, but its two ends stay.
#[test]
fn a_chain_keeps_its_ends_when_short_edges_merge() {
    let chain: Vec<DVec2> =
        [(0.0, 0.0), (1.0, 0.5), (10.0, 1.0), (20.0, 0.0), (21.0, 0.4)].map(|(x, y)| DVec2::new(x, y)).to_vec();
    let merged = merge_short(chain.clone(), false, 5.0);
    assert_eq!((merged[0], *merged.last().unwrap()), (chain[0], chain[4]), "{merged:?}");
    assert!(merged.windows(2).all(|e| (e[1] - e[0]).length() >= 5.0), "{merged:?}");
    // Two points stay two points, however short.
    assert_eq!(merge_short(chain[..2].to_vec(), false, 5.0).len(), 2);
}

/// A thin frame between a window and a body goes to the part it borders most; a thin pole
/// against the background keeps its outline; a thick part is left alone.
#[test]
fn thin_parts_between_objects_join_a_neighbour() {
    let (w, h) = (40, 30);
    let mut labels = vec![BACKGROUND; w * h];
    for y in 0..h {
        for x in 0..w {
            let i = y * w + x;
            if (2..28).contains(&x) && (2..28).contains(&y) {
                // The body (1), a window (2) in it, framed 2 px wide (3).
                labels[i] = if (8..22).contains(&x) && (8..22).contains(&y) {
                    2
                } else if (6..24).contains(&x) && (6..24).contains(&y) {
                    3
                } else {
                    1
                };
            } else if (33..35).contains(&x) && (3..27).contains(&y) {
                labels[i] = 4; // a pole, 2 px wide
            }
        }
    }
    let mut cleaned = labels.clone();
    clean_labels(&mut cleaned, w, h, 3, 5.0);
    // The frame (outer ring 18 x 18, inner 14 x 14: 128 pixels, bordering the body on 72
    // edges and the window on 56) joins the body.
    assert!(!cleaned.contains(&3));
    assert!((0..w * h).all(|i| labels[i] != 3 || cleaned[i] == 1));
    assert!((0..w * h).all(|i| labels[i] == 3 || cleaned[i] == labels[i]), "only the frame changes");
    // Thinner than a width of 1: nothing is thin.
    let mut kept = labels.clone();
    clean_labels(&mut kept, w, h, 3, 1.0);
    assert_eq!(kept, labels);
}
