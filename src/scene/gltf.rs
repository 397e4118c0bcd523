//! glTF 2.0 loading: the only module that touches the gltf crate.
//!
//! Everything a file can get wrong becomes an `Error` naming the node, mesh or accessor;
//! valid content we do not render (points, lines, animations) is skipped with a warning,
//! and content we cannot render faithfully (Draco, unknown required extensions) is refused.

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use base64::Engine;
use glam::{DMat4, DVec3, DVec4, Vec2, Vec3, Vec4};
use gltf::mesh::Mode;

use super::accessor::{read_floats, read_indices};
use super::{
    Filter, Light, LightKind, Material, Mesh, Object, Projection, Scene, SceneCamera, Texture, TextureRef, Wrap,
    compute_normals,
};
use crate::error::{Error, Result};

/// Extensions whose data we read. Anything else listed in `extensionsRequired` is refused.
const SUPPORTED_REQUIRED: &[&str] = &[
    "KHR_lights_punctual",
    "KHR_texture_transform",
    "KHR_materials_unlit",
    "KHR_mesh_quantization",
    // Material extensions that only refine shading we approximate anyway.
    "KHR_materials_emissive_strength",
    "KHR_materials_ior",
    "KHR_materials_specular",
    "KHR_materials_sheen",
];

/// Largest file we read into memory, bytes.
const MAX_FILE: u64 = 2 << 30;
/// Most triangles a scene may expand to once instanced: about 100 bytes each in the render
/// space plus the BVH, so ~6 GB at this bound.
pub const MAX_TRIANGLES: usize = 50_000_000;

pub(super) fn load(path: &Path) -> Result<Scene> {
    let meta = std::fs::metadata(path).map_err(|e| Error::scene(path, format!("cannot read: {e}")))?;
    if meta.is_dir() {
        return Err(Error::scene(path, "is a directory, not a .gltf or .glb file"));
    }
    if meta.len() > MAX_FILE {
        return Err(Error::scene(path, format!("{} bytes is larger than the {MAX_FILE}-byte limit", meta.len())));
    }
    let bytes = std::fs::read(path).map_err(|e| Error::scene(path, format!("cannot read: {e}")))?;
    let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
    load_bytes(&bytes, path, Some(&base))
}

pub(super) fn load_slice(bytes: &[u8], name: &Path) -> Result<Scene> {
    load_bytes(bytes, name, None)
}

fn load_bytes(bytes: &[u8], path: &Path, base: Option<&Path>) -> Result<Scene> {
    // The gltf crate is trusted not to panic on malformed input, but a panic must never
    // reach the user: turn one into an error naming the file.
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let result = std::panic::catch_unwind(|| Loader::parse(bytes, path, base));
    std::panic::set_hook(hook);
    match result {
        Ok(r) => r,
        Err(_) => Err(Error::scene(path, "malformed glTF (the parser failed on this file)")),
    }
}

/// Refuses files that require an extension we cannot render faithfully.
fn check_required_extensions(path: &Path, required: &[String]) -> Result<()> {
    let unsupported = |message: String| Error::Unsupported { path: path.to_path_buf(), message };
    for ext in required {
        match ext.as_str() {
            "KHR_draco_mesh_compression" => {
                return Err(unsupported(
                    "Draco-compressed meshes (KHR_draco_mesh_compression); re-export the scene without mesh compression".into(),
                ));
            }
            "EXT_meshopt_compression" => {
                return Err(unsupported(
                    "meshopt-compressed buffers (EXT_meshopt_compression); re-export without compression".into(),
                ));
            }
            e if !SUPPORTED_REQUIRED.contains(&e) => {
                return Err(unsupported(format!("the file requires the extension {e}")));
            }
            _ => {}
        }
    }
    Ok(())
}

/// Index checks the gltf crate's validation would panic on rather than report.
fn check_references(path: &Path, root: &gltf::json::Root) -> Result<()> {
    let n = root.accessors.len();
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            for (semantic, acc) in &prim.attributes {
                if acc.value() >= n {
                    return Err(Error::scene(
                        path,
                        format!(
                            "meshes[{m}].primitives[{p}] attribute {semantic:?} refers to accessor {} of {n}",
                            acc.value()
                        ),
                    ));
                }
            }
        }
    }
    Ok(())
}

