//! Animation frames (`cubist render --frames A-B`, SPEC "Animation"): every frame of a range in
//! one process, each a pure function of its frame number, so any range rendered alone (a farm
//! chunk) gives the same pictures, byte for byte, as the same frames of a longer run.
//!
//! Frame f is the scene at time (f - frame_at_zero) / fps of its glTF animation
//! (`scene::animation`), seen through the layout frame's camera moved rigidly
//! (`camera::Moved`): turned about the scene's vertical axis by `orbit` degrees per frame (a
//! turntable), and carried along with the glTF camera when the file animates it. The layout frame fixes what frames share: the render space,
//! the camera's framing, and the facet layout (computed from its full pre-render, or loaded).
//!
//! Each frame then runs:
//!
//! | step | what | why it is cheap |
//! |---|---|---|
//! | geometry | the scene posed, flattened, its BVH | kept while no triangle moves (a turntable); objects only moved: the layout frame's world moved (`World::set_transforms`), BVH top level only |
//! | pre-pass | one centre ray per pixel, hits only | no shading |
//! | saliency | the saliency map off the pre-pass | mesh saliency once per mesh content: a skinned or morphed mesh keeps its rest pose's, by vertex index; not needed by facets that follow |
//! | facets | the layout's map (static) or carried to this frame (`facets::motion`) | the layout is never computed again |
//! | imprecision | aims, as a still render's (`aims_stage`); facets that follow: the layout frame's, carried (`imprecision::carried`) | |
//! | re-trace | every pixel, one centre sample through its facet's rays, lit (`retrace_stage`) | sparse shadow rays; no separate lit pre-render |
//! | anti-aliasing | `spp` samples where facet neighbours disagree (`antialias_stage`) | most pixels keep their one sample |
//! | paint, encode | as a still render's (`paint_stage`, `encode_stage`) | |
//!
//! The stages are the still render's (`stages`), each working in place (`Retracing::InPlace`,
//! `Refining::InPlace`, `Painting::InPlace`): a frame keeps nothing of the frame before but
//! what `Keep` holds.
//!
//! What frames keep from one another (the BVH while nothing moves, the layout, the key frame,
//! the painter, per-mesh saliency) is held in `Keep` and `Prepared`: one place, so a stage cache
//! shared with other long-lived renders can take it over.

use glam::{DMat3, DQuat, DVec2, DVec3, Vec3};
use image::RgbaImage;

use super::stages::encode::Encoded;
use super::stages::{
    Painting, Refining, Retracing, aims_stage, antialias_stage, encode_stage, layout_stage, paint_stage, retrace_stage,
};
use super::{Plan, Prepared, Stage, StageParams, Timings};
use crate::accel::Accel;
use crate::camera::{Camera, CameraModel, Moved};
use crate::error::{Error, Result};
use crate::facets::motion::file::{self as follow_file, KeyData};
use crate::facets::motion::{self, FacetMotion, FrameSurface};
use crate::facets::{self, FacetMap, FacetMethod};
use crate::film::Film;
use crate::framing::{Framed, frame_camera};
use crate::imprecision::carried::{self, KeyAim};
use crate::imprecision::{self, AimContext, FacetAim};
use crate::output::{Gray16, Pass};
use crate::paint::chiaroscuro::ViewAxes;
use crate::paint::plane_light::Oval;
use crate::paint::{EffectParams, Held, Lighting, Painter, Sequence};
use crate::progress::Progress;
use crate::saliency;
use crate::scene::animation::{self, Choice, Clip};
use crate::scene::world::Similarity;
use crate::scene::{Scene, SceneCamera, World};
use crate::settings::Settings;
use crate::shading::LightRig;
use crate::strokes::surface::{LaidOn, SurfaceSeeds};
use crate::trace::{TraceParams, Tracer, screen_point};

/// Most frames one run renders (a range is validated before anything is loaded or traced).
pub const MAX_FRAMES: u32 = 1_000_000;
/// Highest frame rate accepted.
pub const MAX_FPS: f64 = 10_000.0;
/// Frame rate when none is given (`--fps`).
pub const DEFAULT_FPS: f64 = 24.0;
/// A turntable's default key-frame spacing, in degrees of turn: facets that follow are carried
/// from a key frame at most this far round, so the view they were made for has not changed
/// too much (the surface a key frame saw is mostly still in view, the revealed share small).
pub const REKEY_TURN_DEG: f64 = 30.0;

/// Which frames, at what rate, and what moves in them.
#[derive(Clone, Debug, PartialEq)]
pub struct FramesParams {
    pub first: u32,
    pub last: u32,
    pub fps: f64,
    /// The frame shown at the animation's time 0: 1 (Blender's first frame, and a file whose
    /// animations start at 0), or 0 for a file Blender exported with its defaults (its frame f
    /// at f / fps seconds), so frame numbers match Blender's timeline.
    pub frame_at_zero: u32,
    /// The glTF animation(s) played; None: the scene stays as loaded.
    pub animation: Option<Choice>,
    /// Turntable: the camera turns by this many degrees per frame about the scene's vertical
    /// axis (the camera's up through the layout frame's scene centre), frame 1 unturned.
    pub orbit_deg: f64,
    /// The frame whose picture the facet layout is made from, and whose pose fixes the render
    /// space and the camera's framing.
    pub layout_frame: u32,
    /// Keep what each frame shows (`FrameOutput::surface`), to measure coherence between
    /// frames (`facets::motion::coherence`).
    pub measure: bool,
    /// With facets that follow, a new key frame every this many frames from the layout frame
    /// (0: the layout frame only). Key frame k's facets are carried from key frame k-1's, so a
    /// point revealed since the layout frame keeps the facet it grew into; frame N needs the
    /// pre-passes of the key frames up to its own, never the frames between (farm chunks agree).
    pub rekey: u32,
}

