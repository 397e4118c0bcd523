use super::sampler::strata;
use super::*;

#[test]
fn strata_are_as_square_as_possible() {
    assert_eq!(strata(1), (1, 1));
    assert_eq!(strata(4), (2, 2));
    assert_eq!(strata(8), (4, 2));
    assert_eq!(strata(7), (7, 1));
    assert_eq!(strata(16), (4, 4));
}

#[test]
fn the_centre_rooks_are_latin_leave_the_middle_and_vary() {
    let mut perms = std::collections::HashSet::new();
    for pixel in 0..1000u64 {
        let cells: Vec<(u32, u32)> = (0..3)
            .map(|s| {
                let o = centre_rook_offset(7, pixel, s);
                assert!((0.0..1.0).contains(&o.x) && (0.0..1.0).contains(&o.y), "{o}");
                ((o.x * 3.0) as u32, (o.y * 3.0) as u32)
            })
            .collect();
        // One per column and per row, none in the middle cell (the centre sample's).
        let (mut cols, mut rows) = ([0; 3], [0; 3]);
        for &(cx, cy) in &cells {
            cols[cx as usize] += 1;
            rows[cy as usize] += 1;
            assert_ne!((cx, cy), (1, 1), "pixel {pixel}: {cells:?}");
        }
        assert_eq!((cols, rows), ([1; 3], [1; 3]), "pixel {pixel}: {cells:?}");
        perms.insert(cells);
    }
    // All 4 such permutations are used.
    assert_eq!(perms.len(), 4);
}

#[test]
fn samples_are_stratified_and_in_the_pixel() {
    for spp in [2u32, 4, 6, 9, 16] {
        let (nx, ny) = strata(spp);
        let mut cells = vec![0; spp as usize];
        for s in 0..spp {
            let o = sample_offset(7, 123, s, spp);
            assert!((0.0..1.0).contains(&o.x) && (0.0..1.0).contains(&o.y));
            let cell = (o.y * ny as f64) as u32 * nx + (o.x * nx as f64) as u32;
            cells[cell as usize] += 1;
        }
        assert!(cells.iter().all(|&c| c == 1), "spp {spp}: {cells:?}");
    }
}

#[test]
fn single_sample_is_the_pixel_centre() {
    assert_eq!(sample_offset(1, 2, 0, 1), DVec2::splat(0.5));
    let p = screen_point(0, 0, DVec2::splat(0.5), 2, 2);
    assert_eq!(p, DVec2::new(-0.25, 0.25));
}

/// A film of `w x h` one-sample pixels, every one a hit on object 0 in mid grey.
fn grey_film(w: u32, h: u32) -> Film {
    let mut film = Film::new(w, h, 1);
    for (c, hit) in film.color.iter_mut().zip(&mut film.hits) {
        *c = Vec4::new(0.2, 0.2, 0.2, 1.0);
        *hit = PixelHit { tri: 0, object: 0, t: 1.0, normal: Vec3::Z, u: 0.0, v: 0.0 };
    }
    film
}

