//! What the effects derive from the facet map and the hits alone, computed once and shared by
//! the effects of a chain (a session keeps it from chain to chain): each pixel's region, the
//! planes, the distance to the region edges, the brushwork's strokes, per-pixel factors.

use std::sync::{Arc, Mutex, OnceLock};

use super::context::PaintContext;
use rayon::prelude::*;

use super::{brushwork, passage, planes};
use crate::film::PixelHit;

/// What the effects derive from the facet map and the hits alone (not from the colour, nor
/// from the effects' strengths): each pixel's region, the planes, the distance to the
/// region edges. Computed on first use and shared by the effects of a chain; a session keeps
/// it across paint-only changes (`Painter::apply_with`), since the film and the facet map it
/// was made from did not change. Each entry holds the last value asked for (one seed, one
/// border width), so its memory stays bounded. A one-off render's (`Default`) keeps only
/// the planes (small): each effect's regions and edge distances are freed after it, as
/// before they were shared (tests/memory_bound.rs).
#[derive(Default)]
pub struct PaintInputs {
    keep: bool,
    /// Kept from chain to chain on the same film and facet map (`kept_for_changes`, a
    /// session's): its edges are made again at twice a wider limit asked for
    /// (`PaintContext::edges`), and effects keep per-pixel factors (`PaintContext::factors`).
    across_chains: bool,
    regions: Mutex<Option<Arc<Vec<u64>>>>,
    planes: Mutex<Option<(u64, Arc<Vec<planes::Plane>>)>>,
    edges: Mutex<Option<(u32, Arc<Edges>)>>,
    /// The brushwork's strokes and fragments (kept only).
    strokes: Mutex<Option<Arc<brushwork::StrokePlan>>>,
    /// The brushwork's key in the last chain (kept only): its strokes are recorded from the
    /// second chain with the same key on.
    strokes_seen: Mutex<Option<[u64; 3]>>,
    /// Per-pixel factors an effect derives from its settings alone, the last per effect
    /// (kept only, `PaintContext::factors`).
    factors: Mutex<Vec<Factors>>,
}

/// One effect's per-pixel factors and what they were made from: `lasting` ones depend on the
/// effect's settings and the image size alone (not the film nor the facet map), so they
/// outlive the inputs they were kept in (`PaintInputs::kept_for_changes_after`).
#[derive(Clone)]
struct Factors {
    effect: &'static str,
    key: [u64; 4],
    lasting: bool,
    values: Arc<Vec<f32>>,
}

/// The nearest region edge of every pixel within a distance (`distance::nearest_features`).
pub struct Edges {
    pub dist: Vec<f32>,
    pub near: Vec<u32>,
    /// Passage's pairs across these edges, made by its first run over them.
    pub passage: OnceLock<passage::Pairs>,
}

impl PaintInputs {
    /// Inputs kept from chain to chain (a session's).
    pub fn kept() -> PaintInputs {
        PaintInputs { keep: true, ..PaintInputs::default() }
    }

    /// Kept inputs that also expect the border width to change (a session's lane): edges made
    /// again for a wider border are made at twice its width (`PaintContext::edges`).
    pub fn kept_for_changes() -> PaintInputs {
        PaintInputs { keep: true, across_chains: true, ..PaintInputs::default() }
    }

    /// `kept_for_changes` for another film or facet map, taking over what `old` (the inputs
    /// of the previous one) holds that reads neither: the lasting per-pixel factors (the
    /// canvas weave).
    pub fn kept_for_changes_after(old: Option<&PaintInputs>) -> PaintInputs {
        let lasting = old
            .and_then(|o| o.factors.lock().ok().map(|f| f.iter().filter(|f| f.lasting).cloned().collect()))
            .unwrap_or_default();
        PaintInputs { factors: Mutex::new(lasting), ..PaintInputs::kept_for_changes() }
    }