fn describe_gltf_error(e: gltf::Error) -> String {
    match e {
        gltf::Error::Validation(list) => {
            let first = list
                .first()
                .map(|(p, err)| format!("{}: {err}", p.as_str()))
                .unwrap_or_else(|| "unknown problem".into());
            if list.len() > 1 {
                format!("invalid glTF: {first} (and {} more)", list.len() - 1)
            } else {
                format!("invalid glTF: {first}")
            }
        }
        gltf::Error::Binary(b) => format!("malformed GLB container: {b:?}"),
        gltf::Error::Deserialize(d) => format!("not valid glTF JSON: {d}"),
        other => format!("{other}"),
    }
}

struct Loader<'a> {
    path: &'a Path,
    base: Option<&'a Path>,
    doc: &'a gltf::Document,
    /// extensionsRequired as in the file (the validated copy drops those we vetted).
    required: Vec<String>,
    buffers: Vec<Vec<u8>>,
    scene: Scene,
    /// (mesh index, primitive index) -> our mesh index, so instancing shares a mesh.
    mesh_cache: HashMap<(usize, usize), Option<usize>>,
    /// glTF material index -> ours (None key for the default material).
    material_cache: HashMap<Option<usize>, usize>,
    texture_cache: HashMap<usize, usize>,
    world: Vec<Option<DMat4>>,
    warned: std::collections::HashSet<String>,
    /// Triangles placed so far (instances counted each time).
    triangles: usize,
}

impl<'a> Loader<'a> {
    fn err(&self, message: impl Into<String>) -> Error {
        Error::scene(self.path, message)
    }

    fn warn(&mut self, message: String) {
        if self.warned.insert(message.clone()) {
            self.scene.warnings.push(message);
        }
    }

    fn parse(bytes: &[u8], path: &'a Path, base: Option<&'a Path>) -> Result<Scene> {
        if bytes.is_empty() {
            return Err(Error::scene(path, "the file is empty"));
        }
        if bytes.starts_with(&[0xEF, 0xBB, 0xBF]) {
            return Err(Error::scene(path, "the JSON starts with a UTF-8 byte-order mark, which glTF forbids"));
        }
        let is_glb = bytes.starts_with(b"glTF");
        if is_glb {
            // The gltf crate computes `declared length - 12` unchecked: a shorter declared
            // length overflowed (a panic with overflow checks; found by fuzzing).
            let declared = bytes.get(8..12).map(|l| u32::from_le_bytes([l[0], l[1], l[2], l[3]]));
            match declared {
                None => {
                    return Err(Error::scene(
                        path,
                        format!("truncated GLB: {} bytes, no complete header", bytes.len()),
                    ));
                }
                Some(n) if n < 20 => {
                    return Err(Error::scene(
                        path,
                        format!(
                            "malformed GLB container: its header declares {n} bytes, less than the headers themselves"
                        ),
                    ));
                }
                _ => {}
            }
        }
        if !is_glb && bytes.len() >= 4 && bytes[..4].contains(&0) && !bytes.starts_with(b"{") {
            return Err(Error::scene(path, "not a glTF file: neither a GLB header ('glTF' magic) nor JSON"));
        }
        let gltf =
            gltf::Gltf::from_slice_without_validation(bytes).map_err(|e| Error::scene(path, describe_gltf_error(e)))?;
        let gltf::Gltf { document, blob } = gltf;
        let mut root = document.into_json();
        let required = root.extensions_required.clone();
        check_required_extensions(path, &required)?;
        check_references(path, &root)?;
        // The gltf crate's validation refuses required extensions it does not parse itself;
        // we have vetted them above (KHR_mesh_quantization is read by our accessor code).
        root.extensions_required.retain(|e| gltf::json::extensions::ENABLED_EXTENSIONS.contains(&e.as_str()));
        let document = gltf::Document::from_json(root).map_err(|e| Error::scene(path, describe_gltf_error(e)))?;
        let mut loader = Loader {
            path,
            base,
            doc: &document,
            required,
            buffers: Vec::new(),
            scene: Scene { source: path.to_path_buf(), ..Scene::default() },
            mesh_cache: HashMap::new(),
            material_cache: HashMap::new(),
            texture_cache: HashMap::new(),
            world: Vec::new(),
            warned: Default::default(),
            triangles: 0,
        };
        loader.check_asset()?;
        loader.load_buffers(blob)?;
        loader.load_scene()?;
        if loader.scene.triangle_count() == 0 {
            return Err(Error::EmptyScene(path.to_path_buf()));
        }
        Ok(loader.scene)
    }

