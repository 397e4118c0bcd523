//! One primitive's triangles and attributes (positions, normals, UVs, colours, morph targets)
//! as a `Mesh`.

use std::sync::Arc;

use glam::{DMat4, Vec2, Vec3, Vec4};
use gltf::mesh::Mode;

use super::accessor::{read_floats, read_indices};
use super::{Loader, MAX_TRIANGLES};
use crate::error::{Error, Result};
use crate::scene::Mesh;
use crate::scene::animation::{Deformable, MorphTarget, deform, deform_owned};
use crate::util::limits::MAX_SCENE_VERTICES;

impl<'a> Loader<'a> {
    /// Reads one primitive into a `Mesh` at morph `weights` and, when skinned, the skin's
    /// `joints` matrices (the rest pose); `None` for primitives without triangles. With `keep`
    /// (the file has animations) a skinned or morphed primitive also returns its undeformed
    /// data, which every frame deforms anew.
    pub(super) fn primitive(
        &mut self,
        mesh: &gltf::Mesh,
        prim: &gltf::Primitive,
        skin: Option<&[DMat4]>,
        weights: &[f32],
        keep: bool,
    ) -> Result<Option<(usize, Option<Arc<Deformable>>)>> {
        let mesh_name = mesh.name().map(str::to_string).unwrap_or_else(|| format!("mesh {}", mesh.index()));
        let name = if mesh.primitives().len() > 1 {
            format!("{mesh_name}/primitive {}", prim.index())
        } else {
            mesh_name.clone()
        };
        let mode = prim.mode();
        if matches!(mode, Mode::Points | Mode::Lines | Mode::LineLoop | Mode::LineStrip) {
            self.warn(format!("{name}: {mode:?} primitives are not rendered (only triangles)"));
            return Ok(None);
        }
        let draco_used = self.doc.extensions_used().any(|e| e == "KHR_draco_mesh_compression");
        let pos_view = prim.get(&gltf::Semantic::Positions).map(|a| a.view().is_some() || a.sparse().is_some());
        if draco_used && pos_view == Some(false) {
            return Err(Error::Unsupported {
                path: self.path.to_path_buf(),
                message: format!(
                    "{name}: Draco-compressed geometry (KHR_draco_mesh_compression) with no uncompressed fallback"
                ),
            });
        }
        let pos_acc = prim
            .get(&gltf::Semantic::Positions)
            .ok_or_else(|| self.err(format!("{name}: primitive {} has no POSITION attribute", prim.index())))?;
        let what = format!("accessor {} (POSITION of {name})", pos_acc.index());
        if pos_acc.data_type() != gltf::accessor::DataType::F32
            && !self.required.iter().any(|e| e == "KHR_mesh_quantization")
        {
            return Err(self.err(format!(
                "{what}: {:?} components need KHR_mesh_quantization in extensionsRequired",
                pos_acc.data_type()
            )));
        }
        // Counts first, then the vectors: a count is checked against the limits before
        // anything is allocated for it.
        let count = pos_acc.count();
        self.vertices = self.vertices.saturating_add(count);
        if self.vertices > MAX_SCENE_VERTICES {
            return Err(self.err(format!(
                "{what}: {count} vertices bring the scene past the limit of {MAX_SCENE_VERTICES} vertices"
            )));
        }
        let index_count = prim.indices().map_or(count, |a| a.count());
        let triangles = match mode {
            Mode::Triangles => index_count / 3,
            _ => index_count.saturating_sub(2),
        };
        if self.triangles.saturating_add(triangles) > MAX_TRIANGLES {
            return Err(self.err(format!(
                "{name}: {triangles} triangles bring the scene past the limit of {MAX_TRIANGLES} triangles"
            )));
        }
        let raw = read_floats::<3>(&pos_acc, &self.buffers, &what).map_err(|m| self.err(m))?;
        let positions: Vec<Vec3> = raw.iter().map(|p| Vec3::from(*p)).collect();
        if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
            return Err(self.err(format!("{what}: vertex {i} is {:?}: NaN or infinite coordinates", positions[i])));
        }
        self.check_bounds(&pos_acc, &positions, &what)?;

        let normals: Option<Vec<Vec3>> = match prim.get(&gltf::Semantic::Normals) {
            Some(acc) => {
                let what = format!("accessor {} (NORMAL of {name})", acc.index());
                let n = read_floats::<3>(&acc, &self.buffers, &what).map_err(|m| self.err(m))?;
                if n.len() != positions.len() {
                    return Err(self.err(format!("{what}: {} normals for {} positions", n.len(), positions.len())));
                }
                Some(n.into_iter().map(Vec3::from).collect())
            }
            None => None,
        };

        // Morph targets: those the rest pose weighs, or all of them for animation.
        let mut targets = Vec::new();
        for (t, target) in prim.morph_targets().enumerate() {
            let w = weights.get(t).copied().unwrap_or(0.0);
            if w == 0.0 && !keep {
                targets.push(MorphTarget { positions: None, normals: None });
                continue;
            }
            self.add_work(positions.len(), &name)?;
            let deltas = match target.positions() {
                Some(acc) => {
                    let what = format!("accessor {} (morph target {t} POSITION of {name})", acc.index());
                    let d = read_floats::<3>(&acc, &self.buffers, &what).map_err(|m| self.err(m))?;
                    if d.len() != positions.len() {
                        return Err(self.err(format!("{what}: {} deltas for {} positions", d.len(), positions.len())));
                    }
                    Some(d.into_iter().map(Vec3::from).collect())
                }
                None => None,
            };
            let normal_deltas = match (target.normals(), normals.as_ref()) {
                (Some(acc), Some(_)) => {
                    let what = format!("accessor {} (morph target {t} NORMAL of {name})", acc.index());
                    let d = read_floats::<3>(&acc, &self.buffers, &what).map_err(|m| self.err(m))?;
                    Some(d.into_iter().map(Vec3::from).collect())
                }
                _ => None,
            };
            targets.push(MorphTarget { positions: deltas, normals: normal_deltas });
        }
        let skinning = match skin {
            Some(joints) => Some(self.read_skinning(prim, &name, joints.len(), positions.len())?),
            None => None,
        };

