//! Skins in the rest pose: joint matrices and linear blend skinning of the positions.

use glam::{DMat4, Vec3};

use super::Loader;
use super::accessor::read_floats;
use crate::error::Result;

impl Loader<'_> {
    /// Joint matrices (scene space) for linear blend skinning in the rest pose.
    pub(super) fn skin_matrices(&self, skin: &gltf::Skin) -> Result<Vec<DMat4>> {
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
        joints
            .iter()
            .zip(ibms)
            .map(|(j, ibm)| {
                let jw = self.world[j.index()].ok_or_else(|| {
                    self.err(format!("skin {}: joint node {} is not in the rendered scene", skin.index(), j.index()))
                })?;
                let ibm = DMat4::from_cols_array(&ibm.map(|x| x as f64));
                if !ibm.is_finite() {
                    return Err(self.err(format!("skin {}: inverse bind matrix is not finite", skin.index())));
                }
                Ok(jw * ibm)
            })
            .collect()
    }

    pub(super) fn apply_skin(
        &self,
        prim: &gltf::Primitive,
        name: &str,
        joint_matrices: &[DMat4],
        positions: &mut [Vec3],
        normals: Option<&mut Vec<Vec3>>,
    ) -> Result<()> {
        let (Some(jacc), Some(wacc)) = (prim.get(&gltf::Semantic::Joints(0)), prim.get(&gltf::Semantic::Weights(0)))
        else {
            return Err(self.err(format!("{name}: skinned node but the primitive has no JOINTS_0/WEIGHTS_0")));
        };
        let joints = read_floats::<4>(&jacc, &self.buffers, &format!("accessor {} (JOINTS_0 of {name})", jacc.index()))
            .map_err(|m| self.err(m))?;
        let weights =
            read_floats::<4>(&wacc, &self.buffers, &format!("accessor {} (WEIGHTS_0 of {name})", wacc.index()))
                .map_err(|m| self.err(m))?;
        if joints.len() != positions.len() || weights.len() != positions.len() {
            return Err(self.err(format!("{name}: JOINTS_0/WEIGHTS_0 counts differ from POSITION")));
        }
        let mut normals = normals;
        for i in 0..positions.len() {
            let mut m = DMat4::ZERO;
            let mut total = 0.0f64;
            for k in 0..4 {
                let w = weights[i][k] as f64;
                if w == 0.0 {
                    continue;
                }
                let j = joints[i][k] as usize;
                let jm = joint_matrices.get(j).ok_or_else(|| {
                    self.err(format!("{name}: vertex {i} uses joint {j} of a {}-joint skin", joint_matrices.len()))
                })?;
                m += *jm * w;
                total += w;
            }
            // Weights that do not sum to 1 (seen in CesiumMan) are renormalised.
            let m = if total > 0.0 { m * (1.0 / total) } else { DMat4::IDENTITY };
            positions[i] = m.transform_point3(positions[i].as_dvec3()).as_vec3();
            if let Some(n) = normals.as_deref_mut() {
                let nm = m.inverse().transpose();
                n[i] = nm.transform_vector3(n[i].as_dvec3()).as_vec3();
            }
        }
        Ok(())
    }
}
