//! An animation as the file gives it: channels, each a node's translation, rotation, scale or
//! morph weights driven by a sampler.

use std::sync::Arc;

use super::sampler::Sampler;

/// What a channel animates (glTF `channel.target.path`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Property {
    Translation,
    Rotation,
    Scale,
    Weights,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Channel {
    pub node: u32,
    pub property: Property,
    /// Index into `Clip::samplers` (several channels may share one).
    pub sampler: usize,
}

/// One glTF animation.
#[derive(Clone, Debug, PartialEq)]
pub struct Clip {
    /// Its name, or `animation i`.
    pub name: String,
    pub channels: Vec<Channel>,
    pub samplers: Vec<Arc<Sampler>>,
}

impl Clip {
    /// Time of its last keyframe, seconds (its first frame is time 0).
    pub fn end(&self) -> f64 {
        self.channels.iter().map(|c| self.samplers[c.sampler].end() as f64).fold(0.0, f64::max)
    }
}
