//! The scene in render space: each mesh's indexed vertex data once (a *geometry*), placed by
//! its objects (instances), and the lights, all in coordinates centred on the scene with
//! radius 1.
//!
//! Why a render space: scenes come scaled by 1e-6 or 1e6 and placed 1e6 units from the
//! origin. Transforms are composed in f64 and the scene is re-centred and rescaled before
//! the single conversion to f32, so tracing precision and every epsilon are the same for
//! all of them (the robustness tests check identical pictures).
//!
//! Why geometries and placements instead of one flat triangle list: a mesh placed by many
//! objects (instancing, Blender's collection instances and particle copies) is stored and
//! traced once, so its copies cost no triangle memory, and an object that moves changes a
//! transform, not its triangles. A geometry's vertices are baked in the render space of the
//! first object placing it (its *base space*): that object's placement is the identity, so a
//! scene without instancing is traced bit for bit as when it was flattened; every further
//! object placing the mesh carries an affine map from base to render space.
//!
//! Triangle ids stay global: object `o`'s triangles are `first_triangle ..
//! first_triangle + triangle_count`, objects in order (the saliency map, face counts and
//! film buffers index them), so the total placed triangles must stay below `u32::MAX`.

use glam::{Affine3A, DMat3, DMat4, DVec3, Mat3A, Vec2, Vec3, Vec3A, Vec4};
use rayon::prelude::*;

use super::{Light, LightKind, Material, Mesh, Projection, Scene, SceneCamera, Texture, compute_normals};
use crate::error::{Error, Result};

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
    /// As a matrix (scene units -> render space), for composing with object transforms.
    pub fn matrix(&self) -> DMat4 {
        DMat4::from_scale(DVec3::splat(self.scale)) * DMat4::from_translation(-self.centre)
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

/// One mesh's triangles as traced: indexed vertices baked into a base space (see the module
/// doc). `Accel` builds one BVH per geometry (per distinct content, in fact).
#[derive(Clone, Debug)]
pub struct Geometry {
    /// Index into `Scene::meshes`.
    pub source: usize,
    /// The object transform (scene units) the vertices were baked with: base space =
    /// `to_render(base(p))`.
    pub base: DMat4,
    /// Vertex positions, base space (f32 of the f64 placement, as the flattened scene had them).
    pub positions: Vec<Vec3>,
    /// Unit shading normals per vertex, base space.
    pub normals: Vec<Vec3>,
    /// UVs per vertex (None: untextured).
    pub uvs: Option<Vec<Vec2>>,
    /// Vertex colours per vertex (COLOR_0, linear RGBA).
    pub colors: Option<Vec<Vec4>>,
    pub triangles: Vec<[u32; 3]>,
}

impl Geometry {
    /// Bakes `mesh` with the object transform `base` into render space `to_render`.
    fn bake(mesh: &Mesh, source: usize, base: DMat4, to_render: Similarity) -> Geometry {
        let mut g = Geometry {
            source,
            base,
            positions: Vec::new(),
            normals: Vec::new(),
            uvs: mesh.uvs.clone(),
            colors: mesh.colors.clone(),
            triangles: mesh.triangles.clone(),
        };
        g.set_vertices(&mesh.positions, &mesh.normals, to_render);
        g
    }

    /// Positions and normals from mesh-local ones (exactly as the flattened scene computed
    /// them: f64 placement, one rounding to f32, normals by the inverse transpose).
    fn set_vertices(&mut self, positions: &[Vec3], normals: &[Vec3], to_render: Similarity) {
        let base = self.base;
        self.positions = positions.par_iter().map(|p| to_render.point(base.transform_point3(p.as_dvec3()))).collect();
        let normal_matrix = DMat3::from_mat4(base).inverse().transpose();
        self.normals = normals
            .par_iter()
            .map(|n| (normal_matrix * n.as_dvec3()).as_vec3().try_normalize().unwrap_or(Vec3::Y))
            .collect();
    }

    /// Corners of local triangle `t`, base space.
    #[inline]
    pub fn corners(&self, t: u32) -> [Vec3; 3] {
        self.triangles[t as usize].map(|i| self.positions[i as usize])
    }
}

/// Base space -> render space of an object whose geometry was baked for another object.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Placement {
    /// Base space -> render space.
    pub to_render: Affine3A,
    /// Render space -> base space (rays are traced in base space).
    pub to_base: Affine3A,
    /// Base-space normals -> render space (the inverse transpose; normalise after).
    pub normals: Mat3A,
}

