//! The scene as loaded: meshes in their own coordinates, objects placing them, materials,
//! textures, lights and the scene's camera, all in the file's units (f64 transforms).
//!
//! `gltf/` is the only user of the gltf crate; `default.rs` builds the built-in still life;
//! `world.rs` flattens a scene into render space for tracing; `animation/` poses a scene at a
//! time of its glTF animations.

pub mod animation;
pub mod backdrop;
pub mod default;
pub mod enclosure;
mod gltf;
pub mod room;
pub mod srgb;
mod sweep;
pub mod texture;
pub mod world;

use std::path::{Path, PathBuf};

use glam::{DMat4, DVec3, Vec2, Vec3, Vec4};

pub use texture::{Filter, Texture, Wrap};
pub use world::World;

use crate::error::Result;

/// One glTF primitive's triangles in the mesh's own coordinates, vertices in file order.
/// Saliency is computed per `Mesh`, so a mesh instanced twice is analysed once.
#[derive(Clone, Debug)]
pub struct Mesh {
    /// `mesh name` or `mesh name/primitive i` when a mesh has several primitives.
    pub name: String,
    pub positions: Vec<Vec3>,
    /// Unit normals; computed (area-weighted) when the file has none.
    pub normals: Vec<Vec3>,
    pub uvs: Option<Vec<Vec2>>,
    /// COLOR_0 as linear RGBA.
    pub colors: Option<Vec<Vec4>>,
    pub triangles: Vec<[u32; 3]>,
    pub material: Option<usize>,
}

/// A mesh placed in the scene (a glTF node x primitive): the paper's "object".
#[derive(Clone, Debug)]
pub struct Object {
    pub name: String,
    pub mesh: usize,
    /// Local to scene units, in f64 so far-from-origin scenes keep their precision.
    pub transform: DMat4,
}

/// A UV transform (KHR_texture_transform) and the UV set a texture reads.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TextureRef {
    pub texture: usize,
    pub uv_set: u32,
    /// Row-major 2x3 affine map applied to UVs: [a, b, c, d, e, f] -> (a u + b v + c, d u + e v + f).
    pub uv_transform: [f32; 6],
}

#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    pub name: String,
    /// Linear RGBA.
    pub base_color: Vec4,
    pub base_color_texture: Option<TextureRef>,
    pub metallic: f32,
    pub roughness: f32,
    /// KHR_materials_unlit: the base colour is the final colour.
    pub unlit: bool,
}

