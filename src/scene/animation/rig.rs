//! The scene graph kept for animation: every node's parent and rest transform, which node
//! places each object, light and the camera, skins, and the undeformed data of skinned and
//! morphed primitives. `Rig::pose` evaluates a clip at a time into a `Pose`.
//!
//! The loader builds the rest pose with the same functions (`deform`, `Skin::matrices`), so
//! an animation sampled at a time where it leaves everything at rest gives the loaded scene
//! bit for bit.

use std::sync::Arc;

use glam::{DMat4, DQuat, DVec3, Vec3};
use rayon::prelude::*;

use super::clip::{Clip, Property};
use crate::scene::{Projection, SceneCamera, compute_normals};

/// A node's transform relative to its parent.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Local {
    /// Translation, unit rotation, scale: what animation channels target.
    Trs { translation: DVec3, rotation: DQuat, scale: DVec3 },
    /// A matrix (glTF forbids animating such a node; channels on it are refused at load).
    Matrix(DMat4),
}

impl Local {
    pub fn matrix(&self) -> DMat4 {
        match *self {
            Local::Trs { translation, rotation, scale } => {
                DMat4::from_scale_rotation_translation(scale, rotation, translation)
            }
            Local::Matrix(m) => m,
        }
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct RigNode {
    pub parent: Option<u32>,
    pub local: Local,
    /// Morph target weights at rest: the node's, else its mesh's, else none.
    pub weights: Vec<f32>,
}

/// A skin: its joints (nodes) and their inverse bind matrices.
#[derive(Clone, Debug, PartialEq)]
pub struct Skin {
    pub joints: Vec<u32>,
    pub inverse_bind: Vec<DMat4>,
}

impl Skin {
    /// Joint matrices for linear blend skinning, scene space: world(joint) x inverse bind.
    pub fn matrices(&self, world: &[DMat4]) -> Vec<DMat4> {
        self.joints.iter().zip(&self.inverse_bind).map(|(&j, ibm)| world[j as usize] * *ibm).collect()
    }
}

/// One morph target's deltas (either may be absent).
#[derive(Clone, Debug, PartialEq)]
pub struct MorphTarget {
    pub positions: Option<Vec<Vec3>>,
    pub normals: Option<Vec<Vec3>>,
}

/// JOINTS_0 and WEIGHTS_0, one entry per vertex, joint indices checked against the skin.
#[derive(Clone, Debug, PartialEq)]
pub struct Skinning {
    pub joints: Vec<[u32; 4]>,
    pub weights: Vec<[f32; 4]>,
}

/// A primitive as in the file, before morph targets and skin: what every frame deforms.
#[derive(Clone, Debug, PartialEq)]
pub struct Deformable {
    pub positions: Vec<Vec3>,
    pub normals: Option<Vec<Vec3>>,
    pub targets: Vec<MorphTarget>,
    pub skinning: Option<Skinning>,
}

/// Positions and unit normals of `d` with morph `weights` and, when skinned, `joints` (the
/// skin's joint matrices). The loader's rest pose is this function at the rest weights and
/// joints. Morph deltas are summed in f32 in target order, skinning is in f64 (weights that do
/// not sum to 1, as in CesiumMan, renormalised), normals go through the inverse transpose, and
/// a normal that is missing or degenerate is replaced by the area-weighted one of the deformed
/// triangles.
pub fn deform(
    d: &Deformable,
    weights: &[f32],
    joints: Option<&[DMat4]>,
    triangles: &[[u32; 3]],
) -> (Vec<Vec3>, Vec<Vec3>) {
    deform_parts(d.positions.clone(), d.normals.clone(), d, weights, joints, triangles)
}

/// `deform` of a primitive no frame deforms again: its own vectors are deformed, not copies
/// (the same values; no copy of a million triangles' vertices at load).
pub fn deform_owned(
    mut d: Deformable,
    weights: &[f32],
    joints: Option<&[DMat4]>,
    triangles: &[[u32; 3]],
) -> (Vec<Vec3>, Vec<Vec3>) {
    let (positions, normals) = (std::mem::take(&mut d.positions), d.normals.take());
    deform_parts(positions, normals, &d, weights, joints, triangles)
}

/// `deform` from `positions` and `normals` (those of `d`, owned), reading `d`'s targets and
/// skin.
fn deform_parts(
    mut positions: Vec<Vec3>,
    mut normals: Option<Vec<Vec3>>,
    d: &Deformable,
    weights: &[f32],
    joints: Option<&[DMat4]>,
    triangles: &[[u32; 3]],
) -> (Vec<Vec3>, Vec<Vec3>) {
    for (t, target) in d.targets.iter().enumerate() {
        let w = weights.get(t).copied().unwrap_or(0.0);
        if w == 0.0 {
            continue;
        }
        if let Some(delta) = &target.positions {
            for (p, dp) in positions.iter_mut().zip(delta) {
                *p += w * *dp;
            }
        }
        if let (Some(delta), Some(n)) = (&target.normals, normals.as_mut()) {
            for (n, dn) in n.iter_mut().zip(delta) {
                *n += w * *dn;
            }
        }
    }
    if let (Some(skin), Some(joints)) = (&d.skinning, joints) {
        for i in 0..positions.len() {
            let mut m = DMat4::ZERO;
            let mut total = 0.0f64;
            for k in 0..4 {
                let w = skin.weights[i][k] as f64;
                if w == 0.0 {
                    continue;
                }
                m += joints[skin.joints[i][k] as usize] * w;
                total += w;
            }
            let m = if total > 0.0 { m * (1.0 / total) } else { DMat4::IDENTITY };
            positions[i] = m.transform_point3(positions[i].as_dvec3()).as_vec3();
            if let Some(n) = normals.as_mut() {
                let nm = m.inverse().transpose();
                n[i] = nm.transform_vector3(n[i].as_dvec3()).as_vec3();
            }
        }
    }
    // The area-weighted normals only when some normal needs them (the same values: a normal
    // that normalises is kept either way).
    let unit = |n: &Vec3| if n.is_finite() { n.try_normalize() } else { None };
    let normals = match normals {
        Some(n) => {
            let fallback = n.par_iter().any(|n| unit(n).is_none()).then(|| compute_normals(&positions, triangles));
            n.par_iter()
                .enumerate()
                .map(|(i, n)| unit(n).unwrap_or_else(|| fallback.as_ref().expect("computed when one is needed")[i]))
                .collect()
        }
        None => compute_normals(&positions, triangles),
    };
    (positions, normals)
}

/// An object of the scene (`Scene::objects`, same index) and what places it.
#[derive(Clone, Debug, PartialEq)]
pub struct Instance {
    pub node: u32,
    /// Its mesh in `Scene::meshes` (a deformable instance has a mesh of its own).
    pub mesh: usize,
    /// The skin deforming it: the object's transform is then the identity (glTF ignores the
    /// node's transform for skinned meshes).
    pub skin: Option<u32>,
    pub deform: Option<Arc<Deformable>>,
}

/// The scene graph and animations of a loaded glTF (`Scene::rig`).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Rig {
    pub nodes: Vec<RigNode>,
    /// The default scene's nodes, every parent before its children.
    pub order: Vec<u32>,
    pub instances: Vec<Instance>,
    pub skins: Vec<Skin>,
    /// The node of `Scene::camera`, and its projection.
    pub camera: Option<(u32, Projection)>,
    /// The node of each of `Scene::lights`, in order.
    pub lights: Vec<u32>,
    /// The file's animations, in its order; one that cannot be played holds the reason.
    pub clips: Vec<Result<Clip, String>>,
}

/// Everything a clip changes at one time: objects' transforms, deformed meshes, the camera
/// and lights. Unlisted parts of the scene are at rest.
#[derive(Clone, Debug, PartialEq)]
pub struct Pose {
    /// (object index, its transform), for the objects the clip moves.
    pub transforms: Vec<(usize, DMat4)>,
    /// (mesh index, positions, unit normals), for the meshes the clip deforms.
    pub meshes: Vec<(usize, Vec<Vec3>, Vec<Vec3>)>,
    /// The scene's camera when the clip moves it (None: at rest, or degenerate this frame).
    pub camera: Option<SceneCamera>,
    /// (light index, position, unit direction), for the lights the clip moves.
    pub lights: Vec<(usize, DVec3, DVec3)>,
}

impl Rig {
    /// World transforms of every node from local ones, parents first (nodes outside the
    /// default scene keep the identity).
    pub fn world(&self, local: &[DMat4]) -> Vec<DMat4> {
        let mut world = vec![DMat4::IDENTITY; self.nodes.len()];
        for &n in &self.order {
            let n = n as usize;
            world[n] = match self.nodes[n].parent {
                Some(p) => world[p as usize] * local[n],
                None => local[n],
            };
        }
        world
    }

