//! Shadow inference: the occlusion a pixel's neighbours agree on, and the coarse grid whose
//! shadow rays the pixels between take.

use super::*;

/// The occlusion of some lights, known across a pixel for samples that hit `object`.
#[derive(Clone, Copy, Debug)]
pub(super) struct Known {
    pub(super) occlusion: Occlusion,
    pub(super) object: u32,
}

impl Known {
    pub(super) const NONE: Known = Known { occlusion: Occlusion::TRACE, object: NO_HIT };

    /// What is known for a sample that hit `h` (nothing on another object).
    #[inline]
    pub(super) fn for_hit(&self, h: &Hit) -> Occlusion {
        if h.object == self.object { self.occlusion } else { Occlusion::TRACE }
    }
}

/// The lights the pixels `js` that hit all agree on, when they hit one object.
pub(super) fn agree(film: &Film, js: impl Iterator<Item = usize>) -> Known {
    let (mut all_blocked, mut any_blocked, mut object) = (u8::MAX, 0u8, NO_HIT);
    for j in js {
        let hit = &film.hits[j];
        if !hit.is_hit() {
            continue;
        }
        if object != NO_HIT && hit.object != object {
            return Known::NONE;
        }
        object = hit.object;
        all_blocked &= film.occlusion[j];
        any_blocked |= film.occlusion[j];
    }
    if object == NO_HIT {
        return Known::NONE;
    }
    let known = all_blocked | !any_blocked;
    Known { occlusion: Occlusion { known, blocked: all_blocked & known }, object }
}

/// What the coarse grid (even x, even y) around pixel `i` agrees on, in its facet (`facets`
/// empty: one facet).
pub(super) fn coarse_occlusion(film: &Film, facets: &[u32], i: usize) -> Known {
    // `coarse_grid_around`'s pixels by plain loops, as `agreed_occlusion` gathers its own.
    let (w, h) = (film.width as usize, film.height as usize);
    let (x, y) = (i % w, i / w);
    let (lx, ly) = (x - x % 2, y - y % 2);
    let nx = if x % 2 == 1 && lx + 2 < w { 2 } else { 1 };
    let ny = if y % 2 == 1 && ly + 2 < h { 2 } else { 1 };
    let mut js = [0usize; 4];
    let mut n = 0;
    for dy in 0..ny {
        for dx in 0..nx {
            let j = (ly + 2 * dy) * w + lx + 2 * dx;
            if facets.is_empty() || facets[j] == facets[i] {
                js[n] = j;
                n += 1;
            }
        }
    }
    agree(film, js[..n].iter().copied())
}

/// The coarse shadow grid's pixels (even x, even y) `coarse_occlusion` reads for pixel `i` of
/// a `w` x `h` film: `i` itself on the grid, else the two or four grid pixels around it. A
/// session's re-trace reuses a pixel only while these keep their facet relation
/// (`pipeline::session`).
#[inline]
pub(crate) fn coarse_grid_around(w: usize, h: usize, i: usize) -> impl Iterator<Item = usize> {
    let (x, y) = (i % w, i / w);
    let around = |c: usize, n: usize| {
        let lo = c - c % 2;
        [Some(lo), (c % 2 == 1 && lo + 2 < n).then_some(lo + 2)]
    };
    let (xs, ys) = (around(x, w), around(y, h));
    ys.into_iter().flatten().flat_map(move |cy| xs.into_iter().flatten().map(move |cx| cy * w + cx))
}
