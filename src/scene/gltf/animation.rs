//! The file's scene graph and animations as a `Rig` (kept only when the file has animations):
//! every node's rest transform and parent, and each animation's channels and samplers.
//!
//! A malformed animation does not stop the scene from loading (a still shows the rest pose):
//! it is kept as the reason it cannot be played, reported when a render asks for it. Samplers
//! shared by several channels or animations are read once, and the keyframe data of all
//! animations together is bounded (`MAX_ANIMATION_VALUES`), so a small file cannot make us
//! decode one large accessor again and again.

use std::collections::HashMap;
use std::sync::Arc;

use glam::{DQuat, DVec3};

use super::Loader;
use super::accessor::read_floats;
use crate::error::Result;
use crate::scene::animation::{Channel, Clip, Interpolation, Local, Property, Rig, RigNode, Sampler};

/// Keyframe times and values decoded for all animations together, numbers (1 GB of f32).
const MAX_ANIMATION_VALUES: usize = 1 << 28;

/// Samplers read so far, by (input, output, interpolation, width): each read once.
type SamplerCache = HashMap<(usize, usize, u8, usize), Result<Arc<Sampler>, String>>;

impl<'a> Loader<'a> {
    /// Every node's parent, rest transform and rest morph weights (`order` is filled as the
    /// scene is walked).
    pub(super) fn rig_nodes(&self) -> Result<Vec<RigNode>> {
        let mut nodes: Vec<RigNode> = Vec::with_capacity(self.doc.nodes().len());
        for node in self.doc.nodes() {
            let local = match node.transform() {
                gltf::scene::Transform::Matrix { .. } => Local::Matrix(self.local_transform(&node)?),
                gltf::scene::Transform::Decomposed { translation, rotation, scale } => {
                    // Checked finite by `local_transform`, which builds the same matrix.
                    self.local_transform(&node)?;
                    let q = DQuat::from_array(rotation.map(|x| x as f64));
                    Local::Trs {
                        translation: DVec3::from(translation.map(|x| x as f64)),
                        rotation: if q.length_squared() > 0.0 { q.normalize() } else { DQuat::IDENTITY },
                        scale: DVec3::from(scale.map(|x| x as f64)),
                    }
                }
            };
            let weights = node.weights().or(node.mesh().and_then(|m| m.weights())).map(<[f32]>::to_vec);
            nodes.push(RigNode { parent: None, local, weights: weights.unwrap_or_default() });
        }
        for node in self.doc.nodes() {
            for child in node.children() {
                nodes[child.index()].parent = Some(node.index() as u32);
            }
        }
        Ok(nodes)
    }

    /// Reads every animation into `rig.clips`.
    pub(super) fn load_animations(&self, rig: &mut Rig) {
        let mut cache: SamplerCache = HashMap::new();
        let mut budget = MAX_ANIMATION_VALUES;
        for anim in self.doc.animations() {
            let clip = self.clip(&anim, rig, &mut cache, &mut budget);
            rig.clips.push(clip);
        }
    }

    fn clip(
        &self,
        anim: &gltf::Animation,
        rig: &Rig,
        cache: &mut SamplerCache,
        budget: &mut usize,
    ) -> Result<Clip, String> {
        let name = anim.name().map(str::to_string).unwrap_or_else(|| format!("animation {}", anim.index()));
        let mut channels = Vec::new();
        let mut samplers: Vec<Arc<Sampler>> = Vec::new();
        let mut local_index: HashMap<usize, usize> = HashMap::new();
        for (c, channel) in anim.channels().enumerate() {
            let target = channel.target();
            let node = target.node();
            let n = node.index();
            let what = format!("channel {c}");
            let property = match target.property() {
                gltf::animation::Property::Translation => Property::Translation,
                gltf::animation::Property::Rotation => Property::Rotation,
                gltf::animation::Property::Scale => Property::Scale,
                gltf::animation::Property::MorphTargetWeights => Property::Weights,
            };
            if property != Property::Weights && matches!(rig.nodes[n].local, Local::Matrix(_)) {
                return Err(format!("{what}: node {n} has a matrix transform, and glTF animates only TRS nodes"));
            }
            let width = match property {
                Property::Translation | Property::Scale => 3,
                Property::Rotation => 4,
                Property::Weights => {
                    let targets =
                        node.mesh().map(|m| m.primitives().map(|p| p.morph_targets().len()).max().unwrap_or(0));
                    match targets {
                        Some(t) if t > 0 => t,
                        _ => {
                            return Err(format!(
                                "{what}: animates the morph weights of node {n}, which has no morph targets"
                            ));
                        }
                    }
                }
            };
            let sampler = channel.sampler();
            let key = (sampler.input().index(), sampler.output().index(), sampler.interpolation() as u8, width);
            let read = match cache.get(&key) {
                Some(s) => s.clone(),
                None => {
                    let s = self.sampler(&sampler, width, budget).map(Arc::new);
                    cache.insert(key, s.clone());
                    s
                }
            };
            let read = read.map_err(|e| format!("{what} (sampler {}): {e}", sampler.index()))?;
            let index = *local_index.entry(Arc::as_ptr(&read) as usize).or_insert_with(|| {
                samplers.push(read.clone());
                samplers.len() - 1
            });
            channels.push(Channel { node: n as u32, property, sampler: index });
        }
        if channels.is_empty() {
            return Err("it has no channel".into());
        }
        Ok(Clip { name, channels, samplers })
    }

    fn sampler(&self, sampler: &gltf::animation::Sampler, width: usize, budget: &mut usize) -> Result<Sampler, String> {
        let (input, output) = (sampler.input(), sampler.output());
        let values = input.count().saturating_add(output.count().saturating_mul(output.dimensions().multiplicity()));
        if values > *budget {
            return Err(format!(
                "the animations' keyframes exceed {MAX_ANIMATION_VALUES} numbers in total (the file's animations are too large to play)"
            ));
        }
        *budget -= values;
        if input.data_type() != gltf::accessor::DataType::F32 {
            return Err(format!("input accessor {} is not of floats (keyframe times are seconds)", input.index()));
        }
        let times: Vec<f32> = read_floats::<1>(&input, &self.buffers, &format!("input accessor {}", input.index()))?
            .into_iter()
            .map(|[t]| t)
            .collect();
        let what = format!("output accessor {}", output.index());
        let values: Vec<f32> = match width {
            3 => read_floats::<3>(&output, &self.buffers, &what)?.into_iter().flatten().collect(),
            4 => read_floats::<4>(&output, &self.buffers, &what)?.into_iter().flatten().collect(),
            _ => read_floats::<1>(&output, &self.buffers, &what)?.into_iter().flatten().collect(),
        };
        let interpolation = match sampler.interpolation() {
            gltf::animation::Interpolation::Step => Interpolation::Step,
            gltf::animation::Interpolation::Linear => Interpolation::Linear,
            gltf::animation::Interpolation::CubicSpline => Interpolation::CubicSpline,
        };
        Sampler::new(times, values, width, interpolation)
    }

    /// The default scene's nodes with every parent before its children.
    pub(super) fn scene_order(roots: &[gltf::Node]) -> Vec<u32> {
        let mut order = Vec::new();
        let mut stack: Vec<gltf::Node> = roots.iter().rev().cloned().collect();
        while let Some(n) = stack.pop() {
            order.push(n.index() as u32);
            let children: Vec<_> = n.children().collect();
            stack.extend(children.into_iter().rev());
        }
        order
    }
}
