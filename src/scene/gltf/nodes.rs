//! The scene graph: world transforms (composed in f64), the scene's camera, its lights, and the
//! mesh instances the primitives are placed by.

use glam::{DMat4, DVec3, DVec4, Vec3};

use super::{Loader, MAX_TRIANGLES};
use crate::error::{Error, Result, short_num};
use crate::scene::{Light, LightKind, Object, Projection, SceneCamera};
use crate::util::limits::{MAX_LIGHTS, MAX_OBJECTS};

impl<'a> Loader<'a> {
    pub(super) fn load_scene(&mut self) -> Result<()> {
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
                if self.scene.lights.len() >= MAX_LIGHTS {
                    return Err(self.err(format!(
                        "node {}: more than {MAX_LIGHTS} lights (each is evaluated at every sample)",
                        node.index()
                    )));
                }
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
    pub(super) fn compute_world(&mut self, node: gltf::Node<'a>, parent: DMat4) -> Result<()> {
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

    pub(super) fn local_transform(&self, node: &gltf::Node) -> Result<DMat4> {
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

    pub(super) fn camera(&self, node: &gltf::Node, camera: gltf::Camera, world: DMat4) -> Result<SceneCamera> {
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
                let ymag = o.ymag() as f64;
                if !(ymag.is_finite() && ymag != 0.0 && o.xmag().is_finite() && o.xmag() != 0.0) {
                    return Err(self.err(format!(
                        "camera {}: orthographic xmag {} / ymag {} must be finite and non-zero",
                        camera.index(),
                        short_num(o.xmag() as f64),
                        short_num(ymag)
                    )));
                }
                Projection::Orthographic { ymag: ymag.abs() }
            }
        };
        let f = forward.try_normalize();
        let u = f.and_then(|f| (up - f * up.dot(f)).try_normalize());
        match (f, u) {
            (Some(forward), Some(up)) => Ok(SceneCamera { position, forward, up, projection, focus_distance: None }),
            _ => Err(self.err(format!("node {}: camera transform is degenerate (zero scale)", node.index()))),
        }
    }

    pub(super) fn light(
        &self,
        node: &gltf::Node,
        light: gltf::khr_lights_punctual::Light,
        world: DMat4,
    ) -> Result<Light> {
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

    pub(super) fn instance(&mut self, node: &gltf::Node<'a>, mesh: gltf::Mesh<'a>, world: DMat4) -> Result<()> {
        let skin_matrices = match node.skin() {
            Some(skin) => {
                self.add_work(skin.joints().len(), &format!("skin {}", skin.index()))?;
                Some(self.skin_matrices(&skin)?)
            }
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
            if self.scene.objects.len() >= MAX_OBJECTS {
                return Err(self.err(format!("the scene places more than {MAX_OBJECTS} mesh instances")));
            }
            let name = node.name().map(str::to_string).unwrap_or_else(|| format!("node {}", node.index()));
            // Skinned vertices are already in scene space (glTF ignores the node's transform).
            let transform = if skin_matrices.is_some() { DMat4::IDENTITY } else { world };
            self.scene.objects.push(Object { name, mesh: mesh_index, transform });
        }
        Ok(())
    }
}
