//! A render session: the scene, its BVH and per-mesh saliency, and the stage outputs of its
//! latest renders, kept per image size ("lanes", most recent first, at most `LANES`, within
//! `budget` bytes: the viewport's 1/4, 1/2 and full-size passes and F12 each keep theirs).
//! Each render drives the stage runner (`run`) over the lane of its size with
//! `Policy::Kept`, so a new render re-runs only the stages a change invalidates. A new
//! scene keeps what its unchanged meshes allow: their saliency and their BVHs.

use std::collections::VecDeque;
use std::path::Path;
use std::time::Instant;

use serde::Serialize;
use xxhash_rust::xxh3::Xxh3;

use super::cache::{Gen, Policy, hash_file};
use super::run::{Frame, Lane, run};
use super::{Prepared, StageParams};
use crate::accel::Accel;
use crate::error::{Error, Result};
use crate::facets::{FacetLayout, FacetMap};
use crate::imprecision::FacetAim;
use crate::progress::Progress;
use crate::saliency::{self, SaliencyMethod};
use crate::scene::{LoadOptions, Scene, World};
use crate::settings::Settings;

/// Image sizes whose outputs are kept: the viewport's three progressive passes and F12's.
pub const LANES: usize = 4;
/// Memory the kept outputs may use by default, bytes; the lane in use is always kept.
pub const DEFAULT_BUDGET: u64 = 3 << 30;

/// What `Session::set_scene` or `Session::load_scene` did.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize)]
pub struct SceneUpdate {
    /// Whether the scene differs from the one before (false: every kept output still holds).
    pub changed: bool,
    /// Whether the file was read and parsed (false: its bytes were those loaded before).
    pub reloaded: bool,
    /// Whether the BVH was built again (the placed triangles changed).
    pub bvh_rebuilt: bool,
    /// Meshes in the scene, and how many are new or changed (only those compute saliency).
    pub meshes: usize,
    pub meshes_changed: usize,
}

/// A scene file as last loaded: its bytes, and whether they are all the scene reads.
#[derive(Clone, Debug, PartialEq)]
struct FileStamp {
    path: std::path::PathBuf,
    /// What the file was allowed to reach (a change loads it again).
    options: LoadOptions,
    bytes: u128,
    self_contained: bool,
}

struct SceneEntry {
    prep: Prepared,
    id: Gen,
    /// Everything a render reads of the scene.
    content: u128,
    /// What the BVH is built from: the placed triangles.
    geometry: u128,
    /// Saliency content key per mesh (what changed meshes are counted by).
    meshes: Vec<u128>,
    /// None: the built-in still life or a scene given in memory.
    file: Option<FileStamp>,
    builtin: bool,
}

/// What a session holds, for `cubist serve`'s `stats`.
#[derive(Clone, Debug, Default, Serialize)]
pub struct SessionStats {
    /// The scene's source (a path, `<default scene>` or `<memory>`), triangles and meshes.
    pub scene: Option<String>,
    pub triangles: usize,
    pub meshes: usize,
    /// Meshes whose saliency is kept.
    pub saliency_meshes: usize,
    /// Kept outputs per image size, most recent first.
    pub lanes: Vec<LaneStats>,
    /// Bytes the kept outputs use, and the budget.
    pub bytes: u64,
    pub budget: u64,
}

#[derive(Clone, Debug, Serialize)]
pub struct LaneStats {
    pub width: u32,
    pub height: u32,
    pub bytes: u64,
    /// The steps whose output is kept.
    pub outputs: Vec<&'static str>,
}

/// A long-lived renderer: one scene at a time, and the outputs of its latest renders.
///
/// ```no_run
/// # use cubist::{Settings, pipeline::Session, progress::Progress, scene::Scene};
/// let mut session = Session::new();
/// session.set_scene(Scene::default_scene());
/// let first = session.render(&Settings::default(), &Progress::silent()).unwrap();
/// // Another border width: only the paint stage (and encoding) run again.
/// let s = Settings { border_width: 2.0, ..Settings::default() };
/// let second = session.render(&s, &Progress::silent()).unwrap();
/// assert!(second.reused.contains(&"pre-render"));
/// // Another pose of the same meshes: the BVH is updated, mesh saliency is kept.
/// # let posed = Scene::default_scene();
/// session.set_scene(posed);
/// ```
pub struct Session {
    scene: Option<SceneEntry>,
    /// Most recent first.
    lanes: VecDeque<Lane>,
    gens: Gen,
    budget: u64,
}