impl FramesParams {
    /// Frames `first`-`last` at `DEFAULT_FPS`, frame 1 at time 0, the layout made at the first
    /// frame, nothing playing or turning, no key frame but the layout frame, nothing measured.
    pub fn new(first: u32, last: u32) -> FramesParams {
        FramesParams {
            first,
            last,
            fps: DEFAULT_FPS,
            frame_at_zero: 1,
            animation: None,
            orbit_deg: 0.0,
            layout_frame: first,
            measure: false,
            rekey: 0,
        }
    }

    /// The default `rekey` of a turntable turning `orbit_deg` per frame: a key frame every
    /// `REKEY_TURN_DEG` of turn (every frame when one frame turns further); 0 (the layout
    /// frame only) without an orbit. A function of the flags alone, so farm chunks agree.
    pub fn turntable_rekey(orbit_deg: f64) -> u32 {
        let turn = orbit_deg.abs();
        if !(turn.is_finite() && turn > 0.0) {
            return 0;
        }
        (REKEY_TURN_DEG / turn).floor().clamp(1.0, MAX_FRAMES as f64) as u32
    }

    /// Seconds into the animation at frame `f`: (f - `frame_at_zero`) / fps (before time 0, the
    /// animation's first keys hold).
    pub fn time(&self, f: u32) -> f64 {
        (f as f64 - self.frame_at_zero as f64) / self.fps
    }

    pub fn validate(&self) -> Result<()> {
        let bad = |key: &'static str, m: String| Err(Error::setting(key, m));
        if self.first > self.last {
            return bad("frames", format!("{}-{}: the first frame is after the last", self.first, self.last));
        }
        if self.last - self.first >= MAX_FRAMES {
            return bad(
                "frames",
                format!("{} frames exceed the limit of {MAX_FRAMES} per run", self.last - self.first + 1),
            );
        }
        if !(self.fps > 0.0 && self.fps <= MAX_FPS) {
            return bad("fps", format!("{} is not in (0, {MAX_FPS}]", self.fps));
        }
        if !(self.orbit_deg.is_finite() && self.orbit_deg.abs() <= 360.0) {
            return bad("orbit", format!("{} degrees per frame is not in [-360, 360]", self.orbit_deg));
        }
        Ok(())
    }
}

/// One frame, rendered.
pub struct FrameOutput {
    pub frame: u32,
    pub image: RgbaImage,
    pub passes: Vec<(Pass, RgbaImage)>,
    pub passes16: Vec<(Pass, Gray16)>,
    /// The facet id of every pixel.
    pub facets: FacetMap,
    pub timings: Timings,
    /// With facets that follow: the fraction of surface pixels the layout frame did not see
    /// (their facets grown from their neighbours').
    pub revealed: Option<f64>,
    /// What the frame shows, per pixel (with `FramesParams::measure`).
    pub surface: Option<FrameSurface>,
    /// The `motion` pass, when asked for (`motion::motion_pass`).
    pub motion: Option<crate::motion::Rgba16>,
}

/// What the whole run decided, for the user.
pub struct FramesSummary {
    pub warnings: Vec<String>,
    /// The layout frame's camera, in a line.
    pub camera: String,
    /// The names of the animations played, in file order.
    pub animations: Vec<String>,
    /// Steps done once, before the first frame (the layout frame's pre-render and layout).
    pub setup: Timings,
}