impl Placement {
    /// The placement of an object with transform `transform` in a geometry baked with
    /// `base`, composed in f64; None when either transform is singular (no inverse to carry
    /// rays into base space).
    fn relative(transform: DMat4, base: DMat4, to_render: Similarity) -> Option<Placement> {
        let s = to_render.matrix();
        let base_inv = base.inverse();
        let m = s * transform * base_inv * s.inverse();
        let m_inv = m.inverse();
        let lin = DMat3::from_mat4(m);
        let n = lin.inverse().transpose();
        let ok = base_inv.is_finite()
            && m.is_finite()
            && m_inv.is_finite()
            && n.is_finite()
            && base.determinant() != 0.0
            && lin.determinant() != 0.0;
        ok.then(|| Placement {
            to_render: Affine3A::from_mat4(m.as_mat4()),
            to_base: Affine3A::from_mat4(m_inv.as_mat4()),
            normals: Mat3A::from(n.as_mat3()),
        })
    }
}

/// Whether rays can be carried through `t` (finite, non-zero determinant, finite inverse).
fn invertible(t: DMat4) -> bool {
    t.is_finite() && t.determinant() != 0.0 && t.inverse().is_finite()
}

/// A mesh placed in render space (the paper's "object").
#[derive(Clone, Debug)]
pub struct WorldObject {
    pub name: String,
    /// Index into `Scene::meshes` (saliency is per mesh).
    pub mesh: usize,
    /// Index into `World::geometries`.
    pub geometry: usize,
    pub material: usize,
    pub first_triangle: u32,
    pub triangle_count: u32,
    /// Its transform in scene units (`Object::transform`, or as last set).
    pub transform: DMat4,
    /// None: the object's geometry is baked for it (identity placement).
    pub placement: Option<Placement>,
    /// Render-space bounds of its triangles' corners and their largest distance from the
    /// origin (None when it has no finite corner).
    pub bounds: Option<(Vec3, Vec3, f32)>,
}

impl WorldObject {
    /// A base-space point in render space.
    #[inline]
    pub fn point(&self, p: Vec3) -> Vec3 {
        match &self.placement {
            None => p,
            Some(m) => m.to_render.transform_point3(p),
        }
    }

    /// A base-space normal in render space (not normalised when placed).
    #[inline]
    pub fn normal(&self, n: Vec3) -> Vec3 {
        match &self.placement {
            None => n,
            Some(m) => Vec3::from(m.normals * Vec3A::from(n)),
        }
    }
}

#[derive(Clone, Debug)]
pub struct World {
    pub to_render: Similarity,
    /// Each placed mesh's vertex data, once per base space (normally once per mesh).
    pub geometries: Vec<Geometry>,
    /// In scene order; triangle ids are global across them (see the module doc).
    pub objects: Vec<WorldObject>,
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    pub lights: Vec<WorldLight>,
    /// The scene's camera in render space.
    pub camera: Option<SceneCamera>,
    /// Render-space axis-aligned bounds of every triangle corner.
    pub bounds: (Vec3, Vec3),
    /// Largest corner distance from the render-space origin (1 unless the scene is a point).
    pub radius: f32,
    /// The objects that are backdrops (`backdrop::backdrops`: a floor or a wall much larger
    /// than the rest), found again whenever the bounds change.
    pub backdrops: Vec<super::backdrop::Backdrop>,
    /// The objects that are enclosures (`enclosure::enclosures`: a closed room around the
    /// scene's camera and its contents), found again with the backdrops.
    pub enclosures: Vec<super::enclosure::Enclosure>,
}