#[test]
fn only_pixels_whose_facet_neighbours_disagree_are_refined() {
    let (w, h) = (8u32, 6u32);
    let one_facet = vec![0u32; 48];
    let mut film = grey_film(w, h);
    assert!(pixels_to_refine(&film, &one_facet, 0.02).is_empty(), "a flat film needs no samples");
    assert_eq!(pixels_to_refine(&film, &one_facet, 0.0).len(), 48, "threshold 0: every pixel");
    // A change below the threshold (sRGB) is not refined; one above it refines the pixel
    // and its 8 neighbours.
    film.color[2 * 8 + 3] = Vec4::new(0.201, 0.2, 0.2, 1.0);
    assert!(pixels_to_refine(&film, &one_facet, 0.02).is_empty());
    film.color[2 * 8 + 3] = Vec4::new(0.5, 0.2, 0.2, 1.0);
    let want: Vec<u32> = (1..=3).flat_map(|y| (2..=4).map(move |x| y * 8 + x)).collect();
    assert_eq!(pixels_to_refine(&film, &one_facet, 0.02), want);
    // Another object (same colour) is a silhouette: refined with its neighbours.
    let mut film = grey_film(w, h);
    film.hits[0].object = 1;
    assert_eq!(pixels_to_refine(&film, &one_facet, 0.02), vec![0, 1, 8, 9]);
    // Across a facet border nothing is compared: columns 0..4 facet 0, 4..8 facet 1, each
    // flat but of different colours.
    let mut film = grey_film(w, h);
    let facets: Vec<u32> = (0..48).map(|i| (i % 8 >= 4) as u32).collect();
    for i in 0..48 {
        if facets[i] == 1 {
            film.color[i] = Vec4::new(0.9, 0.1, 0.1, 1.0);
        }
    }
    assert!(pixels_to_refine(&film, &facets, 0.02).is_empty());
}

/// The word-per-pixel comparison in shifted rows picks exactly the pixels the
/// plain loop over each pixel's facet neighbours picks, on random films with a few
/// facets, objects, misses and colours near the threshold.
#[test]
fn pixels_to_refine_matches_the_neighbour_loop() {
    let reference = |film: &Film, facets: &[u32], threshold: f32| -> Vec<u32> {
        let (w, h) = (film.width as usize, film.height as usize);
        let code = |i: usize| {
            let c = film.color[i];
            [c.x, c.y, c.z].map(|v| crate::scene::srgb::srgb8(v) as i32)
        };
        let limit = (threshold * 255.0).round().max(1.0) as i32;
        (0..w * h)
            .filter(|&i| {
                facet_neighbourhood(w, h, facets, i).any(|j| {
                    let (a, b) = (code(i), code(j));
                    j != i
                        && (film.hits[i].object != film.hits[j].object || (0..3).any(|c| (a[c] - b[c]).abs() > limit))
                })
            })
            .map(|i| i as u32)
            .collect()
    };
    let mut state = 7u64;
    let mut next = || {
        state = splitmix64(state);
        state
    };
    for (w, h) in [(1u32, 1u32), (1, 9), (9, 1), (2, 2), (37, 23), (64, 40)] {
        let n = (w * h) as usize;
        let mut film = grey_film(w, h);
        let facets: Vec<u32> = (0..n).map(|_| (next() % 3) as u32).collect();
        for i in 0..n {
            let r = next();
            film.color[i] = Vec4::new(0.2 + (r % 8) as f32 * 0.002, 0.2, 0.2 + ((r >> 8) % 3) as f32 * 0.05, 1.0);
            match (r >> 16) % 10 {
                0 => film.hits[i] = PixelHit::MISS,
                1 => film.hits[i].object = 1,
                _ => {}
            }
        }
        for threshold in [0.005, 0.02, 0.1] {
            let want = reference(&film, &facets, threshold);
            assert_eq!(pixels_to_refine(&film, &facets, threshold), want, "{w} x {h}, threshold {threshold}");
            if w * h > 100 {
                assert!(!want.is_empty() && want.len() < n, "{w} x {h}: some refined, not all");
            }
        }
    }
}

/// The built-in still life, its default stage parameters at `width x height` and one sample
/// per pixel, and its lit pre-render.
fn still_life_prerender(
    width: u32,
    height: u32,
) -> (crate::pipeline::Prepared, crate::pipeline::StageParams, crate::pipeline::PreRender) {
    use crate::pipeline::{Prepared, Shading, StageParams, Timings, prerender};
    use crate::settings::Settings;
    let prep = Prepared::load(None).unwrap();
    // Shadows on (the default look casts none): the shadow rays are what these tests check.
    let params = StageParams::new(&Settings { width, height, spp: 1, shadows: true, ..Settings::default() });
    let pre =
        prerender(&prep, &params.framing, &params.trace, Shading::Lit, &Progress::silent(), &mut Timings::default())
            .unwrap();
    (prep, params, pre)
}