    fn check_asset(&mut self) -> Result<()> {
        let version = self.doc.as_json().asset.version.clone();
        let major = version.split('.').next().unwrap_or("");
        if major != "2" {
            return Err(self.err(format!("asset.version is \"{version}\": only glTF 2.x is supported")));
        }
        if self.doc.animations().len() > 0 {
            self.warn(format!(
                "{} animation(s) ignored: the scene renders in its rest pose (animate in Blender and render frames instead)",
                self.doc.animations().len()
            ));
        }
        Ok(())
    }

    fn load_buffers(&mut self, mut blob: Option<Vec<u8>>) -> Result<()> {
        let buffers: Vec<_> = self.doc.buffers().collect();
        for buffer in buffers {
            let i = buffer.index();
            let data = match buffer.source() {
                gltf::buffer::Source::Bin => blob.take().ok_or_else(|| {
                    self.err(format!("buffer {i} refers to the GLB's binary chunk, but the file has none"))
                })?,
                gltf::buffer::Source::Uri(uri) => self.read_uri(uri, &format!("buffer {i}"))?,
            };
            if data.len() < buffer.length() {
                return Err(self.err(format!(
                    "buffer {i} holds {} bytes but declares byteLength {}",
                    data.len(),
                    buffer.length()
                )));
            }
            self.buffers.push(data);
        }
        Ok(())
    }

    /// Reads a `data:` URI or a file relative to the glTF file.
    fn read_uri(&self, uri: &str, what: &str) -> Result<Vec<u8>> {
        if let Some(rest) = uri.strip_prefix("data:") {
            let (header, payload) =
                rest.split_once(',').ok_or_else(|| self.err(format!("{what}: malformed data: URI (no comma)")))?;
            if !header.ends_with(";base64") || header.contains(";;") {
                return Err(self.err(format!("{what}: data: URI is not base64 (\"data:{header},...\")")));
            }
            return base64::engine::general_purpose::STANDARD
                .decode(payload.trim())
                .map_err(|e| self.err(format!("{what}: data: URI holds invalid base64 ({e})")));
        }
        if uri.is_empty() || uri.contains("://") || uri.starts_with(':') {
            return Err(
                self.err(format!("{what}: unsupported URI \"{uri}\" (only relative file paths and data: URIs)"))
            );
        }
        let Some(base) = self.base else {
            return Err(self.err(format!("{what}: external file \"{uri}\" cannot be read from an in-memory document")));
        };
        let rel = percent_decode(uri);
        let file: PathBuf = base.join(&rel);
        std::fs::read(&file).map_err(|e| self.err(format!("{what}: cannot read \"{}\": {e}", file.display())))
    }

    fn load_scene(&mut self) -> Result<()> {
        let scene = match self.doc.default_scene() {
            Some(s) => s,
            None => match self.doc.scenes().next() {
                Some(s) => s,
                None => return Err(Error::EmptyScene(self.path.to_path_buf())),
            },
        };
        // World transforms of the whole scene first: skins need joints' matrices.
        self.world = vec![None; self.doc.nodes().len()];
        let roots: Vec<_> = scene.nodes().collect();
        for node in &roots {
            self.compute_world(node.clone(), DMat4::IDENTITY)?;
        }
        let mut stack: Vec<gltf::Node> = roots.into_iter().rev().collect();
        let mut first_camera = true;
        while let Some(node) = stack.pop() {
            let world = self.world[node.index()].expect("computed above");
            if let Some(camera) = node.camera() {
                let cam = self.camera(&node, camera, world)?;
                if first_camera {
                    self.scene.camera = Some(cam);
                    first_camera = false;
                }
            }
            if let Some(light) = node.light() {
                let l = self.light(&node, light, world)?;
                self.scene.lights.push(l);
            }
            if let Some(mesh) = node.mesh() {
                self.instance(&node, mesh, world)?;
            }
            let children: Vec<_> = node.children().collect();
            stack.extend(children.into_iter().rev());
        }
        Ok(())
    }