impl Default for Session {
    fn default() -> Self {
        Session::new()
    }
}

impl Session {
    /// An empty session (no scene yet), with the default memory budget.
    pub fn new() -> Session {
        Session { scene: None, lanes: VecDeque::new(), gens: 0, budget: DEFAULT_BUDGET }
    }

    /// Sets how many bytes kept outputs may use (the current image size's are always kept).
    pub fn with_budget(mut self, bytes: u64) -> Session {
        self.budget = bytes;
        self
    }

    /// Loads `path` (the built-in still life when None), unless it is the file loaded last
    /// with the same bytes (and reads no other file), then `set_scene`. On an error the
    /// previous scene and outputs stay.
    pub fn load_scene(&mut self, path: Option<&Path>) -> Result<SceneUpdate> {
        self.load_scene_with(path, LoadOptions::default())
    }

    /// `load_scene` with what the file may reach besides itself (`params::load_options`).
    pub fn load_scene_with(&mut self, path: Option<&Path>, options: LoadOptions) -> Result<SceneUpdate> {
        let Some(path) = path else {
            if self.scene.as_ref().is_some_and(|s| s.builtin) {
                return Ok(self.unchanged(false));
            }
            let mut update = self.set_scene(Scene::default_scene());
            update.reloaded = true;
            if let Some(s) = self.scene.as_mut() {
                s.builtin = true;
            }
            return Ok(update);
        };
        let stamp = stamp(path, options);
        if let (Some(s), Some(st)) = (&self.scene, &stamp)
            && st.self_contained
            && s.file.as_ref() == Some(st)
        {
            return Ok(self.unchanged(false));
        }
        let scene = Scene::load_with(path, options)?;
        let mut update = self.set_scene(scene);
        update.reloaded = true;
        if let Some(s) = self.scene.as_mut() {
            s.file = stamp;
        }
        Ok(update)
    }

    /// Makes `scene` the session's scene. Nothing changes when its content is the current
    /// scene's. Otherwise the scene is flattened again, in its own render space (the one a
    /// fresh render of it uses, so the pixels are a fresh render's): the BVH is kept while
    /// the placed triangles are bit for bit the same (a change of lights, materials or
    /// camera), and otherwise brought up to the new world by `Accel::update`, which keeps the
    /// per-mesh BVH of every geometry baked to the same vertices (all of them while the render
    /// space holds, e.g. a mesh edited within the scene's bounds) and builds the rest; each
    /// mesh's saliency is kept by content, so only new or edited meshes compute theirs.
    pub fn set_scene(&mut self, scene: Scene) -> SceneUpdate {
        let (content, geometry, meshes) = fingerprints(&scene);
        if let Some(s) = &mut self.scene
            && s.content == content
        {
            s.file = None;
            s.builtin = false;
            return self.unchanged(false);
        }
        let t = Instant::now();
        let world = World::new(&scene);
        let old = self.scene.take();
        let changed = meshes.iter().filter(|k| !old.as_ref().is_some_and(|o| o.meshes.contains(k))).count();
        let (accel, memo, rebuilt) = match old {
            Some(o) if o.geometry == geometry => (o.prep.accel, o.prep.saliency, false),
            Some(o) => {
                let mut accel = o.prep.accel;
                accel.update(&world);
                (accel, o.prep.saliency, true)
            }
            None => (Accel::new(&world), Default::default(), true),
        };
        // Per-mesh saliency of meshes no longer in the scene is dropped (bounded memory).
        let methods = [SaliencyMethod::Auto, SaliencyMethod::Exact, SaliencyMethod::Clustered];
        let keep: std::collections::HashSet<u128> =
            scene.meshes.iter().flat_map(|m| methods.map(|k| saliency::content_key(m, k))).collect();
        memo.retain(|k| keep.contains(&k));
        let prep = Prepared { scene, world, accel, build_time: t.elapsed(), saliency: memo };
        self.gens += 1;
        let count = meshes.len();
        self.scene = Some(SceneEntry { prep, id: self.gens, content, geometry, meshes, file: None, builtin: false });
        // Every kept output read the old scene.
        self.lanes.clear();
        SceneUpdate { changed: true, reloaded: false, bvh_rebuilt: rebuilt, meshes: count, meshes_changed: changed }
    }