impl Default for Material {
    fn default() -> Self {
        Material {
            name: "default".into(),
            base_color: Vec4::new(0.8, 0.8, 0.8, 1.0),
            base_color_texture: None,
            metallic: 0.0,
            roughness: 0.6,
            unlit: false,
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LightKind {
    /// Parallel light along `direction`; intensity in lux.
    Directional,
    /// Intensity in candela.
    Point,
    /// Cone angles in radians; intensity in candela.
    Spot { inner: f32, outer: f32 },
}

#[derive(Clone, Debug, PartialEq)]
pub struct Light {
    pub kind: LightKind,
    /// Linear RGB.
    pub color: Vec3,
    pub intensity: f32,
    /// Scene units (ignored for directional lights).
    pub position: DVec3,
    /// Unit direction the light travels (ignored for point lights).
    pub direction: DVec3,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Projection {
    /// Vertical field of view, radians.
    Perspective { yfov: f64 },
    /// Half the view's height, scene units.
    Orthographic { ymag: f64 },
}

/// The scene's own camera (the first camera node of the default scene).
#[derive(Clone, Debug, PartialEq)]
pub struct SceneCamera {
    pub position: DVec3,
    /// Unit view direction.
    pub forward: DVec3,
    /// Unit up, orthogonal to `forward`.
    pub up: DVec3,
    pub projection: Projection,
    /// Distance to the cubist focal centre along `forward`, scene units, when the scene
    /// chooses one (the built-in still life does; glTF has no such field).
    pub focus_distance: Option<f64>,
}

#[derive(Clone, Debug, Default)]
pub struct Scene {
    /// The file it came from, or `<default scene>`.
    pub source: PathBuf,
    pub meshes: Vec<Mesh>,
    pub objects: Vec<Object>,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    pub lights: Vec<Light>,
    pub camera: Option<SceneCamera>,
    /// Content we skipped (points, lines...), one line each, for the user.
    pub warnings: Vec<String>,
    /// The scene graph and animations (`animation`), when the file has animations.
    pub rig: Option<std::sync::Arc<animation::Rig>>,
}

/// What a scene file may reach besides itself (README "Security").
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LoadOptions {
    /// Let image and buffer URIs name files outside the scene file's folder (absolute paths,
    /// `../`, symlinks leading out). Off by default: a file rendered on a farm or a web
    /// service must not make the renderer read the machine's other files.
    pub allow_external_files: bool,
}

impl Scene {
    /// Loads a .gltf or .glb file; its URIs may only name files in its own folder.
    pub fn load(path: &Path) -> Result<Scene> {
        gltf::load(path, LoadOptions::default())
    }

    /// Loads a .gltf or .glb file with `options`.
    pub fn load_with(path: &Path, options: LoadOptions) -> Result<Scene> {
        gltf::load(path, options)
    }

    /// Reads a glTF document from memory (a .glb, or a .gltf whose buffers are data: URIs).
    /// Used by the fuzzer: external files are refused.
    pub fn from_slice(bytes: &[u8]) -> Result<Scene> {
        gltf::load_slice(bytes, Path::new("<memory>"))
    }

    /// The built-in still life rendered when no scene is given.
    pub fn default_scene() -> Scene {
        default::still_life()
    }

    pub fn triangle_count(&self) -> usize {
        self.objects.iter().map(|o| self.meshes[o.mesh].triangles.len()).sum()
    }
}

/// Area-weighted vertex normals; vertices only touched by degenerate triangles get +Y.
pub fn compute_normals(positions: &[Vec3], triangles: &[[u32; 3]]) -> Vec<Vec3> {
    let mut n = vec![Vec3::ZERO; positions.len()];
    for t in triangles {
        let [a, b, c] = t.map(|i| positions[i as usize]);
        let face = (b - a).cross(c - a); // length = 2 x area: area weighting
        if face.is_finite() {
            for &i in t {
                n[i as usize] += face;
            }
        }
    }
    n.into_iter().map(|v| v.try_normalize().unwrap_or(Vec3::Y)).collect()
}

/// A world of `parts` (each mesh placed at its offset, one white material) and a camera at
/// `camera` looking down -Z: the scene the backdrop and enclosure tests build.
#[cfg(test)]
pub(crate) fn test_world(parts: Vec<(Mesh, glam::DVec3)>, camera: Option<glam::DVec3>) -> World {
    let mut s = Scene::default();
    s.materials.push(Material { base_color: glam::Vec4::ONE, ..Material::default() });
    for (mesh, at) in parts {
        s.meshes.push(mesh);
        s.objects.push(Object {
            name: format!("o{}", s.objects.len()),
            mesh: s.meshes.len() - 1,
            transform: glam::DMat4::from_translation(at),
        });
    }
    s.camera = camera.map(|position| SceneCamera {
        position,
        forward: glam::DVec3::NEG_Z,
        up: glam::DVec3::Y,
        projection: Projection::Perspective { yfov: 1.0 },
        focus_distance: None,
    });
    World::new(&s)
}

#[cfg(test)]
/// A sheet `width` wide (along X) swept along the profile `(z, y)` points, its winding
/// facing up and forward (towards +Y, +Z) or, `flipped`, away.
pub(crate) fn test_sweep(profile: &[(f32, f32)], width: f32, flipped: bool) -> Mesh {
    let xs = [-0.5 * width, -0.25 * width, 0.0, 0.25 * width, 0.5 * width];
    let positions: Vec<glam::Vec3> =
        xs.iter().flat_map(|&x| profile.iter().map(move |&(z, y)| glam::Vec3::new(x, y, z))).collect();
    let m = profile.len() as u32;
    let mut triangles = Vec::new();
    for i in 0..xs.len() as u32 - 1 {
        for j in 0..m - 1 {
            let (a, c) = (i * m + j, (i + 1) * m + j);
            let (t1, t2) = ([a, c, a + 1], [a + 1, c, c + 1]);
            triangles.extend(if flipped { [[t1[0], t1[2], t1[1]], [t2[0], t2[2], t2[1]]] } else { [t1, t2] });
        }
    }
    Mesh {
        name: "sweep".into(),
        normals: vec![glam::Vec3::Y; positions.len()],
        positions,
        uvs: None,
        colors: None,
        triangles,
        material: None,
    }
}

#[cfg(test)]
/// The profile of a studio sweep: a floor 6 m deep at y = `y` from z = 3 back to a curve of
/// radius 1.5 m rising into a wall 5 m high at z = -3.
pub(crate) fn sweep_profile(y: f32) -> Vec<(f32, f32)> {
    let mut p = vec![(3.0, y), (-1.5, y)];
    for k in 1..12 {
        let a = std::f32::consts::FRAC_PI_2 * k as f32 / 12.0;
        p.push((-1.5 - 1.5 * a.sin(), y + 1.5 - 1.5 * a.cos()));
    }
    p.extend([(-3.0, y + 1.5), (-3.0, y + 5.0)]);
    p
}