    /// World transforms of `node` and its descendants. Iterative: a chain of 20,000 nested
    /// nodes (a 1 MB file) overflowed the stack when this recursed (tests/fuzz_regressions).
    fn compute_world(&mut self, node: gltf::Node<'a>, parent: DMat4) -> Result<()> {
        let mut stack = vec![(node, parent)];
        while let Some((node, parent)) = stack.pop() {
            let i = node.index();
            if self.world[i].is_some() {
                return Err(self
                    .err(format!("node {i} appears twice in the hierarchy (a node loop or a node with two parents)")));
            }
            let world = parent * self.local_transform(&node)?;
            self.world[i] = Some(world);
            stack.extend(node.children().map(|child| (child, world)));
        }
        Ok(())
    }

    fn local_transform(&self, node: &gltf::Node) -> Result<DMat4> {
        let i = node.index();
        let m = match node.transform() {
            gltf::scene::Transform::Matrix { matrix } => {
                let m = DMat4::from_cols_array_2d(&matrix.map(|c| c.map(|x| x as f64)));
                let last_row = m.row(3);
                if (last_row - DVec4::new(0.0, 0.0, 0.0, 1.0)).abs().max_element() > 1e-6 {
                    return Err(self.err(format!(
                        "node {i}: its matrix is not an affine transform (last row {last_row:?}); glTF needs a TRS matrix"
                    )));
                }
                m
            }
            gltf::scene::Transform::Decomposed { translation, rotation, scale } => {
                let t = DVec3::from(translation.map(|x| x as f64));
                let q = glam::DQuat::from_array(rotation.map(|x| x as f64));
                let s = DVec3::from(scale.map(|x| x as f64));
                if !(t.is_finite() && q.is_finite() && s.is_finite()) {
                    return Err(self.err(format!("node {i}: translation, rotation or scale is not finite")));
                }
                let q = if q.length_squared() > 0.0 { q.normalize() } else { glam::DQuat::IDENTITY };
                DMat4::from_scale_rotation_translation(s, q, t)
            }
        };
        if !m.is_finite() {
            return Err(self.err(format!("node {i}: its transform is not finite")));
        }
        Ok(m)
    }

    fn camera(&self, node: &gltf::Node, camera: gltf::Camera, world: DMat4) -> Result<SceneCamera> {
        let position = world.transform_point3(DVec3::ZERO);
        let forward = world.transform_vector3(DVec3::NEG_Z);
        let up = world.transform_vector3(DVec3::Y);
        let projection = match camera.projection() {
            gltf::camera::Projection::Perspective(p) => {
                let yfov = p.yfov() as f64;
                if !(yfov > 0.0 && yfov < std::f64::consts::PI) {
                    return Err(self.err(format!("camera {}: yfov {yfov} rad is not in (0, pi)", camera.index())));
                }
                if let Some(zfar) = p.zfar()
                    && zfar <= p.znear()
                {
                    return Err(self.err(format!(
                        "camera {}: zfar {zfar} is not greater than znear {}",
                        camera.index(),
                        p.znear()
                    )));
                }
                Projection::Perspective { yfov }
            }
            gltf::camera::Projection::Orthographic(o) => {
                if o.zfar() <= o.znear() {
                    return Err(self.err(format!("camera {}: zfar is not greater than znear", camera.index())));
                }
                Projection::Orthographic { ymag: (o.ymag() as f64).abs() }
            }
        };
        let f = forward.try_normalize();
        let u = f.and_then(|f| (up - f * up.dot(f)).try_normalize());
        match (f, u) {
            (Some(forward), Some(up)) => Ok(SceneCamera { position, forward, up, projection, focus_distance: None }),
            _ => Err(self.err(format!("node {}: camera transform is degenerate (zero scale)", node.index()))),
        }
    }