    /// Which nodes `clip` moves, directly or through an ancestor.
    fn moved_nodes(&self, clip: &Clip) -> Vec<bool> {
        let mut moved = vec![false; self.nodes.len()];
        for c in &clip.channels {
            if c.property != Property::Weights {
                moved[c.node as usize] = true;
            }
        }
        for &n in &self.order {
            if let Some(p) = self.nodes[n as usize].parent
                && moved[p as usize]
            {
                moved[n as usize] = true;
            }
        }
        moved
    }

    /// The pose of `clips` (applied in order, a later channel overriding an earlier one on the
    /// same property) at `time` seconds. `triangles(mesh)` gives a deformed mesh's triangles
    /// (for normals the file does not give). Cost: one binary search per channel, one matrix
    /// per node, and the vertices of the instances the clips deform.
    pub fn pose<'t>(&self, clips: &[&Clip], time: f64, triangles: impl Fn(usize) -> &'t [[u32; 3]]) -> Pose {
        let mut local: Vec<Local> = self.nodes.iter().map(|n| n.local).collect();
        let mut weights: Vec<Option<Vec<f32>>> = vec![None; self.nodes.len()];
        let mut moved = vec![false; self.nodes.len()];
        for clip in clips {
            for (m, c) in moved.iter_mut().zip(self.moved_nodes(clip)) {
                *m |= c;
            }
            for c in &clip.channels {
                let sampler = &clip.samplers[c.sampler];
                let node = c.node as usize;
                match (c.property, &mut local[node]) {
                    (Property::Translation, Local::Trs { translation, .. }) => *translation = sampler.sample_vec3(time),
                    (Property::Rotation, Local::Trs { rotation, .. }) => *rotation = sampler.sample_rotation(time),
                    (Property::Scale, Local::Trs { scale, .. }) => *scale = sampler.sample_vec3(time),
                    (Property::Weights, _) => {
                        let mut w = vec![0.0; sampler.width()];
                        sampler.sample(time, &mut w);
                        weights[node] = Some(w.into_iter().map(|x| x as f32).collect());
                    }
                    // Refused at load (`Clip` channels never target matrix nodes).
                    (_, Local::Matrix(_)) => {}
                }
            }
        }
        let local: Vec<DMat4> = local.iter().map(Local::matrix).collect();
        let world = self.world(&local);
        let moved_joints: Vec<bool> = self.skins.iter().map(|s| s.joints.iter().any(|&j| moved[j as usize])).collect();

        let mut pose = Pose { transforms: Vec::new(), meshes: Vec::new(), camera: None, lights: Vec::new() };
        for (o, inst) in self.instances.iter().enumerate() {
            let node = inst.node as usize;
            if inst.skin.is_none() && moved[node] {
                pose.transforms.push((o, world[node]));
            }
            let Some(d) = &inst.deform else { continue };
            let skin_moved = inst.skin.is_some_and(|s| moved_joints[s as usize]);
            if weights[node].is_none() && !skin_moved {
                continue;
            }
            let w = weights[node].as_deref().unwrap_or(&self.nodes[node].weights);
            let joints = inst.skin.map(|s| self.skins[s as usize].matrices(&world));
            let (p, n) = deform(d, w, joints.as_deref(), triangles(inst.mesh));
            pose.meshes.push((inst.mesh, p, n));
        }
        if let Some((node, projection)) = self.camera
            && moved[node as usize]
        {
            pose.camera = camera_at(world[node as usize], projection);
        }
        for (i, &node) in self.lights.iter().enumerate() {
            if moved[node as usize] {
                let m = world[node as usize];
                let direction = m.transform_vector3(DVec3::NEG_Z).try_normalize().unwrap_or(DVec3::NEG_Z);
                pose.lights.push((i, m.transform_point3(DVec3::ZERO), direction));
            }
        }
        pose
    }
}

/// The glTF camera of a node with world transform `m` (it looks along its local -Z, up +Y);
/// None when the transform is degenerate (a zero scale).
pub fn camera_at(m: DMat4, projection: Projection) -> Option<SceneCamera> {
    let position = m.transform_point3(DVec3::ZERO);
    let forward = m.transform_vector3(DVec3::NEG_Z).try_normalize()?;
    let up = m.transform_vector3(DVec3::Y);
    let up = (up - forward * up.dot(forward)).try_normalize()?;
    Some(SceneCamera { position, forward, up, projection, focus_distance: None })
}