        let count = positions.len();
        let indices: Vec<u32> = match prim.indices() {
            Some(acc) => {
                let what = format!("accessor {} (indices of {name})", acc.index());
                let idx = read_indices(&acc, &self.buffers, count, &what).map_err(|m| self.err(m))?;
                let restart = match acc.data_type() {
                    gltf::accessor::DataType::U8 => 0xFF,
                    gltf::accessor::DataType::U16 => 0xFFFF,
                    _ => u32::MAX,
                };
                if let Some(i) = idx.iter().position(|&v| v == restart) {
                    return Err(self.err(format!(
                        "{what}: index {i} is the primitive-restart value {restart}, which glTF forbids"
                    )));
                }
                idx
            }
            None => (0..count as u32).collect(),
        };
        let triangles = triangulate(mode, &indices);
        if triangles.is_empty() {
            self.warn(format!("{name}: primitive has no complete triangle"));
            return Ok(None);
        }
        let morphed = !weights.is_empty() && !targets.is_empty();
        let deformable = Deformable { positions, normals, targets, skinning };
        let (positions, normals, kept) = if keep && (deformable.skinning.is_some() || !deformable.targets.is_empty()) {
            let (p, n) = deform(&deformable, weights, skin, &triangles);
            (p, n, Some(Arc::new(deformable)))
        } else {
            let (p, n) = deform_owned(deformable, weights, skin, &triangles);
            (p, n, None)
        };
        if morphed && let Some(i) = positions.iter().position(|p| !p.is_finite()) {
            return Err(self.err(format!("{name}: morphed vertex {i} is not finite")));
        }

        let material = self.material(prim.material())?;
        let uv_set = self.scene.materials[material].base_color_texture.map(|t| t.uv_set);
        let uvs = match uv_set.and_then(|set| prim.get(&gltf::Semantic::TexCoords(set))) {
            Some(acc) => {
                let what = format!("accessor {} (TEXCOORD of {name})", acc.index());
                let uv = read_floats::<2>(&acc, &self.buffers, &what).map_err(|m| self.err(m))?;
                if uv.len() != count {
                    return Err(self.err(format!("{what}: {} UVs for {count} positions", uv.len())));
                }
                Some(uv.into_iter().map(Vec2::from).collect())
            }
            None => None,
        };
        let colors = match prim.get(&gltf::Semantic::Colors(0)) {
            Some(acc) => {
                let what = format!("accessor {} (COLOR_0 of {name})", acc.index());
                let c: Vec<Vec4> = match acc.dimensions() {
                    gltf::accessor::Dimensions::Vec3 => read_floats::<3>(&acc, &self.buffers, &what)
                        .map_err(|m| self.err(m))?
                        .into_iter()
                        .map(|c| Vec3::from(c).extend(1.0))
                        .collect(),
                    _ => read_floats::<4>(&acc, &self.buffers, &what)
                        .map_err(|m| self.err(m))?
                        .into_iter()
                        .map(Vec4::from)
                        .collect(),
                };
                if c.len() != count {
                    return Err(self.err(format!("{what}: {} colours for {count} positions", c.len())));
                }
                Some(
                    c.into_iter()
                        .map(|c| if c.is_finite() { c.clamp(Vec4::ZERO, Vec4::ONE) } else { Vec4::ONE })
                        .collect(),
                )
            }
            None => None,
        };
        self.scene.meshes.push(Mesh { name, positions, normals, uvs, colors, triangles, material: Some(material) });
        Ok(Some((self.scene.meshes.len() - 1, kept)))
    }
}

/// Triangle lists from TRIANGLES, TRIANGLE_STRIP and TRIANGLE_FAN index sequences,
/// keeping each triangle's winding as the glTF spec defines it.
pub(crate) fn triangulate(mode: Mode, idx: &[u32]) -> Vec<[u32; 3]> {
    match mode {
        Mode::Triangles => idx.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect(),
        Mode::TriangleStrip => (0..idx.len().saturating_sub(2))
            .map(|i| if i % 2 == 0 { [idx[i], idx[i + 1], idx[i + 2]] } else { [idx[i + 1], idx[i], idx[i + 2]] })
            .collect(),
        Mode::TriangleFan => (1..idx.len().saturating_sub(1)).map(|i| [idx[0], idx[i], idx[i + 1]]).collect(),
        _ => Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strips_and_fans() {
        assert_eq!(triangulate(Mode::TriangleStrip, &[0, 1, 2, 3]), vec![[0, 1, 2], [2, 1, 3]]);
        assert_eq!(triangulate(Mode::TriangleFan, &[0, 1, 2, 3]), vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(triangulate(Mode::Triangles, &[0, 1, 2, 3]), vec![[0, 1, 2]]);
        assert!(triangulate(Mode::TriangleStrip, &[0, 1]).is_empty());
    }
}