    /// Whether each pixel's region is held (then no effect but chiaroscuro reads the film's
    /// hits: `Painter::reads_hits_from`).
    pub fn has_regions(&self) -> bool {
        self.regions.lock().is_ok_and(|r| r.is_some())
    }

    /// Bytes held.
    pub fn bytes(&self) -> u64 {
        let regions = self.regions.lock().map_or(0, |r| r.as_ref().map_or(0, |r| r.len() * 8));
        let planes =
            self.planes.lock().map_or(0, |p| p.as_ref().map_or(0, |(_, p)| p.len() * size_of::<planes::Plane>()));
        let edges = self.edges.lock().map_or(0, |e| {
            e.as_ref()
                .map_or(0, |(_, e)| e.dist.len() * 4 + e.near.len() * 4 + e.passage.get().map_or(0, |p| p.bytes()))
        });
        let strokes = self.strokes.lock().map_or(0, |s| s.as_ref().map_or(0, |s| s.bytes()));
        let factors = self.factors.lock().map_or(0, |f| f.iter().map(|f| f.values.len() * 4).sum());
        (regions + planes + edges + strokes + factors) as u64
    }
}

impl<'a> PaintContext<'a> {
    /// Each pixel's region: facet id << 32 | object id (0 without a facet map, 0 without
    /// hits), the background counting as one object; `pixels` of them.
    pub fn regions(&self, pixels: usize) -> Arc<Vec<u64>> {
        if let Some(r) = self.inputs.regions.lock().ok().and_then(|g| g.clone()) {
            return r;
        }
        let n = pixels;
        let ids = self.facets.map(|f| &f.ids[..]).filter(|d| d.len() == n);
        let hits = (self.hits.len() == n).then_some(self.hits);
        // A sequence's frames read which planes are open off the layout frame (`Held::open`).
        let held = self.held().and_then(|h| h.open.as_ref()).filter(|_| self.open_planes && ids.is_some());
        let made;
        let open: &[bool] = match (held, ids, hits) {
            (Some(open), _, _) => open,
            (None, Some(ids), Some(hits)) if self.open_planes => {
                made = open_planes(&figure_ground(ids, hits, self.facet_count()));
                &made
            }
            _ => &[],
        };
        let r: Arc<Vec<u64>> = Arc::new(
            (0..n)
                .into_par_iter()
                .map(|i| {
                    let f = ids.map_or(0, |d| d[i]);
                    let object = if open.get(f as usize).copied().unwrap_or(false) {
                        OPEN_REGION
                    } else {
                        hits.map_or(0, |h| h[i].object)
                    };
                    ((f as u64) << 32) | object as u64
                })
                .collect(),
        );
        if self.inputs.keep
            && let Ok(mut g) = self.inputs.regions.lock()
        {
            *g = Some(r.clone());
        }
        r
    }

    /// Whether the inputs are kept beyond this chain (a session's): then the regions are
    /// worth keeping in memory while an effect runs; otherwise an effect may read the facet
    /// map and the hits instead.
    pub fn inputs_kept(&self) -> bool {
        self.inputs.keep
    }

    /// Whether the inputs serve several chains (a session's, `PaintInputs::kept_for_changes`):
    /// then an effect's per-pixel factors are worth keeping (`factors`).
    pub fn kept_across_chains(&self) -> bool {
        self.inputs.across_chains
    }

