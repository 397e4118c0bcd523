//! A scene ready to trace: what stays the same between views and frames.

use std::path::Path;
use std::time::{Duration, Instant};

use crate::accel::Accel;
use crate::error::Result;
use crate::saliency::Memo;
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