impl World {
    pub fn new(scene: &Scene) -> World {
        World::in_space(scene, World::render_space(scene))
    }

    /// The render space of `scene`: centred on its bounding box, its farthest vertex at
    /// distance 1 (animation frames keep the layout frame's).
    pub fn render_space(scene: &Scene) -> Similarity {
        // Bounds in scene units (f64), over every placed vertex. Non-finite vertices (the
        // loader refuses them; a scene built in code may have them) never hit anything and
        // must not drag the render space to infinity.
        let placed = |o: &super::Object| {
            let t = o.transform;
            scene.meshes[o.mesh].positions.par_iter().map(move |p| t.transform_point3(p.as_dvec3()))
        };
        let (mut lo, mut hi) = scene
            .objects
            .par_iter()
            .flat_map(placed)
            .filter(|w| w.is_finite())
            .fold(
                || (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
                |(lo, hi), w| (lo.min(w), hi.max(w)),
            )
            .reduce(
                || (DVec3::splat(f64::INFINITY), DVec3::splat(f64::NEG_INFINITY)),
                |a, b| (a.0.min(b.0), a.1.max(b.1)),
            );
        if !lo.is_finite() || !hi.is_finite() {
            lo = DVec3::ZERO;
            hi = DVec3::ZERO;
        }
        let centre = (lo + hi) * 0.5;
        let r2: f64 = scene
            .objects
            .par_iter()
            .flat_map(placed)
            .map(|w| (w - centre).length_squared())
            .filter(|d2| d2.is_finite())
            .reduce(|| 0.0, f64::max);
        let r = r2.sqrt();
        let scale = if r > 0.0 && r.is_finite() && (1.0 / r).is_finite() { 1.0 / r } else { 1.0 };
        Similarity { centre, scale }
    }

    /// The scene in a given render space (`World::new` chooses the one centred on the scene
    /// with radius 1). A long-lived process keeps the render space of a scene's previous
    /// version so that unchanged meshes bake to the same vertices and `Accel::update` reuses
    /// their BVHs.
    pub fn in_space(scene: &Scene, to_render: Similarity) -> World {
        let scale = to_render.scale;

        let mut w = World {
            to_render,
            geometries: Vec::new(),
            objects: Vec::with_capacity(scene.objects.len()),
            materials: scene.materials.clone(),
            textures: scene.textures.clone(),
            lights: Vec::new(),
            camera: None,
            bounds: (Vec3::ZERO, Vec3::ZERO),
            radius: 0.0,
            backdrops: Vec::new(),
            enclosures: Vec::new(),
        };
        if w.materials.is_empty() {
            w.materials.push(Material::default());
        }
        // The geometry baked for each scene mesh: by the first object placing it whose
        // transform is invertible. Objects with a singular transform get their own.
        let mut baked: Vec<Option<usize>> = vec![None; scene.meshes.len()];
        let mut first = 0u32;
        for o in &scene.objects {
            let mesh = &scene.meshes[o.mesh];
            let (geometry, placement) = match w.place(baked[o.mesh], o.transform) {
                Some(p) => p,
                None => {
                    let g = w.bake(mesh, o.mesh, o.transform);
                    if baked[o.mesh].is_none() && invertible(o.transform) {
                        baked[o.mesh] = Some(g);
                    }
                    (g, None)
                }
            };
            let count = mesh.triangles.len() as u32;
            w.objects.push(WorldObject {
                name: o.name.clone(),
                mesh: o.mesh,
                geometry,
                material: mesh.material.unwrap_or(0).min(w.materials.len() - 1),
                first_triangle: first,
                triangle_count: count,
                transform: o.transform,
                placement,
                bounds: None,
            });
            first = first.saturating_add(count);
        }
        // (The camera first: enclosures are found around it.)
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
        w.refresh_bounds(None);
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
        w
    }

    /// Where an object with `transform` goes in geometry `g`: identity when `transform` is
    /// the one `g` was baked with, else a relative placement; None when there is no such
    /// geometry or the transform is singular.
    fn place(&self, g: Option<usize>, transform: DMat4) -> Option<(usize, Option<Placement>)> {
        let g = g?;
        let base = self.geometries[g].base;
        if transform == base {
            return Some((g, None));
        }
        Placement::relative(transform, base, self.to_render).map(|p| (g, Some(p)))
    }

    /// Bakes a new geometry of `mesh` for an object with `transform`; its index.
    fn bake(&mut self, mesh: &Mesh, source: usize, transform: DMat4) -> usize {
        self.geometries.push(Geometry::bake(mesh, source, transform, self.to_render));
        self.geometries.len() - 1
    }

    /// A world of one object whose triangles are given in render space (tests, benchmarks).
    pub fn from_triangles(tris: &[[Vec3; 3]]) -> World {
        let positions: Vec<Vec3> = tris.iter().flatten().copied().collect();
        let triangles: Vec<[u32; 3]> = (0..tris.len() as u32).map(|i| [3 * i, 3 * i + 1, 3 * i + 2]).collect();
        let mesh = Mesh {
            name: "triangles".into(),
            normals: compute_normals(&positions, &triangles),
            positions,
            uvs: None,
            colors: None,
            triangles,
            material: None,
        };
        let object = super::Object { name: "triangles".into(), mesh: 0, transform: DMat4::IDENTITY };
        let scene = Scene { meshes: vec![mesh], objects: vec![object], ..Scene::default() };
        World::in_space(&scene, Similarity { centre: DVec3::ZERO, scale: 1.0 })
    }

    /// Recomputes the bounds of `objects` (all when None), then the world's `bounds` and
    /// `radius` from every object's: O(vertices of those objects) + O(objects).
    pub fn refresh_bounds(&mut self, objects: Option<&[usize]>) {
        let geometries = &self.geometries;
        // The vertices each geometry's triangles use, each once (min and max over the corners,
        // at a sixth of the points on a closed mesh): found once per geometry, not per object
        // (ten instances of a 1M-triangle mesh walked 30M corners).
        let mut wanted = vec![false; geometries.len()];
        match objects {
            None => self.objects.iter().for_each(|o| wanted[o.geometry] = true),
            Some(list) => list.iter().for_each(|&i| wanted[self.objects[i].geometry] = true),
        }
        let used: Vec<Vec<u32>> = geometries
            .par_iter()
            .zip(&wanted)
            .map(|(g, &w)| {
                if !w {
                    return Vec::new();
                }
                let mut on = vec![false; g.positions.len()];
                for &i in g.triangles.iter().flatten() {
                    if let Some(f) = on.get_mut(i as usize) {
                        *f = true;
                    }
                }
                (0..g.positions.len() as u32).filter(|&i| on[i as usize]).collect()
            })
            .collect();
        let object_bounds = |o: &WorldObject| {
            let g = &geometries[o.geometry];
            used[o.geometry]
                .par_iter()
                .map(|&i| o.point(g.positions[i as usize]))
                .filter(|p| p.is_finite())
                .fold(
                    || None,
                    |b: Option<(Vec3, Vec3, f32)>, p| {
                        let (lo, hi, r) = b.unwrap_or((p, p, 0.0));
                        Some((lo.min(p), hi.max(p), r.max(p.length())))
                    },
                )
                .reduce(
                    || None,
                    |a, b| match (a, b) {
                        (Some(a), Some(b)) => Some((a.0.min(b.0), a.1.max(b.1), a.2.max(b.2))),
                        (a, None) => a,
                        (None, b) => b,
                    },
                )
        };
        match objects {
            None => {
                let all: Vec<_> = self.objects.par_iter().map(object_bounds).collect();
                for (o, b) in self.objects.iter_mut().zip(all) {
                    o.bounds = b;
                }
            }
            Some(list) => {
                for &i in list {
                    let b = object_bounds(&self.objects[i]);
                    self.objects[i].bounds = b;
                }
            }
        }
        let (mut lo, mut hi, mut radius) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY), 0.0f32);
        for (blo, bhi, r) in self.objects.iter().filter_map(|o| o.bounds) {
            lo = lo.min(blo);
            hi = hi.max(bhi);
            radius = radius.max(r);
        }
        self.bounds = if lo.is_finite() { (lo, hi) } else { (Vec3::ZERO, Vec3::ZERO) };
        self.radius = radius;
        self.backdrops = super::backdrop::backdrops(self);
        self.enclosures = super::enclosure::enclosures(self, self.camera.as_ref().map(|c| c.position));
    }

    /// Takes `layout`'s backdrops (the same scene at an animation's layout frame) when none of
    /// their objects moved since: which objects are the setting, and which of them run on, are
    /// decided once for an animation, so a character jumping clear of the floor does not stop
    /// the floor running on, nor a stretched arm turn a wall into subject, for a few frames.
    /// Still: the same transform, triangles, bounds and vertex positions.
    pub fn keep_backdrops_of(&mut self, layout: &World) {
        let still = |o: usize| match (self.objects.get(o), layout.objects.get(o)) {
            (Some(a), Some(b)) => {
                (a.transform, a.first_triangle, a.triangle_count, a.bounds)
                    == (b.transform, b.first_triangle, b.triangle_count, b.bounds)
                    && self.geometries[a.geometry].positions == layout.geometries[b.geometry].positions
            }
            _ => false,
        };
        if self.objects.len() != layout.objects.len() || !layout.backdrops.iter().all(|b| still(b.object)) {
            return;
        }
        let changed = self.backdrops.iter().map(|b| b.object).ne(layout.backdrops.iter().map(|b| b.object));
        self.backdrops = layout.backdrops.clone();
        // Enclosures are found among what is not a backdrop: found again for the kept set.
        if changed {
            self.enclosures = super::enclosure::enclosures(self, self.camera.as_ref().map(|c| c.position));
        }
    }

    /// Whether object `o` is the scene's setting rather than its subject: a backdrop or an
    /// enclosure, which the cameras are not framed around.
    pub fn is_setting(&self, o: usize) -> bool {
        self.backdrops.iter().any(|b| b.object == o) || self.enclosures.iter().any(|e| e.object == o)
    }

    /// Placed triangles, instances counted each time (the range of triangle ids).
    pub fn triangle_count(&self) -> usize {
        self.objects.last().map_or(0, |o| o.first_triangle as usize + o.triangle_count as usize)
    }

    /// Triangles stored: each geometry's once, however many objects place it.
    pub fn stored_triangle_count(&self) -> usize {
        self.geometries.iter().map(|g| g.triangles.len()).sum()
    }

    /// The object holding triangle id `tri` (a binary search over the objects).
    #[inline]
    pub fn object_of(&self, tri: u32) -> u32 {
        // The last object whose first triangle is <= tri; empty objects share a first
        // triangle with the next, so take the last of equals.
        (self.objects.partition_point(|o| o.first_triangle <= tri) - 1) as u32
    }

    /// The object and the triangle index within its mesh for a triangle id.
    #[inline]
    pub fn local_triangle(&self, tri: u32) -> (u32, u32) {
        let o = self.object_of(tri);
        (o, tri - self.objects[o as usize].first_triangle)
    }

    /// Corners of triangle `tri`, render space.
    pub fn triangle(&self, tri: u32) -> [Vec3; 3] {
        let (o, local) = self.local_triangle(tri);
        let o = &self.objects[o as usize];
        self.geometries[o.geometry].corners(local).map(|p| o.point(p))
    }

    /// The point at barycentrics (u, v) of triangle `tri`, render space (a hit's surface point).
    pub fn point_at(&self, tri: u32, u: f32, v: f32) -> Vec3 {
        let [p0, p1, p2] = self.triangle(tri);
        p0 * (1.0 - u - v) + p1 * u + p2 * v
    }

    /// Corners of every triangle, by triangle id, render space: a frame's geometry kept for
    /// later frames (a key frame's, the picture strokes are hatched on).
    pub fn positions(&self) -> Vec<[Vec3; 3]> {
        (0..self.triangle_count()).map(|t| self.triangle(t as u32)).collect()
    }

    /// Corner `k` of the placed triangle list (triangle k / 3, corner k % 3), render space:
    /// bounded samples of the scene's vertices in a fixed order.
    pub fn corner(&self, k: usize) -> Vec3 {
        self.triangle((k / 3) as u32)[k % 3]
    }

    /// Moves objects to new transforms (scene units, as `Object::transform`; the render
    /// space stays). Returns the geometries added for transforms too singular to carry rays
    /// into an existing base space (a zero scale): such an object gets its own baked copy.
    /// Then call `Accel::update_instances` (a top-level rebuild only, plus a BVH for any
    /// geometry added). Bounds and radius follow (O(the moved objects' vertices)).
    pub fn set_transforms(&mut self, scene: &Scene, moves: &[(usize, DMat4)]) -> Result<Vec<usize>> {
        let mut added = Vec::new();
        for &(i, transform) in moves {
            let o = self.objects.get(i).ok_or_else(|| Error::Internal(format!("no object {i} to move")))?;
            let mesh = o.mesh;
            // Its own geometry's base first, then that of the mesh's first geometry.
            let first = self.geometries.iter().position(|g| g.source == mesh && invertible(g.base));
            let (geometry, placement) =
                match self.place(Some(o.geometry), transform).or_else(|| self.place(first, transform)) {
                    Some(p) => p,
                    None => {
                        let g = self.bake(&scene.meshes[mesh], mesh, transform);
                        added.push(g);
                        (g, None)
                    }
                };
            let o = &mut self.objects[i];
            (o.geometry, o.transform, o.placement) = (geometry, transform, placement);
        }
        let moved: Vec<usize> = moves.iter().map(|m| m.0).collect();
        self.refresh_bounds(Some(&moved));
        Ok(added)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Object;

    fn tri_mesh() -> Mesh {
        let positions = vec![Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::new(1.0, 1.0, 0.5)];
        let triangles = vec![[0, 1, 2], [1, 3, 2]];
        Mesh {
            name: "m".into(),
            normals: compute_normals(&positions, &triangles),
            positions,
            uvs: None,
            colors: None,
            triangles,
            material: None,
        }
    }

    fn scene(transforms: &[DMat4]) -> Scene {
        Scene {
            meshes: vec![tri_mesh()],
            objects: transforms
                .iter()
                .enumerate()
                .map(|(i, t)| Object { name: format!("o{i}"), mesh: 0, transform: *t })
                .collect(),
            ..Scene::default()
        }
    }

    /// Instances share one geometry; their corners in render space are those a flattened
    /// scene would have (to f32 rounding), and triangle ids run across objects in order.
    #[test]
    fn instances_share_a_geometry_and_place_it() {
        let ts = [
            DMat4::IDENTITY,
            DMat4::from_translation(DVec3::new(3.0, 0.0, 0.0)),
            DMat4::from_scale_rotation_translation(
                DVec3::new(2.0, 0.5, 1.0),
                glam::DQuat::from_rotation_z(0.7),
                DVec3::new(0.0, -2.0, 1.0),
            ),
        ];
        let s = scene(&ts);
        let w = World::new(&s);
        assert_eq!(w.geometries.len(), 1);
        assert_eq!(w.triangle_count(), 6);
        assert_eq!(w.stored_triangle_count(), 2);
        assert!(w.objects[0].placement.is_none() && w.objects[1].placement.is_some());
        for tri in 0..6u32 {
            let (o, local) = w.local_triangle(tri);
            assert_eq!((o, local), (tri / 2, tri % 2));
            let t = ts[o as usize];
            let want = s.meshes[0].triangles[local as usize]
                .map(|i| w.to_render.point(t.transform_point3(s.meshes[0].positions[i as usize].as_dvec3())));
            for (a, b) in w.triangle(tri).iter().zip(want) {
                assert!((*a - b).length() < 1e-6, "{tri}: {a} {b}");
            }
        }
    }

    /// A zero scale cannot carry rays into the base space: that object gets its own copy.
    #[test]
    fn a_singular_transform_gets_its_own_geometry() {
        let s = scene(&[DMat4::IDENTITY, DMat4::from_scale(DVec3::new(1.0, 1.0, 0.0))]);
        let w = World::new(&s);
        assert_eq!(w.geometries.len(), 2);
        assert!(w.objects.iter().all(|o| o.placement.is_none()));
        assert_eq!(w.triangle(3)[1].z, w.triangle(3)[0].z);
    }

    #[test]
    fn moving_an_object_changes_its_placement_and_the_bounds() {
        let s = scene(&[DMat4::IDENTITY, DMat4::from_translation(DVec3::X * 3.0)]);
        let mut w = World::new(&s);
        let before = w.triangle(2);
        let added = w.set_transforms(&s, &[(1, DMat4::from_translation(DVec3::X * 5.0))]).unwrap();
        assert!(added.is_empty());
        let after = w.triangle(2);
        let shift = (after[0] - before[0]) / w.to_render.scale as f32;
        assert!((shift - Vec3::X * 2.0).length() < 1e-5, "{shift}");
        assert!(w.radius > 1.0);
        // Back to the base transform: identity placement again.
        w.set_transforms(&s, &[(1, DMat4::IDENTITY)]).unwrap();
        assert!(w.objects[1].placement.is_none());
        let added = w.set_transforms(&s, &[(1, DMat4::from_scale(DVec3::new(0.0, 1.0, 1.0)))]).unwrap();
        assert_eq!(added, vec![1]);
        assert_eq!(w.objects[1].geometry, 1);
    }

    /// An animation's setting is its layout frame's: a ball jumping clear of the floor leaves
    /// the floor running on (found again, it would not); a floor that moves is found again.
    #[test]
    fn the_layout_frames_backdrops_hold_while_their_objects_stand_still() {
        use crate::scene::default::{cuboid, ellipsoid};
        let floor = cuboid("floor", Vec3::new(20.0, 0.02, 20.0), 0);
        let ball = ellipsoid("ball", Vec3::splat(1.0), 12, 24, 0);
        let at = |y: f64| DMat4::from_translation(DVec3::Y * y);
        let s = Scene {
            meshes: vec![floor, ball],
            objects: vec![
                Object { name: "floor".into(), mesh: 0, transform: at(-0.01) },
                Object { name: "ball".into(), mesh: 1, transform: at(1.0) },
            ],
            materials: vec![crate::scene::Material::default()],
            ..Scene::default()
        };
        let layout = World::new(&s);
        assert!(layout.backdrops.len() == 1 && layout.backdrops[0].face.is_some());
        let mut jump = layout.clone();
        jump.set_transforms(&s, &[(1, at(3.0))]).unwrap();
        assert!(jump.backdrops[0].face.is_none(), "found again, the floor no longer runs on");
        jump.keep_backdrops_of(&layout);
        assert_eq!(jump.backdrops, layout.backdrops);
        // The floor lowered with the ball on it: its plane is found again.
        let mut lowered = layout.clone();
        lowered.set_transforms(&s, &[(0, at(-1.01)), (1, at(0.0))]).unwrap();
        let found = lowered.backdrops.clone();
        lowered.keep_backdrops_of(&layout);
        assert_eq!(lowered.backdrops, found);
        assert_ne!(found[0].offset, layout.backdrops[0].offset);
    }
}