/// Renders every frame of `frames`, handing each to `emit` as soon as it is done (the caller
/// writes it), in order. `progress` runs over all frames' traces.
pub fn render_frames(
    prep: &Prepared,
    settings: &Settings,
    frames: &FramesParams,
    progress: &Progress,
    emit: &mut dyn FnMut(FrameOutput) -> Result<()>,
) -> Result<FramesSummary> {
    settings.validate()?;
    frames.validate()?;
    let params = StageParams::new(settings);
    let clips = match &frames.animation {
        Some(c) => animation::select(&prep.scene, c)?,
        None => Vec::new(),
    };
    let mut setup = Timings::default();
    let mut warnings = prep.scene.warnings.clone();
    if clips.is_empty() && frames.orbit_deg == 0.0 && frames.first != frames.last {
        warnings.push("nothing moves: the scene has no animation played and --orbit is 0".into());
    }
    let painter = setup.time("paint setup", || Painter::new(&params.paint))?;
    let animations = clips.iter().map(|c| c.name.clone()).collect();
    let mut poser = Poser::new(prep, clips, frames.fps);
    let key_geometry = setup.time("layout frame pose", || poser.geometry(frames, frames.layout_frame, None))?;
    let base = frame_camera(&params.framing, key_geometry.world(), key_geometry.accel())?;
    warnings.extend(base.warnings.iter().cloned());
    let follows_scene_camera = params.framing.position.is_none() && params.framing.target.is_none();
    let cameras = Cameras {
        base: &base,
        scene_camera: if follows_scene_camera { key_geometry.world().camera.clone() } else { None },
        orbit_rad: frames.orbit_deg.to_radians(),
    };
    let camera_line = base.describe(key_geometry.world());

    let keep =
        setup.time("layout", || key_frame(prep, &params, frames, &key_geometry, &cameras, &painter, &mut warnings))?;
    if params.motion == FacetMotion::Follow && !keep.faceted {
        warnings.push("facet motion `follow` has no effect without facets".into());
    }
    let (w, h) = (params.trace.width, params.trace.height);
    progress.begin("frames", (frames.last - frames.first + 1) as u64 * w as u64 * h as u64);
    let mut geometry = key_geometry;
    let mut chain: Option<Chained> = None;
    for f in frames.first..=frames.last {
        let mut timings = Timings::default();
        if let Some(key) = &keep.key
            && frames.rekey > 0
        {
            let target = key_frame_of(f, frames.layout_frame, frames.rekey);
            timings.time("key frames", || {
                advance_chain(&mut chain, target, frames, key, &keep.map, &mut poser, &cameras, &params.trace)
            })?;
        }
        geometry = timings.time("geometry", || poser.geometry(frames, f, Some(geometry)))?;
        let camera = cameras.at(f, geometry.world());
        let neighbours = if params.passes.contains(&Pass::Motion) {
            timings.time("motion poses", || neighbour_frames(&mut poser, frames, &cameras, f))?
        } else {
            Neighbours::default()
        };
        let key = match (&keep.key, &chain) {
            (Some(_), Some(c)) => Some((&c.key, &c.map)),
            (Some(k), None) => Some((k, &keep.map)),
            (None, _) => None,
        };
        let out = render_frame(
            prep,
            &params,
            &keep,
            key,
            &painter,
            &geometry,
            &camera,
            &base,
            f,
            frames.measure,
            &neighbours,
            timings,
            progress,
        )?;
        emit(out)?;
    }
    progress.finish();
    Ok(FramesSummary { warnings, camera: camera_line, animations, setup })
}

/// A frame's scene in render space and its BVH.
enum Geometry<'a> {
    /// Nothing is animated: the loaded scene's own.
    Rest(&'a World, &'a Accel),
    Posed {
        frame: u32,
        world: Box<World>,
        accel: Box<Accel>,
        /// The layout frame's world with objects moved (`World::set_transforms`): its BVH has
        /// the layout frame's per-geometry BVHs, and only its top level changes.
        rigid: bool,
    },
}

impl Geometry<'_> {
    fn world(&self) -> &World {
        match self {
            Geometry::Rest(w, _) => w,
            Geometry::Posed { world, .. } => world,
        }
    }
    fn accel(&self) -> &Accel {
        match self {
            Geometry::Rest(_, a) => a,
            Geometry::Posed { accel, .. } => accel,
        }
    }
}

/// Poses the scene frame by frame: a working copy of the loaded scene, of which the clips only
/// ever change the same parts (a pose lists everything its clips move), so posing it in place
/// gives the same scene as posing the loaded one.
struct Poser<'a> {
    prep: &'a Prepared,
    clips: Vec<&'a Clip>,
    scene: Scene,
    /// The layout frame's render space, shared by every frame.
    space: Option<Similarity>,
    /// The first frame posed's world (the layout frame's): frames whose clips only move objects
    /// are this world with objects moved.
    base: Option<World>,
    fps: f64,
}