    fn unchanged(&self, reloaded: bool) -> SceneUpdate {
        let meshes = self.scene.as_ref().map_or(0, |s| s.meshes.len());
        SceneUpdate { changed: false, reloaded, bvh_rebuilt: false, meshes, meshes_changed: 0 }
    }

    /// The scene as prepared (None before the first `set_scene`/`load_scene`).
    pub fn prepared(&self) -> Option<&Prepared> {
        self.scene.as_ref().map(|s| &s.prep)
    }

    /// Renders `settings` through every stage, re-running only those whose inputs differ from
    /// what this session kept for the image size; the result is the picture `pipeline::render`
    /// gives for the same scene and settings, bit for bit. A cancelled render (`progress`'s
    /// flag) returns `Error::Cancelled` and keeps the stages it finished.
    pub fn render(&mut self, settings: &Settings, progress: &Progress) -> Result<Frame> {
        settings.validate()?;
        let params = StageParams::new(settings);
        let scene = self.scene.as_ref().ok_or_else(|| Error::Internal("no scene to render: set one first".into()))?;
        let (w, h) = (params.trace.width, params.trace.height);
        let at = self.lanes.iter().position(|l| l.size == (w, h));
        let lane = match at {
            Some(i) => self.lanes.remove(i).expect("found"),
            None => Lane::new(w, h),
        };
        self.lanes.push_front(lane);
        self.lanes.truncate(LANES);
        let lane = &mut self.lanes[0];
        let out = run(&scene.prep, scene.id, lane, &mut self.gens, &params, Policy::Kept, progress, None);
        // Within the budget: the oldest sizes go first; the one in use stays.
        while self.lanes.len() > 1 && self.lanes.iter().map(Lane::bytes).sum::<u64>() > self.budget {
            self.lanes.pop_back();
        }
        out
    }

    /// The facet layout, facet map and aims kept for an image size (the latest render's at
    /// that size), e.g. for facets that follow motion from frame to frame.
    pub fn facets(&self, width: u32, height: u32) -> Option<(&FacetLayout, &FacetMap, &[FacetAim])> {
        self.lanes.iter().find(|l| l.size == (width, height))?.facets()
    }

    /// Drops every kept stage output (the scene, its BVH and mesh saliency stay).
    pub fn clear(&mut self) {
        self.lanes.clear();
    }

    /// Drops everything, the scene too.
    pub fn reset(&mut self) {
        self.lanes.clear();
        self.scene = None;
    }

    pub fn stats(&self) -> SessionStats {
        let lanes: Vec<LaneStats> = self
            .lanes
            .iter()
            .map(|l| LaneStats { width: l.size.0, height: l.size.1, bytes: l.bytes(), outputs: l.held() })
            .collect();
        let scene = self.scene.as_ref();
        SessionStats {
            scene: scene.map(|s| match (&s.file, s.builtin) {
                (Some(f), _) => f.path.display().to_string(),
                (None, true) => "<default scene>".into(),
                (None, false) => "<memory>".into(),
            }),
            triangles: scene.map_or(0, |s| s.prep.world.triangle_count()),
            meshes: scene.map_or(0, |s| s.prep.scene.meshes.len()),
            saliency_meshes: scene.map_or(0, |s| s.prep.saliency.len()),
            bytes: lanes.iter().map(|l| l.bytes).sum(),
            lanes,
            budget: self.budget,
        }
    }
}

/// The bytes of a scene file and whether they are all the scene reads: a .glb whose buffers
/// and images are in the file (or `data:` URIs). Other files (.gltf with .bin and textures
/// beside it) are always read again. None when the file cannot be read (loading says why).
fn stamp(path: &Path, options: LoadOptions) -> Option<FileStamp> {
    let mut head = Vec::new();
    let hasher = hash_file(path, |chunk| {
        if head.len() < 20 {
            head.extend_from_slice(&chunk[..chunk.len().min(20 - head.len())]);
        }
    })?;
    let self_contained = glb_json(path, &head).is_some_and(|json| {
        let external = |key: &str| {
            json.get(key).and_then(|v| v.as_array()).is_some_and(|items| {
                items.iter().any(|i| i.get("uri").and_then(|u| u.as_str()).is_some_and(|u| !u.starts_with("data:")))
            })
        };
        !external("buffers") && !external("images")
    });
    Some(FileStamp { path: path.to_path_buf(), options, bytes: hasher.digest128(), self_contained })
}

