//! glTF 2.0 loading: the only module that touches the gltf crate.
//!
//! Everything a file can get wrong becomes an `Error` naming the node, mesh or accessor;
//! valid content we do not render (points, lines) is skipped with a warning,
//! and content we cannot render faithfully (Draco, unknown required extensions) is refused.
//!
//! `Loader` reads a document in order: `validate` (what the file may ask for), `buffers`
//! (binary chunk, files, `data:` URIs; `accessor` reads typed views of them), `nodes` (the
//! scene graph: transforms, cameras, lights, mesh instances), `primitives` (triangles and
//! their attributes), `skins` (joints and weights), `materials` (base colour and textures),
//! `animation` (the scene graph and animations kept for `scene::animation`).

mod accessor;
mod animation;
mod buffers;
mod materials;
mod nodes;
mod primitives;
mod skins;
mod validate;

use std::collections::HashMap;
use std::path::Path;

use glam::DMat4;

use super::{LoadOptions, Scene};
use crate::error::{Error, Result};
use crate::util::files::read_bounded;
use crate::util::limits::MAX_SCENE_FILE;
use validate::{check_indices, check_references, check_required_extensions, describe_gltf_error};

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

/// Most triangles a scene may expand to once instanced: about 100 bytes each in the render
/// space plus the BVH, so ~6 GB at this bound.
pub const MAX_TRIANGLES: usize = 50_000_000;

pub(super) fn load(path: &Path, options: LoadOptions) -> Result<Scene> {
    if path.is_dir() {
        return Err(Error::scene(path, "is a directory, not a .gltf or .glb file"));
    }
    let bytes = read_bounded(path, MAX_SCENE_FILE).map_err(|m| Error::scene(path, m))?;
    let base = path.parent().map(Path::to_path_buf).unwrap_or_default();
    load_bytes(&bytes, path, Some(&base), options)
}

pub(super) fn load_slice(bytes: &[u8], name: &Path) -> Result<Scene> {
    load_bytes(bytes, name, None, LoadOptions::default())
}

fn load_bytes(bytes: &[u8], path: &Path, base: Option<&Path>, options: LoadOptions) -> Result<Scene> {
    // The gltf crate is trusted not to panic on malformed input, but a panic must never
    // reach the user: turn one into an error naming the file.
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let result = std::panic::catch_unwind(|| Loader::parse(bytes, path, base, options));
    std::panic::set_hook(hook);
    match result {
        Ok(r) => r,
        Err(_) => Err(Error::scene(path, "malformed glTF (the parser failed on this file)")),
    }
}

struct Loader<'a> {
    path: &'a Path,
    base: Option<&'a Path>,
    options: LoadOptions,
    /// Bytes of binary buffers read so far (bounded by `MAX_SCENE_BUFFERS`).
    buffer_bytes: u64,
    /// Texels of textures decoded so far (bounded by `MAX_SCENE_TEXELS`).
    texels: u64,
    /// Vertices of meshes read so far (bounded by `MAX_SCENE_VERTICES`).
    vertices: usize,
    /// Morph deltas applied and joints composed so far (bounded by `MAX_LOAD_WORK`).
    work: usize,
    doc: &'a gltf::Document,
    /// extensionsRequired as in the file (the validated copy drops those we vetted).
    required: Vec<String>,
    /// The binary buffers; the GLB's chunk borrowed from the file's bytes (not copied).
    buffers: Vec<std::borrow::Cow<'a, [u8]>>,
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
    /// The scene graph and animations, when the file has animations.
    rig: Option<crate::scene::animation::Rig>,
}

impl<'a> Loader<'a> {
    fn err(&self, message: impl Into<String>) -> Error {
        Error::scene(self.path, message)
    }

    /// Counts `n` more elements of work against `MAX_LOAD_WORK`.
    fn add_work(&mut self, n: usize, what: &str) -> Result<()> {
        self.work = self.work.saturating_add(n);
        if self.work > crate::util::limits::MAX_LOAD_WORK {
            return Err(self.err(format!(
                "{what}: the scene asks for more than {} morph deltas and skin joints in all (instances counted each)",
                crate::util::limits::MAX_LOAD_WORK
            )));
        }
        Ok(())
    }

    fn warn(&mut self, message: String) {
        if self.warned.insert(message.clone()) {
            self.scene.warnings.push(message);
        }
    }

    fn parse(bytes: &[u8], path: &'a Path, base: Option<&'a Path>, options: LoadOptions) -> Result<Scene> {
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
                // Bytes past the declared length would be silently ignored: a file that is not
                // what its header says is refused.
                Some(n) if n as usize != bytes.len() => {
                    return Err(Error::scene(
                        path,
                        format!(
                            "malformed GLB container: its header declares {n} bytes but the file has {}",
                            bytes.len()
                        ),
                    ));
                }
                _ => {}
            }
        }
        if !is_glb && bytes.len() >= 4 && bytes[..4].contains(&0) && !bytes.starts_with(b"{") {
            return Err(Error::scene(path, "not a glTF file: neither a GLB header ('glTF' magic) nor JSON"));
        }
        // The gltf crate wraps indices above u32::MAX (node.mesh 4294967296 became mesh 0).
        check_indices(path, bytes, is_glb)?;
        // A GLB's chunks are split here, so its binary chunk stays a borrow of `bytes` (the
        // gltf crate copies it: tens of MB of fresh pages on one core for a dense scene).
        let (json, blob) = if is_glb {
            let glb = gltf::Glb::from_slice(bytes).map_err(|e| Error::scene(path, describe_gltf_error(e)))?;
            (glb.json, glb.bin)
        } else {
            (std::borrow::Cow::Borrowed(bytes), None)
        };
        let gltf =
            gltf::Gltf::from_slice_without_validation(&json).map_err(|e| Error::scene(path, describe_gltf_error(e)))?;
        let document = gltf.document;
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
            options,
            buffer_bytes: 0,
            texels: 0,
            vertices: 0,
            work: 0,
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
            rig: None,
        };
        loader.check_asset()?;
        loader.load_buffers(blob)?;
        loader.load_scene()?;
        if loader.scene.triangle_count() == 0 {
            return Err(Error::EmptyScene(path.to_path_buf()));
        }
        Ok(loader.scene)
    }
}
