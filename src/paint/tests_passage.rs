//! Passage against the per-pixel form it had before its pairs were kept with the edges
//! (session 6): the same bits on random facet maps, canvases and settings, opaque and
//! transparent, on 1 and 3 threads, through a kept session's inputs and a one-off's.

use glam::Vec3;
use proptest::prelude::*;
use rayon::prelude::*;

use super::border_profile::drawn_line;
use super::edge_smoothing;
use super::noise::Grid2;
use super::passage::{BLEND, LOST_PERIOD, Passage, SALT, neighbours_rdlu};
use super::planes::smoothstep;
use super::region_means::region_means;
use super::tests::voronoi;
use super::*;
use crate::distance::NO_FEATURE;
use crate::error::Result;
use crate::facets::FacetMap;
use crate::film::Film;
use crate::util::edge_line;
use crate::util::rng::{splitmix64, sub_seed, unit_f64};

/// Passage as it was: every pixel near an edge finds its pair and the pair's values itself.
struct Reference(Passage);

impl Effect for Reference {
    fn name(&self) -> &'static str {
        "passage (reference)"
    }

    fn apply(&self, canvas: &mut Canvas<'_>, ctx: &PaintContext) -> Result<()> {
        let (w, h) = (canvas.width as usize, canvas.height as usize);
        let md = self.0.width;
        if w == 0 || h == 0 || !(md > 0.0) {
            return Ok(());
        }
        let ids = ctx.facets.map(|f| &f.ids[..]);
        // Regions (facet << 32 | object): ordered by (facet, object), the tie-break when both
        // sides match in value.
        // (A one-off render reads the facet ids and hits instead: no regions buffer held.)
        let regions = ctx.inputs_kept().then(|| ctx.regions(w * h));
        let hits = (ctx.hits.len() == w * h).then_some(ctx.hits);
        let ids = ids.filter(|d| d.len() == w * h);
        let key = |i: usize| match &regions {
            Some(r) => r[i],
            None => ((ids.map_or(0, |d| d[i]) as u64) << 32) | hits.map_or(0, |o| o[i].object) as u64,
        };
        let same = |i: usize, j: usize| match &regions {
            Some(r) => r[i] == r[j],
            None => ids.is_none_or(|d| d[i] == d[j]) && hits.is_none_or(|o| o[i].object == o[j].object),
        };
        let edges = ctx.edges(w as u32, h as u32, md);
        let (dist, near) = (&edges.dist, &edges.near);
        // The colours before (what the other side blends in; alpha is not read), and each
        // region's value, its mean colour's.
        let before: Vec<Vec3> = canvas.px.par_iter().map(|p| p.truncate()).collect();
        let all: Vec<u64> = (0..w * h).map(key).collect();
        let means = region_means(&*canvas.px, &all, &Coverage(canvas.coverage.as_deref()));
        let value = |i: usize| means.get(&key(i)).map_or(0.0, |m| luminance(*m).max(0.0));
        // A 4-neighbour of q (right, down, left, up: fixed order) that is (`want` = true) or
        // is not in the region of `of`.
        let neighbour = |q: usize, of: usize, want: bool| -> Option<usize> {
            neighbours_rdlu(w, h, q).into_iter().flatten().find(|&n| same(n, of) == want)
        };
        // How far in each side's value is read: a few pixels, at least one.
        let step = (md / 4.0).round().max(1.0) as i64;
        let inward = |from: usize, dx: i64, dy: i64| -> usize {
            let (x, y) = ((from % w) as i64 + dx * step, (from / w) as i64 + dy * step);
            if x < 0 || y < 0 || x >= w as i64 || y >= h as i64 {
                return from;
            }
            let j = y as usize * w + x as usize;
            if same(j, from) { j } else { from }
        };
        let seed = sub_seed(self.0.seed, SALT);
        let period = (LOST_PERIOD * ((w * h) as f32).sqrt()).max(4.0);
        let grid = Grid2::new(seed, (0.0, w as f32 / period), (0.0, h as f32 / period));
        // What a pair (a, b) facing each other across an edge gives: b's inward pixel and
        // the two sides' values (a on the pixel's side; the tie-break's region of the pixel
        // is a's); and the lost-and-found value of each edge pixel q. Each depends on the
        // pair or the edge pixel alone, so it is computed once per edge pixel (`memo` for
        // the four neighbours b of an edge pixel a) instead of once per pixel near it.
        let sides = |a: usize, b: usize| -> (usize, f32, f32) {
            let (dx, dy) = ((b % w) as i64 - (a % w) as i64, (b / w) as i64 - (a / w) as i64);
            let (nx, ny) = if dx.abs() >= dy.abs() { (dx.signum(), 0) } else { (0, dy.signum()) };
            (inward(b, nx, ny), value(a), value(b))
        };
        let lost_found =
            |q: usize| smoothstep(0.25, 0.75, grid.value2(seed, (q % w) as f32 / period, (q / w) as f32 / period));
        // Edge pixels are their own nearest edge pixel.
        let mut slot = vec![u32::MAX; w * h];
        let mut edge_pixels = Vec::new();
        for (i, s) in slot.iter_mut().enumerate() {
            if near[i] as usize == i {
                *s = edge_pixels.len() as u32;
                edge_pixels.push(i);
            }
        }
        struct Memo {
            lost_found: f32,
            /// Per neighbour b (right, down, left, up) of a: (b_in, va, vb); b_in u32::MAX
            /// where there is no such neighbour in another region.
            pairs: [(u32, f32, f32); 4],
        }
        let memo: Vec<Memo> = edge_pixels
            .par_iter()
            .map(|&a| {
                let nb = neighbours_rdlu(w, h, a);
                Memo {
                    lost_found: lost_found(a),
                    pairs: nb.map(|b| {
                        b.filter(|&b| !same(a, b)).map_or((u32::MAX, 0.0, 0.0), |b| {
                            let (b_in, va, vb) = sides(a, b);
                            (b_in as u32, va, vb)
                        })
                    }),
                }
            })
            .collect();
        // The memo of adjacent pixels a, b in different regions, or None.
        let memo_of = |a: usize, b: usize| -> Option<(usize, f32, f32)> {
            let m = memo.get(slot[a] as usize)?;
            let k = if b == a + 1 {
                0
            } else if b == a + w {
                1
            } else if b + 1 == a {
                2
            } else if b + w == a {
                3
            } else {
                return None;
            };
            let (b_in, va, vb) = m.pairs[k];
            (b_in != u32::MAX).then_some((b_in as usize, va, vb))
        };
        let transparent = canvas.transparent;
        let window = edge_line::Window::new();
        let (coverage, px) = canvas.coverage_and_pixels();
        px.par_chunks_mut(w).enumerate().for_each(|(y, row)| {
            for (x, p) in row.iter_mut().enumerate() {
                let i = y * w + x;
                let (q, d) = (near[i], dist[i]);
                if q == NO_FEATURE || d >= md {
                    continue;
                }
                let q = q as usize;
                // The distance to the edge's smoothed line where q is of this pixel's region.
                let d = match window.line(w, h, q, |j| same(j, q)).filter(|_| same(i, q)) {
                    Some(l) => (l.at(x as f32 - (q % w) as f32, y as f32 - (q / w) as f32) - window.grid_offset)
                        .clamp((d - 1.0).max(0.0), d + 1.0),
                    None => d,
                };
                // The pair facing each other across the edge: a on this pixel's side, b across.
                let (a, b) = if same(i, q) {
                    match neighbour(q, q, false) {
                        Some(b) => (q, b),
                        None => continue,
                    }
                } else {
                    (neighbour(q, i, true).unwrap_or(i), q)
                };
                // key(i) is key(a): a is this pixel or a pixel of its region.
                let (b_in, va, vb) = memo_of(a, b).unwrap_or_else(|| sides(a, b));
                let dark_side = if va != vb { va < vb } else { key(a) < key(b) };
                let lf = memo.get(slot[q] as usize).map_or_else(|| lost_found(q), |m| m.lost_found);
                let line = Passage::line(va, vb, lf);
                // Passage: the sides blend where the line is lost, within md / 2 of the edge.
                let wb = 0.5 * md;
                if d < wb && coverage.is_painted(i) && coverage.is_painted(b_in) {
                    let beta = BLEND * (1.0 - line) * (1.0 - d / wb).powi(2);
                    *p = p.truncate().lerp(before[b_in], beta).extend(p.w);
                }
                if dark_side && self.0.strength > 0.0 {
                    darken(p, 1.0 - self.0.strength * line * (1.0 - drawn_line(d, md)), transparent);
                }
            }
        });
        // Last, the edges' steps smoothed (`edge_smoothing`, tested on its own).
        let regions: Vec<u64> = (0..w * h).map(key).collect();
        let far = ctx.edges(w as u32, h as u32, md.max(edge_smoothing::REACH));
        edge_smoothing::smooth_edges(canvas, &regions, &far.dist);
        Ok(())
    }
}

