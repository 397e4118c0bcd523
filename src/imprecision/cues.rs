//! Cues kept by construction: "the most salient vertices (top 5% of mesh
//! saliency) are visible in the final image at least as often as in the unfaceted render from
//! the same camera".
//!
//! A re-aimed facet shows another part of the scene than the pre-render showed there, so a
//! salient vertex the pre-render saw only inside re-aimed facets can drop out of the picture.
//! `keep_cue_vertices` checks every such vertex against the facets' new views (each pixel's
//! centre ray through its facet, exactly what the re-trace traces) and, where one is lost,
//! reduces the shift of a facet that held it (by halves, then none: a facet not re-aimed shows
//! what the pre-render showed). Only shifts shrink, so no ghost comes back. The vertex set and
//! "seen" are the look report's (`look::cues` uses `CueVertices` too): a vertex is seen when a
//! sample hits a triangle it is a corner of.

use std::sync::Arc;

use glam::DVec2;
use rayon::prelude::*;

use super::{AimContext, FacetAim};
use crate::accel::Hit;
use crate::facets::{FacetMap, FacetPixels};
use crate::film::{Film, NO_HIT};
use crate::scene::{Scene, World};
use crate::trace::screen_point;

/// The most salient vertices: this top share of mesh saliency.
pub const CUE_SHARE: f64 = 0.05;

/// The most salient vertices of the placed meshes: the top `CUE_SHARE` of mesh saliency over
/// every vertex of every object whose mesh has saliency values (the meshes in view), each
/// object's vertices counted apart (a slot per object and vertex). With `parts`, a vertex's
/// value is the higher of its mesh saliency and its object's part saliency
/// (`saliency::parts`), so the small parts the saliency map shows (an eye, a beak) are kept in
/// view too.
pub struct CueVertices<'a> {
    scene: &'a Scene,
    world: &'a World,
    /// First slot of each object.
    base: Vec<usize>,
    /// Whether each slot is among the most salient.
    top: Vec<bool>,
}

impl<'a> CueVertices<'a> {
    /// The top `CUE_SHARE` of `saliency` (per mesh, `MeshSaliency::per_mesh`), with the small
    /// parts' saliency when `parts`. None when no mesh has values.
    pub fn new(scene: &'a Scene, world: &'a World, saliency: &[Option<Arc<Vec<f32>>>], parts: bool) -> Option<Self> {
        let mut base = Vec::with_capacity(world.objects.len());
        let mut total = 0usize;
        for o in &world.objects {
            base.push(total);
            total += scene.meshes[o.mesh].positions.len();
        }
        let part = if parts { crate::saliency::parts::part_saliency(world) } else { vec![0.0; world.objects.len()] };
        let value = |k: usize, x: f32| x.max(part[k]);
        let mut values: Vec<f32> = Vec::new();
        for (k, o) in world.objects.iter().enumerate() {
            if let Some(Some(s)) = saliency.get(o.mesh) {
                values.extend(s.iter().map(|&x| value(k, x)));
            }
        }
        if values.is_empty() {
            return None;
        }
        // The value at rank (n - 1) * 0.95 of the sorted values (a selection, not a sort).
        let k = ((values.len() - 1) as f64 * (1.0 - CUE_SHARE)) as usize;
        let (_, &mut t, _) = values.select_nth_unstable_by(k, f32::total_cmp);
        let threshold = t.max(f32::MIN_POSITIVE);
        let mut top = vec![false; total];
        for (k, o) in world.objects.iter().enumerate() {
            if let Some(Some(s)) = saliency.get(o.mesh) {
                for (v, &x) in s.iter().enumerate() {
                    top[base[k] + v] = value(k, x) >= threshold;
                }
            }
        }
        Some(CueVertices { scene, world, base, top })
    }

    /// Calls `f` with the slot of each most salient corner of world triangle `tri`.
    pub fn corners(&self, tri: u32, mut f: impl FnMut(usize)) {
        let (o, local) = self.world.local_triangle(tri);
        let object = &self.world.objects[o as usize];
        if let Some(t) = self.scene.meshes[object.mesh].triangles.get(local as usize) {
            for &v in t {
                let slot = self.base[o as usize] + v as usize;
                if self.top.get(slot).copied().unwrap_or(false) {
                    f(slot);
                }
            }
        }
    }

