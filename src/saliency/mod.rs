//! Mesh saliency (Lee, Varshney, Jacobs 2005) per mesh in its own
//! coordinates, cached by content, and the per-pixel saliency map read off the pre-render.
//!
//! Stages: `surface` (weld by position, canonical order) -> `curvature` (cotangent mean
//! curvature) -> `levels` (Gaussian means through `neighbourhood` grids, centre-surround,
//! normalisation, suppression) -> `map` (per-pixel interpolation, raised where a small part of
//! the subject modelled as its own mesh is salient: `parts`). `approx` offers a clustered
//! evaluation of the Gaussian means with a bounded cost (its inner loops in `kernels`) for
//! meshes too large for the exact sums; `cache` keeps results on disk across processes (the
//! Blender add-on runs once per animation frame).
//!
//! Choices the paper leaves open, each documented where it is made: H = (K . n) / 2 from the
//! cotangent Laplacian with mixed areas, rim and zero-area vertices filled from their
//! neighbours (`curvature`); neighbourhoods strictly within 2 sigma, centre vertex included;
//! levels normalised by their maximum; a local maximum is a vertex no other vertex within the
//! level's sigma exceeds, values within `levels::TIE` counting as equal (ties of exact arithmetic
//! never hang on rounding); mbar = 0 without other maxima; centre-surround differences
//! below 3% of the mean |H| count as no variation, so spheres get 0 (`levels`). Vertices on no
//! triangle get 0. The tests' brute-force oracle (tests/saliency.rs) is the reference.

pub mod approx;
pub mod cache;
pub mod curvature;
pub mod kernels;
pub mod levels;
pub mod map;
pub mod neighbourhood;
pub mod parts;
pub mod proxy;
pub mod surface;

use std::collections::HashMap;
use std::path::Path;
use std::sync::{Arc, Mutex};

use glam::Vec3;
use rayon::prelude::*;

pub use map::{pixel_saliency, saliency_image, saliency_map};

use crate::error::Result;
use crate::film::Film;
use crate::scene::{Mesh, Scene, World};

/// How mesh saliency's Gaussian means are evaluated.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum SaliencyMethod {
    /// Exact while the exact sums' work counted on the mesh stays within `EXACT_BUDGET`, clustered
    /// above; meshes of more than `proxy::PROXY_ABOVE` vertices through a bounded proxy (`proxy`).
    Auto,
    /// The definition's exact sums, whatever the mesh's size.
    Exact,
    /// Each block of vertices exact or by clusters, whichever is cheaper (`approx`): bounded cost, approximate.
    Clustered,
}

impl SaliencyMethod {
    /// The method's name, part of the cache's content key (so never renamed lightly).
    pub fn as_str(self) -> &'static str {
        match self {
            SaliencyMethod::Auto => "auto",
            SaliencyMethod::Exact => "exact",
            SaliencyMethod::Clustered => "clustered",
        }
    }
}

/// What the saliency stage needs: the method, and a directory keeping per-mesh results
/// across processes (None: in memory only).
#[derive(Clone, Debug, PartialEq)]
pub struct SaliencyParams {
    pub method: SaliencyMethod,
    pub cache: Option<std::path::PathBuf>,
    /// Weight of the small parts' saliency in the map (`parts`, `saliency_map`); 0 = mesh
    /// saliency alone (the thesis).
    pub parts: f32,
}

impl SaliencyParams {
    /// Whether the small parts are salient at all: the map holds them and the re-aim's cue
    /// vertices count them (`imprecision::cues::CueVertices`).
    pub fn reads_parts(&self) -> bool {
        self.parts > 0.0
    }
}

/// Bumped whenever the definition or its numbers change, so stale cache entries are ignored.
pub const ALGORITHM_VERSION: u32 = 4;

