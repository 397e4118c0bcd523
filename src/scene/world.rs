//! The scene flattened into render space: one triangle list with per-corner normals, UVs
//! and colours, and the lights, all in coordinates centred on the scene with radius 1.
//!
//! Why a render space: scenes come scaled by 1e-6 or 1e6 and placed 1e6 units from the
//! origin. Transforms are composed in f64 and the scene is re-centred and rescaled before
//! the single conversion to f32, so tracing precision and every epsilon are the same for
//! all of them (the robustness tests check identical pictures).

use glam::{DVec3, Vec2, Vec3, Vec4};

use super::{Light, LightKind, Material, Projection, Scene, SceneCamera, Texture};

/// Scene units -> render space: `render = (p - centre) * scale`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Similarity {
    pub centre: DVec3,
    pub scale: f64,
}

impl Similarity {
    pub fn point(&self, p: DVec3) -> Vec3 {
        ((p - self.centre) * self.scale).as_vec3()
    }
    pub fn point_f64(&self, p: DVec3) -> DVec3 {
        (p - self.centre) * self.scale
    }
    pub fn length(&self, l: f64) -> f64 {
        l * self.scale
    }
    /// Render space back to scene units.
    pub fn inverse_point(&self, p: Vec3) -> DVec3 {
        p.as_dvec3() / self.scale + self.centre
    }
}

/// A light in render space. Point/spot intensities are pre-scaled so that inverse-square
/// falloff computed with render-space distances gives the scene-unit irradiance.
#[derive(Clone, Debug, PartialEq)]
pub struct WorldLight {
    pub kind: LightKind,
    pub color: Vec3,
    pub intensity: f32,
    pub position: Vec3,
    /// Unit direction the light travels.
    pub direction: Vec3,
}

#[derive(Clone, Debug)]
pub struct WorldObject {
    pub name: String,
    /// Index into `Scene::meshes` (saliency is per mesh).
    pub mesh: usize,
    pub material: usize,
    pub first_triangle: u32,
    pub triangle_count: u32,
}

#[derive(Clone, Debug)]
pub struct World {
    pub to_render: Similarity,
    /// Triangle corners, render space. Triangle id = index here (objects in order).
    pub positions: Vec<[Vec3; 3]>,
    /// Unit shading normals per corner.
    pub normals: Vec<[Vec3; 3]>,
    /// UVs per corner (zero for untextured objects).
    pub uvs: Vec<[Vec2; 3]>,
    /// Vertex colours per corner; empty when no mesh has COLOR_0.
    pub colors: Vec<[Vec4; 3]>,
    pub triangle_object: Vec<u32>,
    pub objects: Vec<WorldObject>,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    pub lights: Vec<WorldLight>,
    /// The scene's camera in render space.
    pub camera: Option<SceneCamera>,
    /// Render-space axis-aligned bounds of every vertex.
    pub bounds: (Vec3, Vec3),
    /// Largest vertex distance from the render-space origin (1 unless the scene is a point).
    pub radius: f32,
}

impl World {
    pub fn new(scene: &Scene) -> World {
        World::with_render_space(scene, World::render_space(scene))
    }

    /// The render space of `scene`: centred on its bounding box, its farthest vertex at
    /// distance 1.
    pub fn render_space(scene: &Scene) -> Similarity {
        // Bounds in scene units (f64), over every placed vertex. Non-finite vertices (the
        // loader refuses them; a scene built in code may have them) never hit anything and
        // must not drag the render space to infinity.
        let mut lo = DVec3::splat(f64::INFINITY);
        let mut hi = DVec3::splat(f64::NEG_INFINITY);
        for o in &scene.objects {
            for p in &scene.meshes[o.mesh].positions {
                let w = o.transform.transform_point3(p.as_dvec3());
                if w.is_finite() {
                    lo = lo.min(w);
                    hi = hi.max(w);
                }
            }
        }
        if !lo.is_finite() || !hi.is_finite() {
            lo = DVec3::ZERO;
            hi = DVec3::ZERO;
        }
        let centre = (lo + hi) * 0.5;
        let mut r2: f64 = 0.0;
        for o in &scene.objects {
            for p in &scene.meshes[o.mesh].positions {
                let d2 = (o.transform.transform_point3(p.as_dvec3()) - centre).length_squared();
                if d2.is_finite() {
                    r2 = r2.max(d2);
                }
            }
        }
        let r = r2.sqrt();
        let scale = if r > 0.0 && r.is_finite() && (1.0 / r).is_finite() { 1.0 / r } else { 1.0 };
        Similarity { centre, scale }
    }