impl<'a> Poser<'a> {
    fn new(prep: &'a Prepared, clips: Vec<&'a Clip>, fps: f64) -> Poser<'a> {
        let scene = if clips.is_empty() { Scene::default() } else { prep.scene.clone() };
        Poser { prep, clips, scene, space: None, base: None, fps }
    }

    /// Frame `f`'s scene in render space, without a BVH (what the `motion` pass reads of the
    /// frames around one): as `geometry` poses it.
    fn world(&mut self, frames: &FramesParams, f: u32) -> Result<World> {
        if self.clips.is_empty() {
            return Ok(self.prep.world.clone());
        }
        let rest = &self.prep.scene;
        let rig = rest.rig.as_ref().expect("clips come from the scene's rig");
        let pose = rig.pose(&self.clips, frames.time(f), |m| &rest.meshes[m].triangles);
        animation::apply(&mut self.scene, &pose);
        let space = *self.space.get_or_insert_with(|| World::render_space(&self.scene));
        let objects_only = pose.meshes.is_empty() && pose.camera.is_none() && pose.lights.is_empty();
        if let (true, Some(base)) = (objects_only, &self.base) {
            let mut world = base.clone();
            if world.set_transforms(&self.scene, &pose.transforms)?.is_empty() {
                world.keep_backdrops_of(base);
                return Ok(world);
            }
        }
        let mut world = World::in_space(&self.scene, space);
        if let Some(base) = &self.base {
            world.keep_backdrops_of(base);
        }
        Ok(world)
    }

    /// Frame `f`'s geometry, cheapest first (ARCHITECTURE "Changing a prepared scene"):
    /// - the clips move only objects (no skin, morph, camera or light): the layout frame's
    ///   world with the objects moved, and `previous`'s BVH with its top level rebuilt;
    /// - otherwise the scene posed and flattened anew, and only the geometries whose content
    ///   changed get a BVH (`Accel::update`).
    ///
    /// Which way a frame takes, and what it gives, depends on the frame alone (the layout
    /// frame's world is the first one posed, in every run): farm chunks agree.
    fn geometry(&mut self, frames: &FramesParams, f: u32, previous: Option<Geometry<'a>>) -> Result<Geometry<'a>> {
        if self.clips.is_empty() {
            return Ok(Geometry::Rest(&self.prep.world, &self.prep.accel));
        }
        debug_assert_eq!(frames.fps, self.fps);
        if let Some(Geometry::Posed { frame, .. }) = &previous
            && *frame == f
        {
            return Ok(previous.expect("matched"));
        }
        let rest = &self.prep.scene;
        let rig = rest.rig.as_ref().expect("clips come from the scene's rig");
        let pose = rig.pose(&self.clips, frames.time(f), |m| &rest.meshes[m].triangles);
        animation::apply(&mut self.scene, &pose);
        let space = *self.space.get_or_insert_with(|| World::render_space(&self.scene));
        let objects_only = pose.meshes.is_empty() && pose.camera.is_none() && pose.lights.is_empty();
        if let (true, Some(base)) = (objects_only, &self.base) {
            let mut world = base.clone();
            // A transform too singular to carry rays into the base's space (a zero scale)
            // would give the object a geometry of its own: such a frame is posed anew.
            if world.set_transforms(&self.scene, &pose.transforms)?.is_empty() {
                world.keep_backdrops_of(base);
                let accel = match previous {
                    Some(Geometry::Posed { mut accel, rigid: true, .. }) => {
                        accel.update_instances(&world);
                        accel
                    }
                    Some(Geometry::Posed { mut accel, .. }) => {
                        accel.update(&world);
                        accel
                    }
                    _ => Box::new(Accel::new(&world)),
                };
                return Ok(Geometry::Posed { frame: f, world: Box::new(world), accel, rigid: true });
            }
        }
        let mut world = World::in_space(&self.scene, space);
        match &self.base {
            Some(base) => world.keep_backdrops_of(base),
            None => self.base = Some(world.clone()),
        }
        // Only geometries whose content changed get a BVH (`Accel::update` keys them by
        // content): the result is the same BVH as a fresh build, whatever frame came before.
        let accel = match previous {
            Some(Geometry::Posed { mut accel, .. }) => {
                accel.update(&world);
                accel
            }
            _ => Box::new(Accel::new(&world)),
        };
        Ok(Geometry::Posed { frame: f, world: Box::new(world), accel, rigid: false })
    }
}

/// The scenes and cameras of the frames before and after one (the `motion` pass reads them).
#[derive(Default)]
struct Neighbours<'a> {
    previous: Option<(World, Moved<'a>)>,
    next: Option<(World, Moved<'a>)>,
}

/// Frame `f`'s neighbours' scenes (posed, no BVH) and cameras: frame 0 has no previous one.
fn neighbour_frames<'a>(
    poser: &mut Poser<'_>,
    frames: &FramesParams,
    cameras: &Cameras<'a>,
    f: u32,
) -> Result<Neighbours<'a>> {
    let mut at = |g: u32| -> Result<(World, Moved<'a>)> {
        let world = poser.world(frames, g)?;
        let camera = cameras.at(g, &world);
        Ok((world, camera))
    };
    let previous = if f > 0 { Some(at(f - 1)?) } else { None };
    let next = if f < u32::MAX { Some(at(f + 1)?) } else { None };
    Ok(Neighbours { previous, next })
}

/// The camera of every frame: the layout frame's, moved rigidly.
struct Cameras<'a> {
    base: &'a Framed,
    /// The glTF camera at the layout frame (render space), when frames follow its animation.
    scene_camera: Option<SceneCamera>,
    orbit_rad: f64,
}

impl<'a> Cameras<'a> {
    /// The rigid motion from the layout frame's camera to frame `f`'s: the glTF camera's own
    /// motion, then the orbit about the vertical axis through the scene's centre.
    fn motion(&self, f: u32, world: &World) -> (DQuat, DVec3) {
        let (mut rotation, mut translation) = (DQuat::IDENTITY, DVec3::ZERO);
        if let (Some(a), Some(b)) = (&self.scene_camera, &world.camera)
            && (a.position, a.forward, a.up) != (b.position, b.forward, b.up)
        {
            let basis = |c: &SceneCamera| DMat3::from_cols(c.forward, c.up, c.forward.cross(c.up));
            rotation = DQuat::from_mat3(&(basis(b) * basis(a).transpose())).normalize();
            translation = b.position - rotation * a.position;
        }
        if self.orbit_rad != 0.0 {
            let orbit = DQuat::from_axis_angle(self.base.frame.up, self.orbit_rad * (f as f64 - 1.0));
            rotation = orbit * rotation;
            translation = orbit * translation;
        }
        (rotation, translation)
    }

