//! glTF animation: node translation, rotation, scale and morph weights driven by keyframes
//! (`sampler`: STEP, LINEAR, CUBICSPLINE with the specification's quaternion rules), skins and
//! morph targets re-evaluated per frame (`rig`), applied to a loaded scene (`apply`).
//!
//! The loader (`scene::gltf`) fills a `Rig` when the file has animations; everything here is
//! plain data and maths, so it is tested without files. Which time a frame shows is the
//! sequence's (`pipeline::FramesParams::time`): by default frame 1 is the clips' time 0.
//!
//! Bounds: a sample costs a binary search per channel, a pose one matrix per node and the
//! vertices of the instances it deforms, all bounded by the file's size (its accessors are
//! bounded by the loader); times outside the keys are clamped, never extrapolated.

pub mod clip;
pub mod rig;
pub mod sampler;

pub use clip::{Channel, Clip, Property};
pub use rig::{
    Deformable, Instance, Local, MorphTarget, Pose, Rig, RigNode, Skin, Skinning, camera_at, deform, deform_owned,
};
pub use sampler::{Interpolation, Sampler};

use std::collections::HashSet;

use crate::error::{Error, Result};
use crate::scene::Scene;

/// Which of the file's animations a render plays (`--animation`).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Choice {
    /// By position in the file, from 0.
    Index(usize),
    /// By name.
    Name(String),
    /// Every animation at once, in file order (InterpolationTest's cubes each have their own).
    All,
    /// What plays without `--animation`: the first animation, with every later one that drives
    /// none of the nodes the ones before it drive. Animations of the same nodes are
    /// alternatives (Fox's Survey, Walk and Run: the first plays); animations of different
    /// nodes are parts of one scene's motion (Blender's exporter writes one per object by
    /// default, the camera's apart from the figure's: all of them play).
    Default,
}

impl Choice {
    /// `all`, an index, or a name.
    pub fn parse(s: &str) -> Choice {
        match s {
            "all" => Choice::All,
            _ => s.parse().map(Choice::Index).unwrap_or_else(|_| Choice::Name(s.to_string())),
        }
    }
}

/// The clips `choice` selects from `scene`, or an error naming what the scene offers.
pub fn select<'a>(scene: &'a Scene, choice: &Choice) -> Result<Vec<&'a Clip>> {
    let clips = scene.rig.as_ref().map(|r| r.clips.as_slice()).unwrap_or_default();
    let bad = |m: String| Error::setting("animation", m);
    if clips.is_empty() {
        return Err(bad(format!("{} has no animation", scene.source.display())));
    }
    let names = || {
        clips
            .iter()
            .enumerate()
            .map(|(i, c)| match c {
                Ok(c) => format!("{i}: {}", c.name),
                Err(_) => format!("{i}: (invalid)"),
            })
            .collect::<Vec<_>>()
            .join(", ")
    };
    let checked = |i: usize| -> Result<&'a Clip> {
        clips[i].as_ref().map_err(|e| Error::scene(&scene.source, format!("animation {i}: {e}")))
    };
    match choice {
        Choice::All => clips.iter().enumerate().map(|(i, _)| checked(i)).collect(),
        Choice::Default => {
            let mut chosen = vec![checked(0)?];
            let mut driven: HashSet<u32> = chosen[0].channels.iter().map(|c| c.node).collect();
            // A later animation that does not load is left out, as it was before it was read.
            for clip in clips[1..].iter().filter_map(|c| c.as_ref().ok()) {
                if clip.channels.iter().all(|c| !driven.contains(&c.node)) {
                    driven.extend(clip.channels.iter().map(|c| c.node));
                    chosen.push(clip);
                }
            }
            Ok(chosen)
        }
        Choice::Index(i) if *i < clips.len() => Ok(vec![checked(*i)?]),
        Choice::Index(i) => {
            Err(bad(format!("animation {i} does not exist: the scene has {} ({})", clips.len(), names())))
        }
        Choice::Name(n) => match clips.iter().position(|c| c.as_ref().is_ok_and(|c| &c.name == n)) {
            Some(i) => Ok(vec![checked(i)?]),
            None => Err(bad(format!("no animation named `{n}`: the scene has {}", names()))),
        },
    }
}

/// Puts `pose` into `scene` (a copy of the loaded scene, at rest wherever the pose says
/// nothing): object transforms, deformed meshes' positions and normals, the camera, lights.
pub fn apply(scene: &mut Scene, pose: &Pose) {
    for &(o, m) in &pose.transforms {
        scene.objects[o].transform = m;
    }
    for (m, p, n) in &pose.meshes {
        scene.meshes[*m].positions.clone_from(p);
        scene.meshes[*m].normals.clone_from(n);
    }
    if let Some(c) = &pose.camera
        && let Some(cam) = scene.camera.as_mut()
    {
        cam.position = c.position;
        cam.forward = c.forward;
        cam.up = c.up;
    }
    for &(i, position, direction) in &pose.lights {
        if let Some(l) = scene.lights.get_mut(i) {
            l.position = position;
            l.direction = direction;
        }
    }
}

#[cfg(test)]
mod tests;