/// An ascending list is traced in place by bands of rows; it gives the film the
/// pixels the chunked trace and copy (any order) gives it, sparse shadow rays included,
/// on 1 and 3 threads.
#[test]
fn subset_traced_in_place_matches_the_chunked_trace() {
    let (prep, params, pre) = still_life_prerender(163, 97);
    let tracer = pre.view.tracer(&prep, &params.trace);
    let camera = pre.view.framed.camera.as_ref();
    // A moved ray: the camera's, shifted, so the subset's pixels really change.
    let rays = |_: usize, p: DVec2| camera.ray(p + DVec2::new(0.01, 0.0));
    let (w, n) = (163usize, 163 * 97);
    let facets: Vec<u32> = (0..n).map(|i| ((i % w) / 20 + (i / w) / 15) as u32 % 4).collect();
    let list: Vec<u32> = (0..n as u32).filter(|&i| facets[i as usize] == 1).collect();
    // Reversed in fives: not ascending, so the chunked trace and `write_subset` store it.
    let mut unordered = list.clone();
    unordered.chunks_mut(5).for_each(|c| c.reverse());
    for threads in [1, 3] {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        let run = |l: &[u32]| {
            let mut film = pre.film.clone();
            pool.install(|| tracer.render(&mut film, &rays, Some(l), Some(&facets), &Progress::silent()));
            film
        };
        let (a, b) = (run(&list), run(&unordered));
        assert!(a.hits != pre.film.hits, "the subset was traced again");
        assert_eq!(
            a.color.iter().map(|c| c.to_array().map(f32::to_bits)).collect::<Vec<_>>(),
            b.color.iter().map(|c| c.to_array().map(f32::to_bits)).collect::<Vec<_>>()
        );
        assert!(a.hits == b.hits && a.occlusion == b.occlusion && a.samples == b.samples);
    }
}