    fn at(&self, f: u32, world: &World) -> Moved<'a> {
        let (rotation, translation) = self.motion(f, world);
        let clip_radius = (world.radius as f64).max(1e-9) * 1.001;
        Moved { inner: self.base.camera.as_ref(), rotation, translation, clip_radius }
    }
}

/// A key frame after the layout frame's (`FramesParams::rekey`): its data and facets.
struct Chained {
    frame: u32,
    key: KeyData,
    map: FacetMap,
}

/// The key frame of frame `f`: the last multiple of `every` frames from the layout frame at
/// or before `f` (after it, for frames before the layout frame).
fn key_frame_of(f: u32, layout: u32, every: u32) -> u32 {
    if f >= layout { layout + (f - layout) / every * every } else { layout - (layout - f) / every * every }
}

/// Brings `chain` to key frame `target`, stepping `every` frames at a time from where it is
/// (when on the way) or from the layout frame: each key frame's facets carried from the one
/// before it. The same steps whatever frames were rendered before: deterministic.
#[allow(clippy::too_many_arguments)]
fn advance_chain<'a>(
    chain: &mut Option<Chained>,
    target: u32,
    frames: &FramesParams,
    layout_key: &KeyData,
    layout_map: &FacetMap,
    poser: &mut Poser<'a>,
    cameras: &Cameras,
    trace: &TraceParams,
) -> Result<()> {
    let layout = frames.layout_frame;
    let on_the_way = |c: u32| (c >= layout) == (target >= layout) && c.abs_diff(layout) <= target.abs_diff(layout);
    if chain.as_ref().is_some_and(|c| !on_the_way(c.frame)) || target == layout {
        *chain = None;
    }
    loop {
        let at = chain.as_ref().map_or(layout, |c| c.frame);
        if at == target {
            return Ok(());
        }
        let next = if target > at { at + frames.rekey } else { at - frames.rekey };
        let geometry = poser.geometry(frames, next, None)?;
        let (world, accel) = (geometry.world(), geometry.accel());
        let camera = cameras.at(next, world);
        let pre = prepass(world, accel, &camera, trace);
        let carried = match chain.as_ref() {
            Some(c) => motion::carry(&c.key.key(&c.map), &pre),
            None => motion::carry(&layout_key.key(layout_map), &pre),
        };
        let key = key_of(&pre, world, &camera, trace);
        *chain = Some(Chained { frame: next, key, map: carried.map });
    }
}

/// What every frame shares, decided once at the layout frame.
struct Keep {
    faceted: bool,
    /// The layout at the frames' size (static facets use it as it is).
    map: FacetMap,
    /// The key frame facets follow from.
    key: Option<KeyData>,
    /// With facets that follow and re-aimed: the layout frame's aims, anchored to the surface
    /// points they show (`imprecision::carried` carries them to every frame).
    aims: Option<Vec<KeyAim>>,
    /// What the layout frame's picture decides for every frame (`paint::Held`: the palette's
    /// luminance mapping, the planes open across the outline, the background planes' means),
    /// so a moving subject does not change the still background's colours.
    held: Option<Held>,
    /// The composition's light centre, from the layout frame's subject.
    oval: Option<Oval>,
    /// With facets that follow: per facet id, whether it is one of the still background's
    /// (`facets::motion::still_facets`), whose planes every key frame reads off the layout.
    still: Vec<bool>,
    /// Brushwork without a key frame (static facets, or none): the layout frame's triangle
    /// corners and camera, where the strokes carried with the surfaces are hatched
    /// (`strokes::surface::LaidOn`); facets that follow hatch them on their key frame.
    laid: Option<(Vec<[Vec3; 3]>, CameraModel)>,
    /// Static facets with turned views (`--view-turn`): per facet id, the angle the layout frame
    /// turned its plane by (0: not turned). Every frame turns those planes to the same side
    /// (`imprecision::views::turn_held`), so none flips as the subject moves under it.
    turns: Option<Vec<f64>>,
}

/// One centre ray per pixel, hits only: what the saliency map, the facets' motion and the key
/// frame read of a frame.
fn prepass(world: &World, accel: &Accel, camera: &dyn Camera, trace: &TraceParams) -> Film {
    let tracer = Tracer { world, accel, rig: None, background: Vec3::ZERO, seed: trace.seed };
    let mut film = Film::new(trace.width, trace.height, 1);
    tracer.render(&mut film, &|_, p| camera.ray(p), None, None, &Progress::silent());
    film
}

/// Key data from a frame's pre-pass film.
fn key_of(film: &Film, world: &World, camera: &dyn Camera, trace: &TraceParams) -> KeyData {
    let (w, h) = (trace.width, trace.height);
    let skipped = |i: usize| {
        let (x, y) = (i as u32 % w, i as u32 / w);
        camera.ray(screen_point(x, y, DVec2::splat(0.5), w, h)).skipped
    };
    let (tri, depth) = motion::key_buffers(film, skipped);
    KeyData { width: w, height: h, tri, depth, positions: world.positions(), camera: camera.model() }
}