    /// Whether `film`'s samples show each slot (false for all but the most salient).
    pub fn seen(&self, film: &Film) -> Vec<bool> {
        let mut seen = vec![false; self.top.len()];
        for s in film.samples.iter().filter(|s| s.is_hit()) {
            self.corners(s.tri, |slot| seen[slot] = true);
        }
        seen
    }

    /// How many of the most salient vertices `film`'s samples show.
    pub fn shown(&self, film: &Film) -> usize {
        self.seen(film).iter().filter(|&&s| s).count()
    }
}

/// Shift levels tried for a facet that loses a cue: the whole shift, half, a quarter, none.
const LEVELS: [f64; 4] = [1.0, 0.5, 0.25, 0.0];

/// Re-aims `aim` at `sc` (on the line from its centre to its aim point), or not at all when
/// `sc` is its centre or the turn is negligible.
pub(super) fn reaim_at(aim: &mut FacetAim, ctx: &AimContext, fc: DVec2, sc: DVec2) {
    aim.sc = Some(sc);
    aim.reaim = None;
    aim.target = None;
    if sc != fc
        && let Some((r, p)) = ctx.reaim(fc, sc)
    {
        if r.turn.length() > ctx.negligible_turn(fc) {
            aim.reaim = Some(r);
        }
        aim.target = p;
    }
}

/// A miss among `CentreHits`' hits.
const MISS: Hit = Hit { tri: NO_HIT, object: NO_HIT, t: 0.0, u: 0.0, v: 0.0 };

/// The closest hits of the centre rays `keep_cue_vertices` traced through the aims it kept:
/// the re-trace takes them (`Tracer::render_known`) instead of tracing those rays again, as
/// its one sample is that very ray (`pipeline::facet_rays` at the pixel centre). Memory: a
/// `Hit` (20 bytes) for each pixel of the facets checked, plus 4 bytes a pixel of the image.
pub struct CentreHits {
    /// Per facet, the aim its hits were traced through (None: no hits).
    aims: Vec<Option<FacetAim>>,
    /// Per facet, the hit of each of its pixels in `FacetMap::pixels_by_facet` order (a miss:
    /// tri `NO_HIT`).
    hits: Vec<Vec<Hit>>,
    /// Per pixel, its rank among its facet's pixels (read only for facets with hits).
    rank: Vec<u32>,
}

impl CentreHits {
    /// How many pixels have a hit.
    pub fn len(&self) -> usize {
        self.hits.iter().map(Vec::len).sum()
    }

    /// Whether no pixel has a hit.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Pixel index -> its known centre hit (None on a miss), or None where unknown: only for
    /// the facets whose aim in `aims` is the one their hits were traced through, and only on
    /// `map`, the facet map they were traced on.
    pub fn known<'a>(
        &'a self,
        map: &'a FacetMap,
        aims: &[FacetAim],
    ) -> impl Fn(usize) -> Option<Option<Hit>> + Sync + 'a {
        let same_map = map.ids.len() == self.rank.len() && aims.len() == self.aims.len();
        let valid: Vec<bool> =
            (0..self.aims.len()).map(|f| same_map && self.aims[f].is_some_and(|a| a == aims[f] && a.moved())).collect();
        move |i| {
            let f = *map.ids.get(i)? as usize;
            if !*valid.get(f)? {
                return None;
            }
            let h = *self.hits[f].get(self.rank[i] as usize)?;
            Some((h.tri != NO_HIT).then_some(h))
        }
    }
}