/// The whole film traced by `render_rows` (centre rays in 2 x 2 packets) and the
/// anti-aliasing (each pixel's rays as one packet) give the pixels tracing one ray at a
/// time gives (the chunked subset trace; `supersample`'s rays one by one), bit for bit, on
/// odd and even sizes, lit (the coarse shadow grid first) and hits only.
#[test]
fn packets_trace_what_single_rays_trace() {
    for (w, h) in [(163u32, 97u32), (64, 48), (7, 5)] {
        let (prep, params, pre) = still_life_prerender(w, h);
        let camera = pre.view.framed.camera.as_ref();
        let rays = |_: usize, p: DVec2| camera.ray(p);
        let n = (w * h) as usize;
        for lit in [true, false] {
            let mut tracer = pre.view.tracer(&prep, &params.trace);
            if !lit {
                tracer.rig = None;
            }
            let mut packets = Film::to_be_traced(w, h, 1);
            tracer.render(&mut packets, &rays, None, None, &Progress::silent());
            // Every pixel, not ascending: traced one by one in chunks.
            let mut list: Vec<u32> = (0..n as u32).collect();
            list.chunks_mut(3).for_each(|c| c.reverse());
            let mut single = Film::to_be_traced(w, h, 1);
            if lit {
                // As `render_known` does for a whole film: the grid, then the rest.
                let on_grid = |i: u32| (i % w).is_multiple_of(2) && (i / w).is_multiple_of(2);
                let grid: Vec<u32> = list.iter().copied().filter(|&i| on_grid(i)).collect();
                let rest: Vec<u32> = list.iter().copied().filter(|&i| !on_grid(i)).collect();
                tracer.render_subset(&mut single, &rays, &grid, None, None, &Progress::silent());
                let known: Vec<Known> = rest.iter().map(|&i| coarse_occlusion(&single, &[], i as usize)).collect();
                tracer.render_subset(&mut single, &rays, &rest, Some(&known), None, &Progress::silent());
            } else {
                tracer.render_subset(&mut single, &rays, &list, None, None, &Progress::silent());
            }
            let bits = |f: &Film| f.color.iter().map(|c| c.to_array().map(f32::to_bits)).collect::<Vec<_>>();
            assert_eq!(bits(&packets), bits(&single), "{w} x {h}, lit {lit}");
            assert!(packets.hits == single.hits && packets.occlusion == single.occlusion, "{w} x {h}, lit {lit}");
            assert!(packets.hits.iter().filter(|h| h.tri != NO_HIT).count() > n / 4, "the rays must mostly hit");
            if lit {
                // Anti-aliasing of every pixel: its rays as packets, against one by one.
                let facets = vec![0u32; n];
                let all: Vec<u32> = (0..n as u32).collect();
                for spp in [4u32, 6] {
                    let mut aa = packets.clone();
                    tracer.antialias(&mut aa, &rays, &all, &facets, spp, &Progress::silent());
                    for i in 0..n {
                        let known = agreed_occlusion(&packets, &facets, i);
                        let centre = (spp == 4).then(|| packets.color[i]);
                        let (x, y) = (i as u32 % w, i as u32 / w);
                        let traced = if centre.is_some() { 3 } else { spp };
                        let (mut color, mut covered) = centre.map_or((Vec3::ZERO, 0.0), |c| (c.truncate(), c.w));
                        for s in 0..traced {
                            let off = match centre {
                                Some(_) => centre_rook_offset(tracer.seed, i as u64, s),
                                None => sample_offset(tracer.seed, i as u64, s, spp),
                            };
                            let (c, hit, _) = tracer.sample(&rays(i, screen_point(x, y, off, w, h)), known);
                            color += c;
                            covered += hit.is_some() as u32 as f32;
                        }
                        let want = (color / spp as f32).extend(covered / spp as f32);
                        assert_eq!(aa.color[i].to_array().map(f32::to_bits), want.to_array().map(f32::to_bits));
                    }
                    assert!(aa.color != packets.color, "anti-aliasing changed some pixels");
                }
            }
        }
    }
}

/// The loops gathering the neighbours of `agreed_occlusion` and `coarse_occlusion`
/// agree with `facet_neighbourhood` and `coarse_grid_around` on random films of odd and
/// even sizes, with and without facets.
#[test]
fn neighbour_loops_match_the_neighbourhood_iterators() {
    let mut state = 11u64;
    let mut next = || {
        state = splitmix64(state);
        state
    };
    for (w, h) in [(1u32, 1u32), (1, 6), (7, 1), (2, 3), (9, 8), (16, 11)] {
        let n = (w * h) as usize;
        let mut film = grey_film(w, h);
        for i in 0..n {
            let r = next();
            film.occlusion[i] = (r % 4) as u8;
            match (r >> 8) % 8 {
                0 => film.hits[i] = PixelHit::MISS,
                1 => film.hits[i].object = 1,
                _ => {}
            }
        }
        let facets: Vec<u32> = (0..n).map(|_| (next() % 2) as u32).collect();
        let key = |k: Known| (k.object, k.occlusion);
        for i in 0..n {
            let (wu, hu) = (w as usize, h as usize);
            let want = agree(&film, facet_neighbourhood(wu, hu, &facets, i));
            assert_eq!(key(agreed_occlusion(&film, &facets, i)), key(want), "{w} x {h}, pixel {i}");
            for ids in [&facets[..], &[]] {
                let same = |j: &usize| ids.is_empty() || ids[*j] == ids[i];
                let want = agree(&film, coarse_grid_around(wu, hu, i).filter(same));
                assert_eq!(key(coarse_occlusion(&film, ids, i)), key(want), "{w} x {h}, pixel {i}");
            }
        }
    }
}