/// The layout (loaded, or made from the layout frame's full pre-render) and, for facets that
/// follow, the key frame: loaded beside a loaded layout when saved there, else made here.
fn key_frame(
    prep: &Prepared,
    params: &StageParams,
    frames: &FramesParams,
    geometry: &Geometry,
    cameras: &Cameras,
    painter: &Painter,
    warnings: &mut Vec<String>,
) -> Result<Keep> {
    let plan = Plan::new(params);
    let faceted = plan.faceting;
    let (world, accel) = (geometry.world(), geometry.accel());
    let camera = cameras.at(frames.layout_frame, world);
    let trace = &params.trace;
    let reads_picture = matches!(params.facets.method, FacetMethod::Segment | FacetMethod::Planes)
        && params.facets.layout_file.is_none();
    // Only Segment and Planes faceting read the picture; the other methods (and a loaded
    // layout) make their layout from their parameters, so no pre-render is traced for them.
    let film = if faceted && reads_picture {
        let rig = LightRig::new(world, &camera.frame(&cameras.base.frame), trace.shadows, trace.exposure);
        let tracer =
            Tracer { world, accel, rig: Some(&rig), background: Vec3::from(trace.background), seed: trace.seed };
        let mut film = Film::new(trace.width, trace.height, trace.spp);
        tracer.render(&mut film, &|_, p| camera.ray(p), None, None, &Progress::silent());
        if plan.saliency {
            let sal = saliency::for_film(&prep.scene, world, &prep.saliency, &film, &params.saliency)?;
            film.saliency = Some(saliency::saliency_map(world, &sal, &film, &params.saliency));
        }
        film
    } else {
        // Read by no faceting method but Segment's and Planes'.
        Film::new(1, 1, 1)
    };
    let (layout, map) = layout_stage(&params.facets, &film, &Progress::silent(), &mut Timings::default(), warnings)?;
    let follows = faceted && params.motion == FacetMotion::Follow;
    // Static facets with turned views hold the layout frame's turns.
    let holds_turns = faceted && !follows && plan.imprecision && params.aim.view_turn > 0.0;
    // The layout frame's pre-pass: its key data (facets that follow) and its aims.
    let mut pre = (follows || holds_turns).then(|| prepass(world, accel, &camera, trace));
    let key = match &pre {
        Some(pre) if follows => {
            let saved = params.facets.layout_file.as_deref().map(follow_file::path_for).filter(|p| p.is_file());
            let key = match saved {
                Some(p) => follow_file::load(&p)?,
                None => key_of(pre, world, &camera, trace),
            };
            check_key(&key, trace, world)?;
            Some(key)
        }
        _ => None,
    };
    // The layout frame's aims, decided as a still's (from its pre-pass and saliency map):
    // anchored to the scene, what facets that follow keep in every frame; with static facets,
    // the turns every frame makes. Facets that follow keep them only when this layout frame is
    // the key frame's scene: follow data saved from another pose (a single frame exported on
    // its own, `follow_frame`) leaves each frame its own aims.
    let is_key_scene = key
        .as_ref()
        .is_some_and(|k| k.positions.iter().enumerate().all(|(t, corners)| *corners == world.triangle(t as u32)));
    let ctx = aim_context(&camera, cameras.base, accel, trace);
    let layout_aims = match pre.as_mut() {
        Some(pre) if plan.imprecision && (is_key_scene || holds_turns) => {
            if params.aim.reads_saliency() {
                pre.saliency = Some(frame_saliency(prep, world, pre, params)?);
            }
            let silent = Progress::silent();
            Some(aims_stage(&ctx, &map, pre, &params.aim, None, None, &silent, &mut Timings::default()).0)
        }
        _ => None,
    };
    let aims = layout_aims.as_deref().filter(|_| is_key_scene).map(|a| carried::anchor_aims(&ctx, a));
    let turns = layout_aims
        .as_deref()
        .filter(|_| holds_turns)
        .map(|a| a.iter().map(|a| a.turn.map_or(0.0, |t| t.angle)).collect());
    if let Some(path) = &params.save_facets {
        facets::io::save(path, &layout, &map)?;
        if let Some(key) = &key {
            follow_file::save(&follow_file::path_for(path), key)?;
        }
    }
    // The composition's light centre, from the layout frame's centre rays (a layout loaded or
    // made here agrees): held still across the sequence.
    let oval = plan.paint.then(|| {
        let made = if pre.is_none() { Some(prepass(world, accel, &camera, trace)) } else { None };
        let hits = &pre.as_ref().or(made.as_ref()).expect("one of the two is traced").hits;
        Oval::of(trace.width as usize, trace.height as usize, hits)
    });
    // What the frames hold from the layout frame's picture (traced lit here when the layout
    // did not need it), painted by the effects before the palette and the brushwork.
    let held = if plan.paint {
        let view = camera.frame(&cameras.base.frame);
        let rig = LightRig::new(world, &view, trace.shadows, trace.exposure);
        let lit = if film.width == trace.width && film.height == trace.height {
            film
        } else {
            let tracer =
                Tracer { world, accel, rig: Some(&rig), background: Vec3::from(trace.background), seed: trace.seed };
            // The samples the layout's pre-render takes: a layout loaded or made here maps alike.
            let mut lit = Film::new(trace.width, trace.height, trace.spp);
            tracer.render(&mut lit, &|_, p| camera.ray(p), None, None, &Progress::silent());
            lit
        };
        let axes = ViewAxes { right: view.right.as_vec3(), up: view.up.as_vec3(), forward: view.forward.as_vec3() };
        let lighting = Lighting { world, rig: &rig, view: axes };
        let sequence = Sequence { planes_from: faceted.then_some(&map), oval, ..Sequence::default() };
        Some(painter.hold(&lit, faceted.then_some(&map), Some(&lighting), &sequence)?)
    } else {
        None
    };
    let still = key.as_ref().map_or_else(Vec::new, |k| motion::still_facets(&k.key(&map)));
    let laid =
        (key.is_none() && plan.paint && params.paint.brushwork.is_on()).then(|| (world.positions(), camera.model()));
    Ok(Keep { faceted, map, key, aims, held, oval, still, laid, turns })
}