/// `Auto` uses the exact sums while they visit at most this many candidate pairs (counted on
/// the mesh, `Analysed::exact_work`: under a second of CPU, half a second on two cores; meshes
/// up to ~35K vertices of even density), the clustered approximation above.
pub const EXACT_BUDGET: u64 = 50_000_000;

/// Per-vertex saliency of the meshes a frame needs.
#[derive(Clone, Debug, Default)]
pub struct MeshSaliency {
    /// Index = `Scene::meshes` index; per vertex in the mesh's order, in [0, 1]. None: not
    /// computed because no sample of the frame hit the mesh.
    pub per_mesh: Vec<Option<Arc<Vec<f32>>>>,
    /// The same values per triangle corner (`[s(v0), s(v1), s(v2)]` for each triangle of the
    /// mesh): what the saliency map interpolates, since `World` keeps no vertex indices.
    pub corners: Vec<Option<Arc<Vec<[f32; 3]>>>>,
}

impl MeshSaliency {
    /// Wraps per-vertex values of `scene`'s meshes and derives their triangle corners.
    pub fn new(scene: &Scene, per_mesh: Vec<Option<Arc<Vec<f32>>>>) -> MeshSaliency {
        let corners = per_mesh
            .iter()
            .zip(&scene.meshes)
            .map(|(s, m)| {
                s.as_ref().map(|s| {
                    let at = |i: u32| s.get(i as usize).copied().unwrap_or(0.0);
                    Arc::new(m.triangles.iter().map(|t| t.map(at)).collect::<Vec<_>>())
                })
            })
            .collect();
        MeshSaliency { per_mesh, corners }
    }
}

/// In-process reuse of per-mesh results, keyed by content hash (kept in `Prepared`, so views and
/// frames rendered from one loaded scene compute each mesh once).
#[derive(Debug, Default)]
pub struct Memo(Mutex<HashMap<u128, Arc<Vec<f32>>>>);

impl Memo {
    /// Keeps the entries whose content key `keep` accepts: a render server drops the meshes
    /// a new version of its scene no longer has (`pipeline::Session`), so memory stays bounded.
    pub fn retain(&self, keep: impl Fn(u128) -> bool) {
        if let Ok(mut g) = self.0.lock() {
            g.retain(|k, _| keep(*k));
        }
    }