#[test]
fn occlusion_is_known_only_where_neighbours_agree() {
    let mut film = grey_film(4, 4);
    let facets = vec![0u32; 16];
    // Light 0 blocked everywhere, light 1 blocked at one pixel only.
    film.occlusion.iter_mut().for_each(|o| *o = 0b01);
    film.occlusion[5] = 0b11;
    let k = agreed_occlusion(&film, &facets, 15);
    assert_eq!(k.occlusion.known & 0b11, 0b11, "pixel 15's neighbourhood agrees on both lights");
    assert_eq!(k.occlusion.blocked & 0b11, 0b01);
    let k = agreed_occlusion(&film, &facets, 10);
    assert_eq!(k.occlusion.known & 0b11, 0b01, "pixel 10 sees pixel 5: light 1 must be traced");
    assert_eq!(k.occlusion.blocked & 0b01, 0b01);
    // Only for samples on the same object.
    let other = Hit { t: 1.0, tri: 0, object: 3, u: 0.0, v: 0.0 };
    assert_eq!(k.for_hit(&other), Occlusion::TRACE);
    // Neighbours on two objects: nothing known.
    film.hits[1].object = 2;
    assert_eq!(agreed_occlusion(&film, &facets, 0).occlusion, Occlusion::TRACE);
}

/// The coarse-grid shadow rays (one sample per pixel: shadow rays only where coarse
/// neighbours disagree) against casting every one, on the default still life with its
/// cast shadows: the grid pixels are exact, and the others differ only at a few.
#[test]
fn coarse_shadow_rays_match_casting_every_one() {
    let (prep, params, pre) = still_life_prerender(160, 120);
    assert!(params.trace.shadows);
    let coarse = pre.film;
    let tracer = pre.view.tracer(&prep, &params.trace);
    let camera = pre.view.framed.camera.as_ref();
    let mut full = Film::new(160, 120, 1);
    tracer.render_all(&mut full, &|_, p| camera.ray(p), &Progress::silent());
    let blocked = full.occlusion.iter().filter(|&&o| o != 0).count();
    let lit = full.occlusion.iter().zip(&full.hits).filter(|(o, h)| **o == 0 && h.is_hit()).count();
    assert!(blocked > 200 && lit > 200, "the still life has shadows and light: {blocked} blocked, {lit} lit");
    let mut wrong = 0;
    for i in 0..full.pixel_count() {
        let on_grid = (i % 160) % 2 == 0 && (i / 160) % 2 == 0;
        assert_eq!(coarse.hits[i].tri, full.hits[i].tri);
        if on_grid {
            assert_eq!(coarse.color[i], full.color[i], "grid pixel {i}");
            assert_eq!(coarse.occlusion[i], full.occlusion[i], "grid pixel {i}");
        } else if coarse.occlusion[i] != full.occlusion[i] {
            wrong += 1;
        }
    }
    assert!(wrong * 200 < full.pixel_count(), "{wrong} pixels' shadows differ (of {})", full.pixel_count());
}