    /// The facets as planes (`planes::planes`; one plane without a facet map) for `seed`.
    pub fn planes(&self, width: u32, pixels: usize, seed: u64) -> Arc<Vec<planes::Plane>> {
        if let Some((s, p)) = self.inputs.planes.lock().ok().and_then(|g| g.clone())
            && s == seed
        {
            return p;
        }
        let from = self.sequence.and_then(|s| s.planes_from).filter(|f| f.ids.len() == pixels).or(self.facets);
        let mut p = match from {
            Some(f) => planes::planes(width, &f.ids, self.facet_count().max(f.facet_count as usize), seed),
            None => planes::planes(width, &vec![0; pixels], 1, seed),
        };
        if let Some(shift) = self.sequence.and_then(|s| s.plane_shift) {
            for (plane, d) in p.iter_mut().zip(shift) {
                plane.centre += *d;
                let along = d.dot(plane.dark);
                plane.span = (plane.span.0 + along, plane.span.1 + along);
            }
        }
        if let Some((layout, still)) = self.sequence.and_then(|s| s.still_planes).filter(|(f, _)| f.ids.len() == pixels)
        {
            let held = planes::planes(width, &layout.ids, p.len().max(layout.facet_count as usize), seed);
            for ((plane, held), _) in p.iter_mut().zip(held).zip(still).filter(|(_, still)| **still) {
                *plane = held;
            }
        }
        let p = Arc::new(p);
        if let Ok(mut g) = self.inputs.planes.lock() {
            *g = Some((seed, p.clone()));
        }
        p
    }

    /// For every pixel within `limit` of a region edge (a pixel whose 4-neighbour is in another
    /// region), the nearest such pixel and its distance. Pixels at `limit` or farther may hold
    /// a nearest edge too: callers read only those closer than `limit`.
    ///
    /// A session's inputs (`kept_for_changes`) are computed at the limit first (a facet or
    /// camera change paints once at that width), then, when a wider limit is asked of the same
    /// inputs, at twice that: they serve every limit up to the one they were made at, so a
    /// border width dragged narrower, or wider within the margin, reuses them: below a limit,
    /// the feature transform gives the same nearest pixel at any larger limit (the features
    /// a larger limit adds are all farther than it, so they never change which parabola is
    /// lowest just left of a pixel, the one `distance::nearest_features` takes on a tie;
    /// `edges_below_a_limit_do_not_depend_on_it` checks it, ties included).
    pub fn edges(&self, width: u32, height: u32, limit: f32) -> Arc<Edges> {
        let held = self.inputs.edges.lock().ok().and_then(|g| g.clone());
        if let Some((l, e)) = &held
            && limit <= f32::from_bits(*l)
        {
            return e.clone();
        }
        let limit = if self.inputs.across_chains && held.is_some() { 2.0 * limit } else { limit };
        let (w, h) = (width as usize, height as usize);
        let r = self.regions(w * h);
        let is_edge = |i: usize| {
            let (x, y) = (i % w, i / w);
            (x > 0 && r[i] != r[i - 1])
                || (x + 1 < w && r[i] != r[i + 1])
                || (y > 0 && r[i] != r[i - w])
                || (y + 1 < h && r[i] != r[i + w])
        };
        let (dist, near) = crate::distance::nearest_features(width, height, limit, is_edge);
        drop(r);
        let e = Arc::new(Edges { dist, near, passage: OnceLock::new() });
        if self.inputs.keep
            && let Ok(mut g) = self.inputs.edges.lock()
        {
            *g = Some((limit.to_bits(), e.clone()));
        }
        e
    }

    /// The per-pixel factors `effect` made for `key`, made by `make` when not held; `lasting`:
    /// they depend on `key` alone, not on the film nor the facet map. For inputs kept across
    /// chains (`kept_across_chains`): an effect of a one-off chain computes its factors as it
    /// applies them, holding no buffer.
    pub fn factors(
        &self,
        effect: &'static str,
        key: [u64; 4],
        lasting: bool,
        make: impl FnOnce() -> Vec<f32>,
    ) -> Arc<Vec<f32>> {
        let held = self.inputs.factors.lock().ok().and_then(|f| {
            f.iter().find(|f| f.effect == effect && f.key == key && f.lasting == lasting).map(|f| f.values.clone())
        });
        if let Some(v) = held {
            return v;
        }
        let values = Arc::new(make());
        if self.inputs.across_chains
            && let Ok(mut f) = self.inputs.factors.lock()
        {
            f.retain(|f| f.effect != effect);
            f.push(Factors { effect, key, lasting, values: values.clone() });
        }
        values
    }