/// The JSON chunk of a binary glTF (`head`: its first 20 bytes), if it is one.
fn glb_json(path: &Path, head: &[u8]) -> Option<serde_json::Value> {
    use std::io::{Read, Seek, SeekFrom};
    if head.len() < 20 || &head[..4] != b"glTF" || &head[16..20] != b"JSON" {
        return None;
    }
    let len = u32::from_le_bytes(head[12..16].try_into().ok()?) as u64;
    let (mut f, size) = crate::util::files::open_regular(path, u64::MAX).ok()?;
    if len > size {
        return None;
    }
    f.seek(SeekFrom::Start(20)).ok()?;
    let mut json = Vec::new();
    f.take(len).read_to_end(&mut json).ok()?;
    serde_json::from_slice(&json).ok()
}

/// The scene's content keys: everything a render reads of it; what the BVH is built from (each
/// object's mesh geometry and placement); and each mesh's saliency content key.
fn fingerprints(scene: &Scene) -> (u128, u128, Vec<u128>) {
    use bytemuck::cast_slice;
    let meshes: Vec<u128> = scene.meshes.iter().map(|m| saliency::content_key(m, SaliencyMethod::Auto)).collect();
    let mut geometry = Xxh3::new();
    for o in &scene.objects {
        geometry.update(&meshes.get(o.mesh).copied().unwrap_or(0).to_le_bytes());
        geometry.update(cast_slice(&o.transform.to_cols_array()));
    }
    let geometry = geometry.digest128();

    let mut h = Xxh3::new();
    let text = |h: &mut Xxh3, s: &str| {
        h.update(&(s.len() as u64).to_le_bytes());
        h.update(s.as_bytes());
    };
    h.update(&geometry.to_le_bytes());
    for m in &scene.meshes {
        text(&mut h, &m.name);
        h.update(cast_slice(&m.positions));
        h.update(cast_slice(&m.normals));
        h.update(&[m.uvs.is_some() as u8, m.colors.is_some() as u8]);
        if let Some(uv) = &m.uvs {
            h.update(cast_slice(uv));
        }
        if let Some(c) = &m.colors {
            h.update(cast_slice(c));
        }
        h.update(cast_slice(&m.triangles));
        h.update(&m.material.map_or(u64::MAX, |i| i as u64).to_le_bytes());
    }
    for o in &scene.objects {
        text(&mut h, &o.name);
        h.update(&(o.mesh as u64).to_le_bytes());
    }
    for m in &scene.materials {
        text(&mut h, &format!("{m:?}"));
    }
    for t in &scene.textures {
        text(&mut h, &format!("{} {} {:?} {:?} {:?}", t.width, t.height, t.wrap_s, t.wrap_t, t.filter));
        h.update(cast_slice(&t.pixels));
    }
    // Lights, camera and warnings: small; their Debug forms print every float exactly.
    text(&mut h, &format!("{:?} {:?} {:?}", scene.lights, scene.camera, scene.warnings));
    (h.digest128(), geometry, meshes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fingerprints_follow_content_not_identity() {
        let a = Scene::default_scene();
        let (c, g, m) = fingerprints(&a);
        assert_eq!((c, g, m.clone()), fingerprints(&a.clone()));
        // A material changed: the content changes, not the geometry.
        let mut lit = a.clone();
        lit.materials[0].roughness *= 0.5;
        let (c2, g2, m2) = fingerprints(&lit);
        assert_ne!(c, c2);
        assert_eq!((g, &m), (g2, &m2));
        // An object moved: the geometry changes, no mesh does.
        let mut moved = a.clone();
        moved.objects[0].transform.w_axis.x += 0.5;
        let (_, g3, m3) = fingerprints(&moved);
        assert_ne!(g, g3);
        assert_eq!(m, m3);
        // A vertex moved: that one mesh changes.
        let mut edited = a.clone();
        edited.meshes[1].positions[0].y += 0.01;
        let (_, _, m4) = fingerprints(&edited);
        assert_eq!(m.iter().zip(&m4).filter(|(x, y)| x != y).count(), 1);
    }
}