/// A key frame must match the frames it is carried to: same picture size, same triangles.
pub fn check_key(key: &KeyData, trace: &TraceParams, world: &World) -> Result<()> {
    if (key.width, key.height) != (trace.width, trace.height) {
        return Err(Error::setting(
            "facets",
            format!(
                "the follow data is {}x{}, this render {}x{}: facets follow at the layout frame's size",
                key.width, key.height, trace.width, trace.height
            ),
        ));
    }
    if key.positions.len() != world.triangle_count() {
        return Err(Error::setting(
            "facets",
            format!(
                "the layout frame had {} triangles, this frame has {}: facets follow the same meshes from frame to frame",
                key.positions.len(),
                world.triangle_count()
            ),
        ));
    }
    Ok(())
}

/// The saliency map of a frame off its pre-pass (mesh saliency once per mesh content).
fn frame_saliency(prep: &Prepared, world: &World, pre: &Film, params: &StageParams) -> Result<Vec<f32>> {
    let sal = saliency::for_film(&prep.scene, world, &prep.saliency, pre, &params.saliency)?;
    Ok(saliency::saliency_map(world, &sal, pre, &params.saliency))
}

/// A frame's camera as the imprecision stage sees it.
fn aim_context<'a>(camera: &'a Moved, base: &Framed, accel: &'a Accel, trace: &TraceParams) -> AimContext<'a> {
    let up = camera.frame(&base.frame).up;
    AimContext { camera, accel, width: trace.width, height: trace.height, clip_radius: camera.clip_radius, up }
}

