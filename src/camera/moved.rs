//! A camera moved rigidly, for animation frames: a turntable (`--orbit`) turns the layout
//! frame's camera about the scene, an animated glTF camera carries it with its node. Moving the
//! rays (rather than framing a camera anew each frame) keeps every framing decision of the
//! layout frame, so the picture never zooms or jumps as the scene moves.

use glam::{DQuat, DVec2, DVec3};

use super::{Camera, CameraFrame, CameraModel, CameraRay, Projected, finish_ray};

/// `inner` rotated by `rotation` about the render-space origin, then shifted by `translation`.
pub struct Moved<'a> {
    pub inner: &'a dyn Camera,
    pub rotation: DQuat,
    pub translation: DVec3,
    /// The radius of the scene's sphere this frame: rays start where they enter it
    /// (`finish_ray`), which the inner camera's own radius (its frame's) may not cover.
    pub clip_radius: f64,
}

impl Moved<'_> {
    /// A point of the inner camera's space in the moved camera's.
    pub fn point(&self, p: DVec3) -> DVec3 {
        self.rotation * p + self.translation
    }

    /// The inner camera's frame, moved (the light rig that follows the camera reads it).
    pub fn frame(&self, f: &CameraFrame) -> CameraFrame {
        CameraFrame {
            position: self.point(f.position),
            forward: self.rotation * f.forward,
            up: self.rotation * f.up,
            right: self.rotation * f.right,
        }
    }
}

impl Camera for Moved<'_> {
    fn ray(&self, p: DVec2) -> CameraRay {
        let r = self.inner.ray(p);
        let origin = self.point(r.surface_origin());
        finish_ray(origin, self.rotation * r.dir.as_dvec3(), r.surface_focus(), self.clip_radius)
    }

    fn project(&self, q: DVec3) -> Option<Projected> {
        self.inner.project(self.rotation.inverse() * (q - self.translation))
    }

    fn model(&self) -> CameraModel {
        CameraModel::Moved(Box::new(MovedModel {
            inner: self.inner.model(),
            rotation: self.rotation,
            translation: self.translation,
            clip_radius: self.clip_radius,
        }))
    }
}

/// A `Moved` camera as plain data (`CameraModel::Moved`).
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct MovedModel {
    pub inner: CameraModel,
    pub rotation: DQuat,
    pub translation: DVec3,
    pub clip_radius: f64,
}

impl MovedModel {
    fn moved(&self) -> Moved<'_> {
        Moved {
            inner: self.inner.camera(),
            rotation: self.rotation,
            translation: self.translation,
            clip_radius: self.clip_radius,
        }
    }
}

impl Camera for MovedModel {
    fn ray(&self, p: DVec2) -> CameraRay {
        self.moved().ray(p)
    }
    fn project(&self, q: DVec3) -> Option<Projected> {
        self.moved().project(q)
    }
    fn model(&self) -> CameraModel {
        CameraModel::Moved(Box::new(self.clone()))
    }
}