    /// The brushwork's strokes kept by an earlier chain (`brushwork::StrokePlan`), if any.
    pub(crate) fn stroke_plan(&self) -> Option<Arc<brushwork::StrokePlan>> {
        self.inputs.strokes.lock().ok().and_then(|g| g.clone())
    }

    /// Whether the last chain's brushwork had this `key` (kept inputs only); notes it.
    pub(crate) fn stroke_plan_seen(&self, key: [u64; 3]) -> bool {
        self.inputs.keep && self.inputs.strokes_seen.lock().is_ok_and(|mut g| g.replace(key) == Some(key))
    }

    /// Keeps the brushwork's strokes for the next chain (when the inputs are kept).
    pub(crate) fn keep_stroke_plan(&self, plan: Arc<brushwork::StrokePlan>) {
        if self.inputs.keep
            && let Ok(mut g) = self.inputs.strokes.lock()
        {
            *g = Some(plan);
        }
    }
}

/// The object part of the region of a plane that spans figure and ground (`open_planes`).
pub(super) const OPEN_REGION: u32 = u32::MAX - 1;
/// Whether region `r` (`PaintContext::regions`) is part of one object's surface: neither the
/// background nor a plane open across the outline.
pub(super) fn is_subject(r: u64) -> bool {
    ((r & 0xffff_ffff) as u32) < OPEN_REGION
}

/// Each plane's pixels showing geometry (figure) and not (ground), per facet id below
/// `count`: what open planes and the ground's deeper light are decided from, one pass.
pub(super) fn figure_ground(ids: &[u32], hits: &[PixelHit], count: usize) -> Vec<(u64, u64)> {
    let mut on = vec![(0u64, 0u64); count];
    for (&f, h) in ids.iter().zip(hits) {
        if let Some(c) = on.get_mut(f as usize) {
            if h.is_hit() {
                c.0 += 1;
            } else {
                c.1 += 1;
            }
        }
    }
    on
}

/// Each plane's share of ground (`figure_ground`): 0 for an id no pixel has. The per-plane
/// light models the ground's planes more deeply (`plane_light::GROUND`).
pub(super) fn ground_shares(counts: &[(u64, u64)]) -> Vec<f32> {
    counts.iter().map(|&(a, b)| if a + b > 0 { b as f32 / (a + b) as f32 } else { 0.0 }).collect()
}

impl PaintContext<'_> {
    /// Each plane's share of ground (`ground_shares`), per facet id: a sequence's frames read
    /// the layout frame's (`Held::ground`); empty without a facet map or hits.
    pub fn ground_shares(&self, pixels: usize) -> std::borrow::Cow<'_, [f32]> {
        if let Some(held) = self.held().and_then(|h| h.ground.as_deref()) {
            return std::borrow::Cow::Borrowed(held);
        }
        match self.facets.map(|f| &f.ids[..]).filter(|d| d.len() == pixels && self.hits.len() == pixels) {
            Some(ids) => std::borrow::Cow::Owned(ground_shares(&figure_ground(ids, self.hits, self.facet_count()))),
            None => std::borrow::Cow::Borrowed(&[]),
        }
    }
}

/// A plane spans figure and ground when each has at least this share of its pixels.
pub const OPEN_MIN_SHARE: f64 = 0.15;

/// The planes that span figure and ground (passage: the planes faceting leaves some whole
/// across the outline): each side holds at least `OPEN_MIN_SHARE` of the plane. Their pixels
/// are one region, so strokes, light and joins treat the plane as one and the outline opens
/// inside it.
pub(super) fn open_planes(counts: &[(u64, u64)]) -> Vec<bool> {
    counts
        .iter()
        .map(|&(a, b)| {
            let t = (a + b) as f64;
            t > 0.0 && a as f64 >= OPEN_MIN_SHARE * t && b as f64 >= OPEN_MIN_SHARE * t
        })
        .collect()
}