/// The most salient vertices `pixels` (a facet's) show through `aim`: each pixel's centre
/// ray, re-aimed as the re-trace re-aims it (`pipeline::facet_rays`), as the indices `keep`
/// gives them (None: not counted), sorted and deduplicated; and each pixel's closest hit.
fn seen_through(
    ctx: &AimContext,
    cues: &CueVertices,
    pixels: &[u32],
    aim: &FacetAim,
    keep: &(dyn Fn(usize) -> Option<usize> + Sync),
) -> (Vec<usize>, Vec<Hit>) {
    let w = ctx.width;
    // In chunks in parallel (a facet traced alone while its shift shrinks), in pixel order.
    let chunks: Vec<(Vec<usize>, Vec<Hit>)> = pixels
        .par_chunks(SEEN_CHUNK)
        .map(|chunk| {
            let mut out = Vec::new();
            let mut hits = Vec::with_capacity(chunk.len());
            for &i in chunk {
                let p = screen_point(i % w, i / w, DVec2::splat(0.5), ctx.width, ctx.height);
                let ray = ctx.camera.ray(p);
                let ray = if aim.moved() { aim.apply(ray, ctx.pixel_pos(p), ctx.clip_radius) } else { ray };
                // As the tracer sees it, backdrops running on (the re-trace trusts these hits).
                let hit = ctx.accel.closest(ray.origin, ray.dir, 0.0, f32::INFINITY);
                match crate::trace::run_on(cues.world, ray.origin, ray.dir, hit) {
                    Some(h) => {
                        cues.corners(h.tri, |slot| out.extend(keep(slot)));
                        hits.push(h);
                    }
                    None => hits.push(MISS),
                }
            }
            (out, hits)
        })
        .collect();
    let mut out = Vec::new();
    let mut hits = Vec::with_capacity(pixels.len());
    for (o, h) in chunks {
        out.extend(o);
        hits.extend(h);
    }
    out.sort_unstable();
    out.dedup();
    (out, hits)
}

/// Pixels per parallel work item of `seen_through`.
const SEEN_CHUNK: usize = 512;

/// Makes every most salient vertex the pre-render (`film`, one centre sample per pixel) shows
/// stay shown through the facets' new views (see the module doc); returns how many facets'
/// shifts were reduced. Each pixel of a re-aimed facet is re-traced through its centre ray,
/// so a vertex stays shown when some pixel's ray hits one of its triangles. A vertex the
/// pre-render showed in a facet that is not re-aimed is kept as it is; the others are checked
/// against the re-aimed facets that showed them (others that might show them too are not
/// traced: the check is conservative). A facet holding a lost vertex has its shift reduced to
/// the next of `LEVELS` until none of its own is lost; at level 0 it shows the pre-render's
/// view, so the loop ends with every vertex shown.
pub fn keep_cue_vertices(
    aims: &mut [FacetAim],
    ctx: &AimContext,
    map: &FacetMap,
    film: &Film,
    cues: &CueVertices,
) -> usize {
    keep_cue_vertices_traced(aims, ctx, map, &map.facet_pixels(), film, cues).0
}