/// One frame, through the still pipeline's stages: its pre-pass (hits only: the saliency map
/// and the facets' motion read it), the facets (static, or carried from the key frame), the
/// aims (decided from this frame's pixels as a still's are, or, for facets that follow, the key
/// frame's carried with the scene: `imprecision::carried`), then one centre sample per pixel
/// through its facet's rays (`retrace_stage` over every pixel, with sparse shadow rays) and
/// the adaptive anti-aliasing (`antialias_stage`: `spp` samples only where facet neighbours
/// disagree).
#[allow(clippy::too_many_arguments)]
fn render_frame(
    prep: &Prepared,
    params: &StageParams,
    keep: &Keep,
    key: Option<(&KeyData, &FacetMap)>,
    painter: &Painter,
    geometry: &Geometry,
    camera: &Moved,
    base: &Framed,
    frame: u32,
    measure: bool,
    neighbours: &Neighbours,
    mut timings: Timings,
    progress: &Progress,
) -> Result<FrameOutput> {
    let (world, accel) = (geometry.world(), geometry.accel());
    let trace = &params.trace;
    let plan = Plan::new(params);
    let mut pre = timings.time("pre-pass", || prepass(world, accel, camera, trace));

    let carried_aims = keep.aims.as_deref().filter(|_| plan.imprecision);
    let wants_map = params.passes.contains(&Pass::Saliency) || params.passes.contains(&Pass::Facets);
    let reads_saliency = plan.imprecision && params.aim.reads_saliency() && carried_aims.is_none();
    if reads_saliency || wants_map {
        let map = timings.time(Stage::Saliency.name(), || frame_saliency(prep, world, &pre, params))?;
        pre.saliency = Some(map);
    }

    let (map, revealed, plane_shift, at_key, ground) = match key {
        Some((key, key_map)) => {
            let carried = timings.time("facet motion", || motion::carry(&key.key(key_map), &pre));
            (carried.map, Some(carried.revealed), Some(carried.shift), Some(carried.at_key), Some(carried.ground))
        }
        None => (keep.map.clone(), None, None, None, None),
    };
    // The planes (their light ramps, the strokes' directions): the key frame's, moved with
    // their facets when facets follow; the layout's, still, when they do not.
    let planes_from = key.map_or(&keep.map, |(_, key_map)| key_map);
    if keep.faceted && params.aim.neighborhood > 0.0 && pre.saliency.is_some() {
        imprecision::check_neighbourhood(&map, params.aim.neighbourhood_px())?;
    }

    let ctx = aim_context(camera, base, accel, trace);
    let silent = Progress::silent();
    let aims: Vec<FacetAim> = match carried_aims {
        Some(key_aims) => timings.time(Stage::Imprecision.name(), || {
            let corners = |t: u32| ((t as usize) < world.triangle_count()).then(|| world.triangle(t));
            carried::carry_aims(&ctx, key_aims, &map, &corners, &params.aim)
        }),
        // With static facets, turned as the layout frame turned them (`Keep::turns`).
        None if plan.imprecision => {
            aims_stage(&ctx, &map, &pre, &params.aim, None, keep.turns.as_deref(), &silent, &mut timings).0
        }
        None => Vec::new(),
    };

    let view = camera.frame(&base.frame);
    let rig = LightRig::new(world, &view, trace.shadows, trace.exposure);
    let tracer = Tracer { world, accel, rig: Some(&rig), background: Vec3::from(trace.background), seed: trace.seed };
    let mut film = Film::new(trace.width, trace.height, 1);
    retrace_stage(&tracer, &ctx, &map, &aims, None, None, &mut film, Retracing::InPlace, progress, &mut timings);
    if plan.antialiasing {
        antialias_stage(&tracer, &ctx, trace, &map, &aims, &mut film, Refining::InPlace, &silent, &mut timings);
    }
    film.saliency = pre.saliency.take();

    if plan.paint {
        let axes = ViewAxes { right: view.right.as_vec3(), up: view.up.as_vec3(), forward: view.forward.as_vec3() };
        let lighting = Lighting { world, rig: &rig, view: axes };
        // Strokes on the surfaces, fading over a stroke's width at occlusion edges.
        let fade_px = ((params.paint.brushwork.width * params.paint.brushwork.scale) as f32).max(2.0);
        let facets = keep.faceted.then_some(&map);
        let (w, h) = (trace.width as usize, trace.height as usize);
        let hits = film.hits.clone();
        // Hatched on the key frame's picture (facets that follow), else on the layout frame's.
        let laid_on = match key {
            Some((k, _)) => Some(LaidOn { positions: &k.positions, camera: &k.camera }),
            None => keep.laid.as_ref().map(|(positions, camera)| LaidOn { positions, camera }),
        };
        // The still ground's facets under the subject: the layout's (static facets) or those
        // carried from the key frame's ground.
        let ground = keep.faceted.then(|| ground.as_deref().unwrap_or(&keep.map.ids));
        let seeds = timings.time("stroke seeds", || {
            SurfaceSeeds::new(&hits, w, h, world, camera, facets, fade_px, laid_on).with_ground(ground)
        });
        let sequence = Sequence {
            held: keep.held.as_ref(),
            planes_from: keep.faceted.then_some(planes_from),
            plane_shift: plane_shift.as_deref(),
            at_key: at_key.as_deref(),
            still_planes: key
                .filter(|(_, key_map)| !std::ptr::eq(*key_map, &keep.map))
                .map(|_| (&keep.map, &keep.still[..])),
            seeds: Some(&seeds),
            oval: keep.oval,
        };
        paint_stage(painter, &mut film, facets, Some(&lighting), Painting::Sequence(&sequence), &mut timings)?;
    }
    let motion = params.passes.contains(&Pass::Motion).then(|| {
        timings.time("motion", || {
            use crate::motion::FrameView;
            let this = FrameView { world, camera };
            let prev_view = neighbours.previous.as_ref().map(|(w, c)| FrameView { world: w, camera: c as &dyn Camera });
            let next_view = neighbours.next.as_ref().map(|(w, c)| FrameView { world: w, camera: c as &dyn Camera });
            let v = crate::motion::motion_vectors(
                &film.hits,
                trace.width,
                trace.height,
                &this,
                prev_view.as_ref(),
                next_view.as_ref(),
            );
            crate::motion::motion_pass(&v, trace.width, trace.height)
        })
    });
    let Encoded { image, passes, passes16 } = encode_stage(&film, &map, &aims, params, &mut timings);
    let surface = measure.then(|| FrameSurface::new(key_of(&pre, world, camera, trace), &pre));
    Ok(FrameOutput { frame, image, passes, passes16, facets: map, timings, revealed, surface, motion })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_turntable_gets_a_key_frame_every_thirty_degrees() {
        assert_eq!(FramesParams::turntable_rekey(0.0), 0);
        assert_eq!(FramesParams::turntable_rekey(2.0), 15);
        assert_eq!(FramesParams::turntable_rekey(-2.0), 15);
        assert_eq!(FramesParams::turntable_rekey(7.0), 4);
        assert_eq!(FramesParams::turntable_rekey(45.0), 1);
        assert_eq!(FramesParams::turntable_rekey(1e-9), MAX_FRAMES);
        assert_eq!(FramesParams::turntable_rekey(f64::NAN), 0);
    }

    #[test]
    fn key_frames_fall_every_n_frames_from_the_layout_frame_both_ways() {
        assert_eq!((1..=7).map(|f| key_frame_of(f, 1, 3)).collect::<Vec<_>>(), [1, 1, 1, 4, 4, 4, 7]);
        assert_eq!((1..=5).map(|f| key_frame_of(f, 5, 2)).collect::<Vec<_>>(), [1, 3, 3, 5, 5]);
    }
}
