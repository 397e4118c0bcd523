//! Skins: joints and inverse bind matrices, and each skinned primitive's JOINTS_0/WEIGHTS_0,
//! checked once here; `scene::animation::deform` does the linear blend skinning, for the rest
//! pose (the loader) and for animation frames alike.

use glam::DMat4;

use super::Loader;
use super::accessor::read_floats;
use crate::error::Result;
use crate::scene::animation::{Skin, Skinning};

impl Loader<'_> {
    /// The skin's joints (nodes of the rendered scene) and inverse bind matrices.
    pub(super) fn read_skin(&self, skin: &gltf::Skin) -> Result<Skin> {
        let joints: Vec<_> = skin.joints().collect();
        let ibms: Vec<[f32; 16]> = match skin.inverse_bind_matrices() {
            Some(acc) => {
                read_floats::<16>(&acc, &self.buffers, &format!("accessor {} (inverseBindMatrices)", acc.index()))
                    .map_err(|m| self.err(m))?
            }
            None => vec![glam::Mat4::IDENTITY.to_cols_array(); joints.len()],
        };
        if ibms.len() < joints.len() {
            return Err(self.err(format!(
                "skin {}: {} inverse bind matrices for {} joints",
                skin.index(),
                ibms.len(),
                joints.len()
            )));
        }
        let mut inverse_bind = Vec::with_capacity(joints.len());
        for (j, ibm) in joints.iter().zip(ibms) {
            if self.world[j.index()].is_none() {
                return Err(self.err(format!(
                    "skin {}: joint node {} is not in the rendered scene",
                    skin.index(),
                    j.index()
                )));
            }
            let ibm = DMat4::from_cols_array(&ibm.map(|x| x as f64));
            if !ibm.is_finite() {
                return Err(self.err(format!("skin {}: inverse bind matrix is not finite", skin.index())));
            }
            inverse_bind.push(ibm);
        }
        Ok(Skin { joints: joints.iter().map(|j| j.index() as u32).collect(), inverse_bind })
    }

    /// JOINTS_0 and WEIGHTS_0 of a skinned primitive of `vertices` vertices, every weighted
    /// joint index checked against the skin's `joint_count`.
    pub(super) fn read_skinning(
        &self,
        prim: &gltf::Primitive,
        name: &str,
        joint_count: usize,
        vertices: usize,
    ) -> Result<Skinning> {
        let (Some(jacc), Some(wacc)) = (prim.get(&gltf::Semantic::Joints(0)), prim.get(&gltf::Semantic::Weights(0)))
        else {
            return Err(self.err(format!("{name}: skinned node but the primitive has no JOINTS_0/WEIGHTS_0")));
        };
        let joints = read_floats::<4>(&jacc, &self.buffers, &format!("accessor {} (JOINTS_0 of {name})", jacc.index()))
            .map_err(|m| self.err(m))?;
        let weights =
            read_floats::<4>(&wacc, &self.buffers, &format!("accessor {} (WEIGHTS_0 of {name})", wacc.index()))
                .map_err(|m| self.err(m))?;
        if joints.len() != vertices || weights.len() != vertices {
            return Err(self.err(format!("{name}: JOINTS_0/WEIGHTS_0 counts differ from POSITION")));
        }
        let mut out = Skinning { joints: Vec::with_capacity(vertices), weights: Vec::with_capacity(vertices) };
        for (i, (j, w)) in joints.iter().zip(&weights).enumerate() {
            let mut ids = [0u32; 4];
            let mut ws = [0f32; 4];
            for k in 0..4 {
                if w[k] == 0.0 {
                    continue;
                }
                if !(j[k] >= 0.0 && (j[k] as usize) < joint_count) {
                    return Err(self.err(format!(
                        "{name}: vertex {i} uses joint {} of a {joint_count}-joint skin",
                        j[k] as usize
                    )));
                }
                ids[k] = j[k] as u32;
                ws[k] = w[k];
            }
            out.joints.push(ids);
            out.weights.push(ws);
        }
        Ok(out)
    }
}