/// A deferred pre-render (hits only) shaded afterwards on some pixels gives those pixels
/// bit for bit what the lit pre-render gives them, shadows of the coarse grid included,
/// and the hits of every pixel; on 1 and 3 threads.
#[test]
fn deferred_shading_matches_the_lit_pre_render() {
    use crate::pipeline::{Prepared, Shading, StageParams, Timings, prerender};
    use crate::settings::Settings;
    let prep = Prepared::load(None).unwrap();
    let s = Settings { width: 161, height: 119, spp: 1, shadows: true, ..Settings::default() };
    let params = StageParams::new(&s);
    assert!(params.trace.shadows);
    let pre = |shading| {
        prerender(&prep, &params.framing, &params.trace, shading, &Progress::silent(), &mut Timings::default()).unwrap()
    };
    let lit = pre(Shading::Lit);
    let (w, n) = (161usize, 161 * 119);
    // Blocks of 7 x 5 pixels kept, the others left (as facets the re-trace takes).
    let kept: Vec<u32> =
        (0..n as u32).filter(|&i| !((i as usize % w) / 7 + (i as usize / w) / 5).is_multiple_of(3)).collect();
    let blocked = kept.iter().filter(|&&i| lit.film.occlusion[i as usize] != 0).count();
    assert!(blocked > 100 && kept.len() > n / 2, "shadows among the kept pixels: {blocked}");
    for threads in [1, 3] {
        let pool = rayon::ThreadPoolBuilder::new().num_threads(threads).build().unwrap();
        let mut deferred = pool.install(|| pre(Shading::Deferred));
        assert!(deferred.unshaded && !lit.unshaded);
        assert_eq!(deferred.film.hits, lit.film.hits, "the hits need no lights");
        let tracer = deferred.view.tracer(&prep, &params.trace);
        let camera = deferred.view.framed.camera.as_ref();
        let rays = camera.centre_rays(161, 119);
        pool.install(|| tracer.shade_traced(&mut deferred.film, &*rays, &kept, &Progress::silent()));
        for &i in &kept {
            let i = i as usize;
            assert_eq!(
                deferred.film.color[i].to_array().map(f32::to_bits),
                lit.film.color[i].to_array().map(f32::to_bits),
                "pixel {i}"
            );
            assert_eq!(deferred.film.occlusion[i], lit.film.occlusion[i], "pixel {i}");
            assert_eq!(deferred.film.hits[i], lit.film.hits[i]);
            assert_eq!(deferred.film.samples[i], lit.film.samples[i]);
        }
    }
}

/// `write_subset` in parallel bands stores what the serial loop stores, for lists
/// long enough to take the parallel path and for short or unordered ones.
#[test]
fn write_subset_in_bands_matches_the_serial_loop() {
    let (w, h, spp) = (600u32, 400u32, 2usize);
    let fill = |i: u32| {
        let hit = PixelHit { tri: i, object: i % 5, t: i as f32 * 0.5, normal: Vec3::Y, u: 0.25, v: 0.5 };
        (Vec4::splat(i as f32), hit, (i % 7) as u8)
    };
    let stride3: Vec<u32> = (0..w * h).filter(|i| i % 3 == 0).collect();
    let short: Vec<u32> = (0..w * h).filter(|i| i % 17 == 0).take(5000).collect();
    let mut unordered = stride3.clone();
    unordered.swap(10, 20_000);
    for list in [stride3, short, unordered] {
        let chunks: Vec<SubsetChunk> = list
            .chunks(CHUNK)
            .map(|c| {
                let out = c.iter().map(|&i| fill(i)).collect();
                let samples = c
                    .iter()
                    .flat_map(|&i| (0..spp as u32).map(move |s| SampleHit { tri: i * 2 + s, u: 0.1, v: 0.2 }))
                    .collect();
                (out, samples)
            })
            .collect();
        let mut want = Film::new(w, h, spp as u32);
        for (chunk, (out, samples)) in list.chunks(CHUNK).zip(&chunks) {
            for (k, &i) in chunk.iter().enumerate() {
                let i = i as usize;
                (want.color[i], want.hits[i], want.occlusion[i]) = out[k];
                want.samples[i * spp..(i + 1) * spp].copy_from_slice(&samples[k * spp..(k + 1) * spp]);
            }
        }
        let mut got = Film::new(w, h, spp as u32);
        write_subset(&mut got, &list, chunks);
        assert!(got.color == want.color && got.hits == want.hits, "{} pixels", list.len());
        assert!(got.occlusion == want.occlusion && got.samples == want.samples);
    }
}

#[test]
fn seeds_change_the_jitter() {
    assert_ne!(sample_offset(1, 5, 0, 4), sample_offset(2, 5, 0, 4));
    assert_eq!(sample_offset(1, 5, 0, 4), sample_offset(1, 5, 0, 4));
}
