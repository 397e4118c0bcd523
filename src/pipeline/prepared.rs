//! A scene ready to trace: what stays the same between views and frames.

use std::path::Path;
use std::time::{Duration, Instant};

use crate::accel::Accel;
use crate::error::Result;
use crate::saliency::{Memo, SaliencyParams};
use crate::scene::{LoadOptions, Scene, World};

/// A loaded scene, flattened into render space, with its BVH, and the per-mesh saliency
/// computed so far (by content), reused by every view and frame rendered from it.
pub struct Prepared {
    pub scene: Scene,
    pub world: World,
    pub accel: Accel,
    /// Time spent flattening and building the BVH.
    pub build_time: Duration,
    pub saliency: Memo,
}

impl Prepared {
    pub fn new(scene: Scene) -> Prepared {
        let t = Instant::now();
        let world = World::new(&scene);
        let accel = Accel::new(&world);
        Prepared { scene, world, accel, build_time: t.elapsed(), saliency: Memo::default() }
    }

    /// `new`, with every placed mesh's saliency (`saliency::precompute`, by `saliency`'s method)
    /// computed beside the BVH build into the memo the render's saliency stage reads: it reads
    /// only the meshes, and the build leaves a core idle in its serial parts. Also returns that
    /// computation's wall time (`build_time` is the build's, the two overlapping).
    pub fn with_saliency(scene: Scene, saliency: &SaliencyParams) -> (Prepared, Duration) {
        let t = Instant::now();
        let world = World::new(&scene);
        let (mut prep, mesh_time) = Prepared::build_with_saliency(scene, world, saliency);
        prep.build_time = t.elapsed();
        (prep, mesh_time)
    }

    /// `with_saliency` from the scene already placed in render space (`build_time`: the BVH's).
    pub fn build_with_saliency(scene: Scene, world: World, saliency: &SaliencyParams) -> (Prepared, Duration) {
        let t = Instant::now();
        let memo = Memo::default();
        let (accel, mesh_time) = rayon::join(
            || Accel::new(&world),
            || {
                let t = Instant::now();
                crate::saliency::precompute(&scene, &world, &memo, saliency);
                t.elapsed()
            },
        );
        (Prepared { scene, world, accel, build_time: t.elapsed(), saliency: memo }, mesh_time)
    }

    /// `load_with`, then `with_saliency` when `saliency` is given (a render that needs it).
    pub fn load_for_render(
        path: Option<&Path>,
        options: LoadOptions,
        saliency: Option<&SaliencyParams>,
    ) -> Result<(Prepared, Option<Duration>)> {
        let scene = match path {
            Some(p) => Scene::load_with(p, options)?,
            None => Scene::default_scene(),
        };
        Ok(match saliency {
            Some(s) => {
                let (prep, t) = Prepared::with_saliency(scene, s);
                (prep, Some(t))
            }
            None => (Prepared::new(scene), None),
        })
    }

    /// Loads `path`, or the built-in still life when None.
    pub fn load(path: Option<&Path>) -> Result<Prepared> {
        Prepared::load_with(path, LoadOptions::default())
    }

    /// Loads `path` with `options` (`params::load_options`), or the built-in still life.
    pub fn load_with(path: Option<&Path>, options: LoadOptions) -> Result<Prepared> {
        let scene = match path {
            Some(p) => Scene::load_with(p, options)?,
            None => Scene::default_scene(),
        };
        Ok(Prepared::new(scene))
    }
}