    fn light(&self, node: &gltf::Node, light: gltf::khr_lights_punctual::Light, world: DMat4) -> Result<Light> {
        use gltf::khr_lights_punctual::Kind;
        let kind = match light.kind() {
            Kind::Directional => LightKind::Directional,
            Kind::Point => LightKind::Point,
            Kind::Spot { inner_cone_angle, outer_cone_angle } => {
                if !(inner_cone_angle >= 0.0
                    && inner_cone_angle < outer_cone_angle
                    && outer_cone_angle <= std::f32::consts::FRAC_PI_2)
                {
                    return Err(self.err(format!(
                        "light {}: spot cone angles inner {inner_cone_angle} / outer {outer_cone_angle} need 0 <= inner < outer <= pi/2",
                        light.index()
                    )));
                }
                LightKind::Spot { inner: inner_cone_angle, outer: outer_cone_angle }
            }
        };
        let color = Vec3::from(light.color());
        let intensity = light.intensity();
        if !(color.is_finite() && intensity.is_finite() && intensity >= 0.0 && color.min_element() >= 0.0) {
            return Err(self.err(format!("light {}: colour or intensity is negative or not finite", light.index())));
        }
        let direction = world
            .transform_vector3(DVec3::NEG_Z)
            .try_normalize()
            .ok_or_else(|| self.err(format!("node {}: light transform is degenerate", node.index())))?;
        Ok(Light { kind, color, intensity, position: world.transform_point3(DVec3::ZERO), direction })
    }

    fn instance(&mut self, node: &gltf::Node<'a>, mesh: gltf::Mesh<'a>, world: DMat4) -> Result<()> {
        let skin_matrices = match node.skin() {
            Some(skin) => Some(self.skin_matrices(&skin)?),
            None => None,
        };
        // Morph weights: the node's, else the mesh's defaults.
        let weights: Vec<f32> = node.weights().or(mesh.weights()).map(<[f32]>::to_vec).unwrap_or_default();
        for prim in mesh.primitives() {
            let key = (mesh.index(), prim.index());
            let deformed = skin_matrices.is_some() || weights.iter().any(|w| *w != 0.0);
            let mesh_index = if deformed {
                self.primitive(&mesh, &prim, skin_matrices.as_deref(), &weights)?
            } else if let Some(cached) = self.mesh_cache.get(&key) {
                *cached
            } else {
                let m = self.primitive(&mesh, &prim, None, &[])?;
                self.mesh_cache.insert(key, m);
                m
            };
            let Some(mesh_index) = mesh_index else {
                continue;
            };
            // Instancing multiplies triangles: a small file must not expand without bound.
            self.triangles += self.scene.meshes[mesh_index].triangles.len();
            if self.triangles > MAX_TRIANGLES {
                return Err(self.err(format!(
                    "the scene expands to more than {MAX_TRIANGLES} triangles (meshes instanced by many nodes)"
                )));
            }
            let name = node.name().map(str::to_string).unwrap_or_else(|| format!("node {}", node.index()));
            // Skinned vertices are already in scene space (glTF ignores the node's transform).
            let transform = if skin_matrices.is_some() { DMat4::IDENTITY } else { world };
            self.scene.objects.push(Object { name, mesh: mesh_index, transform });
        }
        Ok(())
    }