/// `keep_cue_vertices`, also returning the centre hits it traced through the aims it kept
/// (None when it traced none), for the re-trace.
pub fn keep_cue_vertices_traced(
    aims: &mut [FacetAim],
    ctx: &AimContext,
    map: &FacetMap,
    by_facet: &FacetPixels,
    film: &Film,
    cues: &CueVertices,
) -> (usize, Option<CentreHits>) {
    if film.spp != 1 || film.samples.len() != map.ids.len() || aims.len() != map.facet_count as usize {
        return (0, None);
    }
    let n = aims.len();
    let own = |f: usize| by_facet.of(f);
    // What the pre-render showed, per facet: the slots its pixels saw.
    let held_slots: Vec<Vec<usize>> = (0..n)
        .into_par_iter()
        .map(|f| {
            let mut v = Vec::new();
            for &i in own(f) {
                let s = film.samples[i as usize];
                if s.is_hit() {
                    cues.corners(s.tri, |slot| v.push(slot));
                }
            }
            v.sort_unstable();
            v.dedup();
            v
        })
        .collect();
    // The vertices the pre-render showed, numbered densely (a scene may have millions of slots).
    let mut shown: Vec<usize> = held_slots.iter().flatten().copied().collect();
    shown.sort_unstable();
    shown.dedup();
    let index = |slot: usize| shown.binary_search(&slot).ok();
    let held: Vec<Vec<usize>> = held_slots.iter().map(|v| v.iter().filter_map(|&s| index(s)).collect()).collect();
    // Shown by a facet that is not re-aimed: kept whatever the others do.
    let mut risky = vec![true; shown.len()];
    for f in (0..n).filter(|&f| !aims[f].moved()) {
        for &s in &held[f] {
            risky[s] = false;
        }
    }
    let checked: Vec<usize> = (0..n).filter(|&f| aims[f].moved() && held[f].iter().any(|&s| risky[s])).collect();
    if checked.is_empty() {
        return (0, None);
    }
    let keep = |slot: usize| index(slot).filter(|&k| risky[k]);
    let mut seen: Vec<Vec<usize>> = vec![Vec::new(); n];
    let mut hits: Vec<Vec<Hit>> = vec![Vec::new(); n];
    let traced: Vec<(Vec<usize>, Vec<Hit>)> =
        checked.par_iter().map(|&f| seen_through(ctx, cues, own(f), &aims[f], &keep)).collect();
    let mut count = vec![0u32; shown.len()];
    for (&f, (v, h)) in checked.iter().zip(traced) {
        for &s in &v {
            count[s] += 1;
        }
        seen[f] = v;
        hits[f] = h;
    }
    let last = LEVELS.len() - 1;
    let mut level = vec![0usize; n];
    let original: Vec<FacetAim> = aims.to_vec();
    loop {
        // The facet holding the most lost vertices (the lowest id on a tie). A facet at the
        // last level shows the pre-render's view, so it holds none.
        let lost_in = |f: usize| held[f].iter().filter(|&&s| risky[s] && count[s] == 0).count();
        let Some((f, _)) = checked
            .iter()
            .filter(|&&f| level[f] < last)
            .map(|&f| (f, lost_in(f)))
            .filter(|&(_, k)| k > 0)
            .max_by_key(|&(f, k)| (k, std::cmp::Reverse(f)))
        else {
            break;
        };
        let (Some(fc), Some(sc)) = (original[f].fc, original[f].sc) else { break };
        // Lower levels until none of f's own vertices is lost (the last level always does).
        while level[f] < last {
            level[f] += 1;
            let t = LEVELS[level[f]];
            let mut aim = original[f];
            if t == 0.0 {
                (aim.sc, aim.reaim, aim.linear, aim.target) = (aim.fc, None, None, None);
            } else {
                reaim_at(&mut aim, ctx, fc, fc + (sc - fc) * t);
            }
            let (now, h) = if aim.moved() {
                seen_through(ctx, cues, own(f), &aim, &keep)
            } else {
                (held[f].iter().copied().filter(|&s| risky[s]).collect(), Vec::new())
            };
            hits[f] = h;
            for &s in &seen[f] {
                count[s] -= 1;
            }
            for &s in &now {
                count[s] += 1;
            }
            seen[f] = now;
            aims[f] = aim;
            if held[f].iter().all(|&s| !risky[s] || count[s] > 0) {
                break;
            }
        }
    }
    let reduced = level.iter().filter(|&&l| l > 0).count();
    // The hits of the aims kept, for the facets still re-aimed.
    let mut rank = vec![0u32; map.ids.len()];
    let mut kept_aims = vec![None; n];
    for &f in &checked {
        if hits[f].is_empty() || !aims[f].moved() {
            hits[f] = Vec::new();
            continue;
        }
        kept_aims[f] = Some(aims[f]);
        for (k, &i) in own(f).iter().enumerate() {
            rank[i as usize] = k as u32;
        }
    }
    (reduced, Some(CentreHits { aims: kept_aims, hits, rank }))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::imprecision::aim_facets;
    use crate::imprecision::tests::Grid;
    use crate::pipeline::stages::{Retracing, moved_pixels, retrace_stage};
    use crate::pipeline::{Shading, Timings};
    use crate::progress::Progress;

    /// A head and an eye modelled as two spheres: mesh saliency is 0 on both (a sphere has no
    /// variation), so no vertex is a cue; with the parts, every vertex of the eye is and none of
    /// the head.
    #[test]
    fn the_small_parts_are_cue_vertices_with_parts() {
        use glam::{DMat4, DVec3, Vec3};
        let mut scene = Scene::default();
        scene.materials.push(crate::scene::Material::default());
        scene.meshes.push(crate::scene::default::ellipsoid("ball", Vec3::ONE, 12, 24, 0));
        let place = |c: DVec3, r: f64| DMat4::from_translation(c) * DMat4::from_scale(DVec3::splat(r));
        for (name, c, r) in [("head", DVec3::ZERO, 1.0), ("eye", DVec3::new(0.0, 0.3, 1.0), 0.05)] {
            scene.objects.push(crate::scene::Object { name: name.into(), mesh: 0, transform: place(c, r) });
        }
        let prep = crate::pipeline::Prepared::new(scene);
        let n = prep.scene.meshes[0].positions.len();
        let flat = vec![Some(Arc::new(vec![0.0f32; n]))];
        let without = CueVertices::new(&prep.scene, &prep.world, &flat, false).unwrap();
        assert!(without.top.iter().all(|&t| !t), "no variation, no cue");
        let with = CueVertices::new(&prep.scene, &prep.world, &flat, true).unwrap();
        let eye = prep.world.objects.iter().position(|o| o.name == "eye").unwrap();
        let head = 1 - eye;
        assert!((0..n).all(|v| with.top[with.base[eye] + v]), "every vertex of the eye");
        assert!((0..n).all(|v| !with.top[with.base[head] + v]), "none of the head");
    }

    /// The still life on a grid of 48 facets, each re-aimed at a random point up to 40 pixels
    /// away (far more than the default's shifts): some salient vertices drop out of view.
    /// After `keep_cue_vertices` and the re-trace, every most salient vertex the pre-render
    /// showed is shown again, and only some facets gave up part of their shift.
    #[test]
    fn every_salient_vertex_shown_before_is_shown_after() {
        let grid = Grid::new(Shading::Lit);
        let (prep, pre, map, params) = (&grid.prep, &grid.pre, &grid.map, &grid.params);
        let silent = Progress::silent();
        assert_eq!(pre.film.spp, 1);
        let mesh =
            crate::saliency::for_film(&prep.scene, &prep.world, &prep.saliency, &pre.film, &params.saliency).unwrap();
        let cues = CueVertices::new(&prep.scene, &prep.world, &mesh.per_mesh, params.saliency.reads_parts()).unwrap();
        let before = cues.seen(&pre.film);
        let shown_before = before.iter().filter(|&&b| b).count();
        assert!(shown_before >= 10, "{shown_before}");
        let ctx = grid.ctx();
        let aim = grid.random_aims(40.0);
        let wild = aim_facets(&ctx, map, None, &aim);
        let retraced = |aims: &[FacetAim], centre: Option<&CentreHits>| {
            let mut film = pre.film.clone();
            let moved = moved_pixels(map, aims);
            let tracer = pre.view.tracer(prep, &params.trace);
            let (pixels, retracing) = (Some(moved), Retracing::InPlace);
            let mut timings = Timings::default();
            retrace_stage(&tracer, &ctx, map, aims, pixels, centre, &mut film, retracing, &silent, &mut timings);
            film
        };
        let traced = |aims: &[FacetAim]| cues.seen(&retraced(aims, None));
        let lost = |after: &[bool]| before.iter().zip(after).filter(|&(&b, &a)| b && !a).count();
        assert!(lost(&traced(&wild)) > 0, "the wild aims lose no cue: the test shows nothing");
        let mut kept = wild.clone();
        let (reduced, centre) = keep_cue_vertices_traced(&mut kept, &ctx, map, &map.facet_pixels(), &pre.film, &cues);
        assert_eq!(lost(&traced(&kept)), 0, "{reduced} facets reduced");
        // The centre hits the check traced are those the re-trace finds: the same film with
        // them as without, and none taken for facets whose aim is not the one kept.
        let centre = centre.expect("facets were checked");
        let known = centre.known(map, &kept);
        let taken = (0..map.ids.len()).filter(|&i| known(i).is_some()).count();
        assert!(taken > 0 && taken == centre.len(), "{taken} of {} hits taken", centre.len());
        let (a, b) = (retraced(&kept, Some(&centre)), retraced(&kept, None));
        assert!(a.color == b.color && a.hits == b.hits && a.samples == b.samples && a.occlusion == b.occlusion);
        let known = centre.known(map, &wild);
        let stale = (0..map.ids.len())
            .filter(|&i| known(i).is_some() && kept[map.ids[i] as usize] != wild[map.ids[i] as usize]);
        assert_eq!(stale.count(), 0);
        let moved = wild.iter().filter(|a| a.moved()).count();
        assert!(reduced > 0 && reduced < moved, "{reduced} of {moved} re-aimed facets reduced");
        assert!(kept.iter().filter(|a| a.moved()).count() > 0);
        // Shifts only shrink, along the same line.
        for (k, w) in kept.iter().zip(&wild) {
            let (Some(fc), Some(a), Some(b)) = (w.fc, k.sc, w.sc) else { continue };
            assert!((a - fc).length() <= (b - fc).length() + 1e-9);
            assert!((a - fc).perp_dot(b - fc).abs() < 1e-6 * (1.0 + (b - fc).length_squared()));
        }
    }
}