/// A random canvas: smooth planes of colour with noise, some pixels clear when `transparent`.
fn canvas(w: u32, h: u32, seed: u64, transparent: bool) -> Film {
    let mut f = Film::new(w, h, 1);
    for (i, (p, hit)) in f.color.iter_mut().zip(f.hits.iter_mut()).enumerate() {
        let r = |k: u64| unit_f64(splitmix64(seed ^ splitmix64(i as u64 * 7 + k))) as f32;
        let (x, y) = ((i as u32 % w) as f32, (i as u32 / w) as f32);
        let c = Vec3::new(0.3 + 0.2 * (x * 0.05).sin(), 0.4 + 0.3 * (y * 0.07).cos(), 0.2 + 0.1 * r(1));
        // A few flat plateaus so that both sides of some edges have the same value (ties).
        let c = if r(2) < 0.3 { Vec3::splat(0.5) } else { c };
        let a = if transparent && r(3) < 0.2 { 0.0 } else { 1.0 };
        *p = c.extend(a);
        hit.object = (x > w as f32 * 0.6 && y < h as f32 * 0.4) as u32;
    }
    f
}

fn paint_both(passage: Passage, frame: &Film, facets: Option<&FacetMap>, transparent: bool, threads: usize) {
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
    let bg = [0.62, 0.56, 0.46];
    let new = Painter::from_effects(vec![Box::new(Passage { ..passage })], bg, transparent);
    let old = Painter::from_effects(vec![Box::new(Reference(passage))], bg, transparent);
    let (mut a, mut b, mut c) = (frame.clone(), frame.clone(), frame.clone());
    pool.install(|| new.apply(&mut a, facets, None)).unwrap();
    // Through kept inputs: a narrower width, then this one (the edges made again, at twice
    // it), then a wider one within that (reusing the edges and the pairs).
    let kept = PaintInputs::kept_for_changes();
    let with_width = |f: f32| {
        Painter::from_effects(vec![Box::new(Passage { width: passage.width * f, ..passage })], bg, transparent)
    };
    let mut d = frame.clone();
    pool.install(|| with_width(0.5).apply_with(&mut d, facets, None, &kept)).unwrap();
    pool.install(|| new.apply_with(&mut c, facets, None, &kept)).unwrap();
    // The same width on other colours (a change upstream), twice: the second run over these
    // edges keeps the sides' geometry, the third reads it.
    let mut other = frame.clone();
    for p in &mut other.color {
        *p = (p.truncate() * 0.6 + Vec3::new(0.1, 0.0, 0.2)).extend(p.w);
    }
    let (mut g, mut g2, mut g_ref) = (other.clone(), frame.clone(), other.clone());
    pool.install(|| new.apply_with(&mut g, facets, None, &kept)).unwrap();
    pool.install(|| new.apply_with(&mut g2, facets, None, &kept)).unwrap();
    old.apply(&mut g_ref, facets, None).unwrap();
    let mut e = frame.clone();
    pool.install(|| with_width(1.5).apply_with(&mut e, facets, None, &kept)).unwrap();
    let mut f = frame.clone();
    Painter::from_effects(
        vec![Box::new(Reference(Passage { width: passage.width * 1.5, ..passage }))],
        bg,
        transparent,
    )
    .apply(&mut f, facets, None)
    .unwrap();
    old.apply(&mut b, facets, None).unwrap();
    let bits = super::tests_plane::bits;
    assert_eq!(bits(&a), bits(&b), "one-off");
    assert_eq!(bits(&c), bits(&b), "kept inputs");
    assert_eq!(bits(&e), bits(&f), "kept inputs, wider");
    assert_eq!(bits(&g), bits(&g_ref), "kept inputs, other colours");
    assert_eq!(bits(&g2), bits(&b), "kept inputs, the geometry read");
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(40))]
    #[test]
    fn passage_gives_the_per_pixel_forms_bits(
        w in 1u32..90,
        h in 1u32..70,
        cells in 1u32..40,
        seed in 0u64..1000,
        width in 0.5f32..20.0,
        strength in 0.0f32..1.0,
        transparent in any::<bool>(),
        faceted in any::<bool>(),
        threads in 1usize..4,
    ) {
        let frame = canvas(w, h, seed, transparent);
        let facets = voronoi(w, h, cells, seed);
        let p = Passage { width, strength, seed };
        paint_both(p, &frame, faceted.then_some(&facets), transparent, threads);
    }
}

#[test]
fn passage_gives_the_per_pixel_forms_bits_on_a_large_map() {
    let (w, h) = (400u32, 300u32);
    let facets = voronoi(w, h, 60, 11);
    for (k, transparent) in [false, true].into_iter().enumerate() {
        let frame = canvas(w, h, 5 + k as u64, transparent);
        for width in [11.0, 3.0, 24.0] {
            let p = Passage { width, strength: 0.8, seed: 3 };
            paint_both(p, &frame, Some(&facets), transparent, 2);
        }
    }
}