    /// `scene` flattened into a given render space: animation frames share the layout frame's,
    /// so a point keeps its render-space coordinates while nothing moves it.
    pub fn with_render_space(scene: &Scene, to_render: Similarity) -> World {
        let scale = to_render.scale;
        let n_tris = scene.triangle_count();
        let any_colors = scene.objects.iter().any(|o| scene.meshes[o.mesh].colors.is_some());
        let mut w = World {
            to_render,
            positions: Vec::with_capacity(n_tris),
            normals: Vec::with_capacity(n_tris),
            uvs: Vec::with_capacity(n_tris),
            colors: Vec::new(),
            triangle_object: Vec::with_capacity(n_tris),
            objects: Vec::with_capacity(scene.objects.len()),
            materials: scene.materials.clone(),
            textures: scene.textures.clone(),
            lights: Vec::new(),
            camera: None,
            bounds: (Vec3::ZERO, Vec3::ZERO),
            radius: 0.0,
        };
        if w.materials.is_empty() {
            w.materials.push(Material::default());
        }
        if any_colors {
            w.colors.reserve(n_tris);
        }
        for (oi, o) in scene.objects.iter().enumerate() {
            let mesh = &scene.meshes[o.mesh];
            let normal_matrix = glam::DMat3::from_mat4(o.transform).inverse().transpose();
            let placed: Vec<Vec3> =
                mesh.positions.iter().map(|p| to_render.point(o.transform.transform_point3(p.as_dvec3()))).collect();
            let normals: Vec<Vec3> = mesh
                .normals
                .iter()
                .map(|n| {
                    let v = (normal_matrix * n.as_dvec3()).as_vec3();
                    v.try_normalize().unwrap_or(Vec3::Y)
                })
                .collect();
            let first = w.positions.len() as u32;
            for t in &mesh.triangles {
                let [a, b, c] = t.map(|i| i as usize);
                w.positions.push([placed[a], placed[b], placed[c]]);
                w.normals.push([normals[a], normals[b], normals[c]]);
                w.uvs.push(match &mesh.uvs {
                    Some(uv) => [uv[a], uv[b], uv[c]],
                    None => [Vec2::ZERO; 3],
                });
                if any_colors {
                    w.colors.push(match &mesh.colors {
                        Some(col) => [col[a], col[b], col[c]],
                        None => [Vec4::ONE; 3],
                    });
                }
                w.triangle_object.push(oi as u32);
            }
            w.objects.push(WorldObject {
                name: o.name.clone(),
                mesh: o.mesh,
                material: mesh.material.unwrap_or(0).min(w.materials.len() - 1),
                first_triangle: first,
                triangle_count: mesh.triangles.len() as u32,
            });
        }
        let (mut blo, mut bhi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
        let mut radius = 0.0f32;
        for tri in &w.positions {
            for p in tri.iter().filter(|p| p.is_finite()) {
                blo = blo.min(*p);
                bhi = bhi.max(*p);
                radius = radius.max(p.length());
            }
        }
        if blo.is_finite() {
            w.bounds = (blo, bhi);
        }
        w.radius = radius;
        w.lights = scene
            .lights
            .iter()
            .map(|l: &Light| WorldLight {
                kind: l.kind,
                color: l.color,
                intensity: match l.kind {
                    LightKind::Directional => l.intensity,
                    _ => (l.intensity as f64 * scale * scale).min(f32::MAX as f64) as f32,
                },
                position: to_render.point(l.position),
                direction: l.direction.as_vec3(),
            })
            .collect();
        w.camera = scene.camera.as_ref().map(|c| SceneCamera {
            position: to_render.point_f64(c.position),
            forward: c.forward,
            up: c.up,
            projection: match c.projection {
                Projection::Orthographic { ymag } => Projection::Orthographic { ymag: ymag * scale },
                p => p,
            },
            focus_distance: c.focus_distance.map(|f| f * scale),
        });
        w
    }

    pub fn triangle_count(&self) -> usize {
        self.positions.len()
    }

    /// The object and the triangle index within its mesh for a world triangle id.
    pub fn local_triangle(&self, tri: u32) -> (u32, u32) {
        let o = self.triangle_object[tri as usize];
        (o, tri - self.objects[o as usize].first_triangle)
    }
}