    /// Joint matrices (scene space) for linear blend skinning in the rest pose.
    fn skin_matrices(&self, skin: &gltf::Skin) -> Result<Vec<DMat4>> {
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

    /// Reads one primitive into a `Mesh`; `None` for primitives without triangles.
    fn primitive(
        &mut self,
        mesh: &gltf::Mesh,
        prim: &gltf::Primitive,
        skin: Option<&[DMat4]>,
        weights: &[f32],
    ) -> Result<Option<usize>> {
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
        let raw = read_floats::<3>(&pos_acc, &self.buffers, &what).map_err(|m| self.err(m))?;
        let mut positions: Vec<Vec3> = raw.iter().map(|p| Vec3::from(*p)).collect();
        if let Some(i) = positions.iter().position(|p| !p.is_finite()) {
            return Err(self.err(format!("{what}: vertex {i} is {:?}: NaN or infinite coordinates", positions[i])));
        }
        self.check_bounds(&pos_acc, &positions, &what)?;

        let mut normals: Option<Vec<Vec3>> = match prim.get(&gltf::Semantic::Normals) {
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

        // Morph targets at the given weights (rest pose).
        for (t, target) in prim.morph_targets().enumerate() {
            let w = weights.get(t).copied().unwrap_or(0.0);
            if w == 0.0 {
                continue;
            }
            if let Some(acc) = target.positions() {
                let what = format!("accessor {} (morph target {t} POSITION of {name})", acc.index());
                let d = read_floats::<3>(&acc, &self.buffers, &what).map_err(|m| self.err(m))?;
                if d.len() != positions.len() {
                    return Err(self.err(format!("{what}: {} deltas for {} positions", d.len(), positions.len())));
                }
                for (p, d) in positions.iter_mut().zip(d) {
                    *p += w * Vec3::from(d);
                }
            }
            if let (Some(acc), Some(n)) = (target.normals(), normals.as_mut()) {
                let what = format!("accessor {} (morph target {t} NORMAL of {name})", acc.index());
                let d = read_floats::<3>(&acc, &self.buffers, &what).map_err(|m| self.err(m))?;
                for (n, d) in n.iter_mut().zip(d) {
                    *n += w * Vec3::from(d);
                }
            }
        }
        if !weights.is_empty()
            && prim.morph_targets().len() > 0
            && let Some(i) = positions.iter().position(|p| !p.is_finite())
        {
            return Err(self.err(format!("{name}: morphed vertex {i} is not finite")));
        }

        if let Some(joint_matrices) = skin {
            self.apply_skin(prim, &name, joint_matrices, &mut positions, normals.as_mut())?;
        }

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
        let normals = match normals {
            Some(n) => {
                let fallback = compute_normals(&positions, &triangles);
                n.into_iter()
                    .zip(fallback)
                    .map(|(n, f)| if n.is_finite() { n.try_normalize().unwrap_or(f) } else { f })
                    .collect()
            }
            None => compute_normals(&positions, &triangles),
        };

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
        Ok(Some(self.scene.meshes.len() - 1))
    }

    /// Declared POSITION bounds must hold the data (the validator's ACCESSOR_MIN/MAX checks).
    fn check_bounds(&self, acc: &gltf::Accessor, positions: &[Vec3], what: &str) -> Result<()> {
        let as_vec = |v: Option<gltf::json::Value>| -> Option<Vec3> {
            let arr = v?.as_array()?.iter().map(|x| x.as_f64()).collect::<Option<Vec<f64>>>()?;
            (arr.len() == 3).then(|| Vec3::new(arr[0] as f32, arr[1] as f32, arr[2] as f32))
        };
        let (min, max) = (as_vec(acc.min()), as_vec(acc.max()));
        let Some((lo, hi)) = positions
            .iter()
            .fold(None, |acc: Option<(Vec3, Vec3)>, p| Some(acc.map_or((*p, *p), |(lo, hi)| (lo.min(*p), hi.max(*p)))))
        else {
            return Ok(());
        };
        let tol = |v: Vec3| v.abs() * 1e-5 + Vec3::splat(1e-6);
        if let Some(min) = min
            && (lo + tol(lo)).cmplt(min).any()
        {
            return Err(self.err(format!("{what}: data reach {lo:?}, below the declared min {min:?}")));
        }
        if let Some(max) = max
            && (hi - tol(hi)).cmpgt(max).any()
        {
            return Err(self.err(format!("{what}: data reach {hi:?}, above the declared max {max:?}")));
        }
        Ok(())
    }

    fn apply_skin(
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

    fn material(&mut self, m: gltf::Material) -> Result<usize> {
        if let Some(&i) = self.material_cache.get(&m.index()) {
            return Ok(i);
        }
        let mut mat = Material::default();
        if let Some(i) = m.index() {
            let pbr = m.pbr_metallic_roughness();
            mat.name = m.name().map(str::to_string).unwrap_or_else(|| format!("material {i}"));
            mat.base_color = Vec4::from(pbr.base_color_factor());
            if !mat.base_color.is_finite() {
                return Err(self.err(format!("material {i}: baseColorFactor is not finite")));
            }
            mat.metallic = pbr.metallic_factor().clamp(0.0, 1.0);
            mat.roughness = pbr.roughness_factor().clamp(0.0, 1.0);
            mat.unlit = m.unlit();
            if let Some(info) = pbr.base_color_texture() {
                let texture = self.texture(info.texture())?;
                let mut uv_set = info.tex_coord();
                let mut uv_transform = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0];
                if let Some(t) = info.texture_transform() {
                    let [ox, oy] = t.offset();
                    let r = t.rotation();
                    let [sx, sy] = t.scale();
                    let (s, c) = r.sin_cos();
                    // KHR_texture_transform: T * R * S, with R rotating UVs counter-clockwise.
                    uv_transform = [c * sx, s * sy, ox, -s * sx, c * sy, oy];
                    if let Some(set) = t.tex_coord() {
                        uv_set = set;
                    }
                }
                mat.base_color_texture = texture.map(|texture| TextureRef { texture, uv_set, uv_transform });
            }
        }
        self.scene.materials.push(mat);
        let i = self.scene.materials.len() - 1;
        self.material_cache.insert(m.index(), i);
        Ok(i)
    }

    /// Decodes a texture's image (only textures a material uses are decoded).
    fn texture(&mut self, t: gltf::Texture) -> Result<Option<usize>> {
        if let Some(&i) = self.texture_cache.get(&t.index()) {
            return Ok(Some(i));
        }
        let image = t.source();
        let what = format!("image {} (texture {})", image.index(), t.index());
        // `Image::source` unwraps what the spec requires (a mimeType beside a bufferView, a uri
        // otherwise): a file without them panicked inside the gltf crate (found by fuzzing).
        if let Some(json) = self.doc.as_json().images.get(image.index()) {
            match (&json.buffer_view, &json.uri) {
                (Some(v), _) if v.value() >= self.doc.views().len() => {
                    return Err(self.err(format!("{what}: bufferView {} does not exist", v.value())));
                }
                (Some(_), _) if json.mime_type.is_none() => {
                    return Err(self.err(format!("{what}: an image in a bufferView needs a mimeType")));
                }
                (None, None) => return Err(self.err(format!("{what}: has neither a uri nor a bufferView"))),
                _ => {}
            }
        }
        let bytes: Vec<u8> = match image.source() {
            gltf::image::Source::View { view, .. } => {
                let b = view.buffer().index();
                let data = self.buffers.get(b).ok_or_else(|| self.err(format!("{what}: missing buffer {b}")))?;
                let end = view.offset().checked_add(view.length()).filter(|e| *e <= data.len()).ok_or_else(|| {
                    self.err(format!("{what}: bufferView {} runs past the end of buffer {b}", view.index()))
                })?;
                data[view.offset()..end].to_vec()
            }
            gltf::image::Source::Uri { uri, .. } => self.read_uri(uri, &what)?,
        };
        let decoded = image::load_from_memory(&bytes).map_err(|e| self.err(format!("{what}: cannot decode: {e}")))?;
        let rgba = decoded.to_rgba8();
        let sampler = t.sampler();
        let wrap = |w: gltf::texture::WrappingMode| match w {
            gltf::texture::WrappingMode::ClampToEdge => Wrap::Clamp,
            gltf::texture::WrappingMode::MirroredRepeat => Wrap::Mirror,
            gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
        };
        let filter = match sampler.mag_filter() {
            Some(gltf::texture::MagFilter::Nearest) => Filter::Nearest,
            _ => Filter::Linear,
        };
        let tex = Texture::from_srgba8(
            rgba.width(),
            rgba.height(),
            rgba.as_raw(),
            wrap(sampler.wrap_s()),
            wrap(sampler.wrap_t()),
            filter,
        );
        if tex.width == 0 || tex.height == 0 {
            return Err(self.err(format!("{what}: image is empty")));
        }
        self.scene.textures.push(tex);
        let i = self.scene.textures.len() - 1;
        self.texture_cache.insert(t.index(), i);
        Ok(Some(i))
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

fn percent_decode(s: &str) -> String {
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' && i + 2 < bytes.len() {
            let hex = |b: u8| (b as char).to_digit(16);
            if let (Some(h), Some(l)) = (hex(bytes[i + 1]), hex(bytes[i + 2])) {
                out.push((h * 16 + l) as u8);
                i += 3;
                continue;
            }
        }
        out.push(bytes[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
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

    #[test]
    fn percent_decoding() {
        assert_eq!(percent_decode("my%20file.bin"), "my file.bin");
        assert_eq!(percent_decode("100%"), "100%");
        assert_eq!(percent_decode("a%2"), "a%2");
    }
}