    /// Number of meshes held.
    pub fn len(&self) -> usize {
        self.0.lock().map_or(0, |g| g.len())
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// A mesh's surface, curvature and eps: the inputs of the scale space.
#[derive(Clone, Debug)]
pub struct Analysed {
    pub surface: surface::Surface,
    /// Mean curvature per surface vertex.
    pub h: Vec<f64>,
    /// the method's eps with its coarse-mesh rule.
    pub eps: f64,
    /// One-ring neighbours (a shortcut for the local-maximum test).
    pub adjacency: surface::Adjacency,
}

/// Welds, estimates curvature and picks eps.
pub fn analyse(positions: &[Vec3], triangles: &[[u32; 3]]) -> Analysed {
    let surface = surface::Surface::new(positions, triangles);
    let edges = surface.edges();
    let c = curvature::mean_curvature(&surface, &edges);
    let eps = levels::epsilon(surface.diagonal(), surface.mean_edge_length(&edges));
    let adjacency = surface::Adjacency::new(surface.len(), &edges);
    Analysed { surface, h: c.h, eps, adjacency }
}

impl Analysed {
    /// Candidate pairs the exact sums visit on this mesh, counted on their own grid (what they
    /// cost, whatever the tessellation; not an estimate from the vertex count and area, which
    /// is off by 20x on meshes of uneven density).
    pub fn exact_work(&self) -> u64 {
        if self.surface.is_empty() || !(self.eps > 0.0) {
            return 0;
        }
        levels::exact_work(&self.surface.positions, levels::SIGMA_SCALES[7] * self.eps)
    }

    /// Whether `method` resolves to the exact sums for this mesh.
    pub fn uses_exact(&self, method: SaliencyMethod) -> bool {
        match method {
            SaliencyMethod::Exact => true,
            SaliencyMethod::Clustered => false,
            SaliencyMethod::Auto => self.exact_work() <= EXACT_BUDGET,
        }
    }

    /// Saliency per surface vertex (canonical order), in [0, 1].
    pub fn saliency(&self, method: SaliencyMethod) -> Vec<f64> {
        self.saliency_with_beta(method, approx::BETA)
    }

    /// `saliency` with the clustered means' cells of sigma / `beta` where `method` does not sum
    /// exactly (the proxy's coarser cells, `proxy::PROXY_BETA`).
    pub fn saliency_with_beta(&self, method: SaliencyMethod, beta: f64) -> Vec<f64> {
        let pts = &self.surface.positions;
        if pts.is_empty() || !(self.eps > 0.0) {
            return vec![0.0; pts.len()];
        }
        let sigmas = levels::SIGMA_SCALES.map(|s| s * self.eps);
        let means = if self.uses_exact(method) {
            levels::gaussian_means(pts, &self.h, &sigmas)
        } else {
            approx::clustered_means_with(pts, &self.h, &sigmas, beta, approx::GROUP).0
        };
        levels::combine(pts, &self.adjacency, &self.h, &means, self.eps)
    }

    /// Maps canonical values back to the mesh's vertex order (0 for vertices on no triangle).
    pub fn to_mesh_order(&self, values: &[f64]) -> Vec<f32> {
        self.surface
            .vertex_of
            .iter()
            .map(|&c| if c == surface::NOT_ON_SURFACE { 0.0 } else { values[c as usize] as f32 })
            .collect()
    }
}

/// Exact saliency of one mesh, per vertex in the mesh's vertex order, in [0, 1].
pub fn mesh_saliency(mesh: &Mesh) -> Vec<f32> {
    mesh_saliency_with(mesh, SaliencyMethod::Exact)
}

/// Saliency of one mesh by `method`, per vertex in the mesh's vertex order, in [0, 1].
pub fn mesh_saliency_with(mesh: &Mesh, method: SaliencyMethod) -> Vec<f32> {
    // Huge meshes under `Auto`: through a bounded-size proxy (`proxy`).
    if method == SaliencyMethod::Auto
        && mesh.positions.len() > proxy::PROXY_ABOVE
        && let Some(v) = proxy::proxy_saliency(&mesh.positions, &mesh.triangles)
    {
        return v;
    }
    let a = analyse(&mesh.positions, &mesh.triangles);
    let s = a.saliency(method);
    a.to_mesh_order(&s)
}

/// Content key of a mesh's saliency: positions and triangles (what the definition reads),
/// the method and the algorithm version.
pub fn content_key(mesh: &Mesh, method: SaliencyMethod) -> u128 {
    use crate::util::hash::update_words;
    let mut h = xxhash_rust::xxh3::Xxh3::new();
    h.update(b"cubist-saliency");
    h.update(&ALGORITHM_VERSION.to_le_bytes());
    h.update(method.as_str().as_bytes());
    // The same bytes as one `update` per number, fed in bulk (`update_words`).
    h.update(&(mesh.positions.len() as u64).to_le_bytes());
    update_words(&mut h, &mesh.positions);
    h.update(&(mesh.triangles.len() as u64).to_le_bytes());
    update_words(&mut h, &mesh.triangles);
    h.digest128()
}

/// Saliency of `mesh`, from the in-process memo, else the disk cache, else computed (and then
/// stored in both).
pub fn cached_mesh_saliency(
    mesh: &Mesh,
    method: SaliencyMethod,
    memo: Option<&Memo>,
    cache_dir: Option<&Path>,
) -> Result<Arc<Vec<f32>>> {
    let key = content_key(mesh, method);
    if let Some(m) = memo
        && let Some(v) = m.0.lock().ok().and_then(|g| g.get(&key).cloned())
    {
        return Ok(v);
    }
    let from_disk = match cache_dir {
        Some(dir) => cache::load(dir, key, mesh.positions.len()),
        None => None,
    };
    let values = match from_disk {
        Some(v) => Arc::new(v),
        None => {
            let v = Arc::new(mesh_saliency_with(mesh, method));
            if let Some(dir) = cache_dir {
                cache::store(dir, key, &v)?;
            }
            v
        }
    };
    if let Some(m) = memo
        && let Ok(mut g) = m.0.lock()
    {
        g.insert(key, values.clone());
    }
    Ok(values)
}

/// Computes into `memo` the saliency of every mesh `world` places, before the pre-render says
/// which are seen: a mesh's saliency depends on the mesh alone, so the pipeline runs this beside
/// framing and the pre-render (`pipeline::run`), on the core their serial parts leave
/// idle, and `for_film` then finds the values made. The same function fills the memo either way,
/// so the picture is the same bits. Errors (a disk cache that cannot be written) are left for
/// `for_film`, which meets them again and reports them.
pub fn precompute(scene: &Scene, world: &World, memo: &Memo, params: &SaliencyParams) {
    let mut placed = vec![false; scene.meshes.len()];
    for o in &world.objects {
        placed[o.mesh] = true;
    }
    scene.meshes.par_iter().zip(placed.par_iter()).filter(|(_, p)| **p).for_each(|(mesh, _)| {
        let _ = cached_mesh_saliency(mesh, params.method, Some(memo), params.cache.as_deref());
    });
}

/// Which of `scene`'s meshes some sample of `film` hit.
pub fn visible_meshes(scene: &Scene, world: &World, film: &Film) -> Vec<bool> {
    let mut seen_objects = vec![false; world.objects.len()];
    for s in film.samples.iter().filter(|s| s.is_hit()) {
        if (s.tri as usize) < world.triangle_count() {
            seen_objects[world.object_of(s.tri) as usize] = true;
        }
    }
    let mut meshes = vec![false; scene.meshes.len()];
    for (o, seen) in seen_objects.iter().enumerate() {
        if *seen {
            meshes[world.objects[o].mesh] = true;
        }
    }
    meshes
}

/// Saliency of the meshes hit by some sample of `film` (skip what the picture does not
/// need), from `memo` (this process's per-mesh results) or the disk cache when they hold it.
pub fn for_film(
    scene: &Scene,
    world: &World,
    memo: &Memo,
    film: &Film,
    params: &SaliencyParams,
) -> Result<MeshSaliency> {
    let visible = visible_meshes(scene, world, film);
    let cache = params.cache.as_deref();
    let per_mesh: Vec<Option<Arc<Vec<f32>>>> = scene
        .meshes
        .par_iter()
        .zip(visible.par_iter())
        .map(
            |(mesh, &v)| {
                if v { cached_mesh_saliency(mesh, params.method, Some(memo), cache).map(Some) } else { Ok(None) }
            },
        )
        .collect::<Result<_>>()?;
    Ok(MeshSaliency::new(scene, per_mesh))
}

/// Every mesh's per-vertex saliency as `{"meshes": [{"name", "vertex_saliency": [...]}, ...]}`
/// in `Scene::meshes` order (what `cubist saliency --json` prints).
pub fn vertex_json(scene: &Scene, memo: &Memo, params: &SaliencyParams) -> Result<serde_json::Value> {
    let values: Vec<Arc<Vec<f32>>> = scene
        .meshes
        .par_iter()
        .map(|m| cached_mesh_saliency(m, params.method, Some(memo), params.cache.as_deref()))
        .collect::<Result<_>>()?;
    let meshes: Vec<serde_json::Value> = scene
        .meshes
        .iter()
        .zip(values)
        .map(|(m, v)| serde_json::json!({ "name": m.name, "vertex_saliency": v.as_slice() }))
        .collect();
    Ok(serde_json::json!({ "meshes": meshes }))
}
