"""The Cubist viewport (issue 14): a 3D view in Rendered shading shows the cubist render of
what it sees, through the scene camera when it looks through it, from the view otherwise.

One `ViewportSession` per 3D view (per viewport engine instance), each with its own
`cubist serve` process (serve_client.py), which keeps the scene, BVH, saliency and every
stage's output between requests, so a panel change re-runs only the stages it reaches.

Threads (Blender's API is used on the main thread only):
- main thread, `view_update` (the depsgraph changed: a panel value, an object, a material):
  when more than the scene's own settings changed, the scene's data is read from the
  depsgraph (`export.read_scene`: the meshes' arrays, materials, images; nothing built), the
  settings are made from the panel (mapping.py), and a job is handed to the session;
  `view_draw` (every redraw): a new job when the view moved, then the latest image drawn with
  the `gpu` module (errors as text, with `blf`);
- a worker thread per session: writes the job's scene file first when it was not written
  (the glTF arrays are made there: triangles, welding, the buffer; a newer scene read
  meanwhile stops it), then renders the latest job progressively, 1/4, 1/2 then full
  resolution, each a request to the server; a newer job cancels the running request;
- a timer on the main thread (`bpy.app.timers`) tags the 3D views for redraw when a worker has
  a new image (`tag_redraw`, the way the image reaches the screen) and ends the sessions whose
  view left Rendered shading.

A session ends (its server with it) when its view leaves Rendered shading (the engine is freed,
or the timer sees it), a file is loaded, Blender quits or the add-on is disabled. F12 and
Render Animation render through a session's server when the scene they exported is the one the
session holds (`server_for`): the server then keeps its scene, BVH and saliency.
"""

from __future__ import annotations

import atexit
import hashlib
import json
import os
import shutil
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional

import numpy as np

import bpy

from . import export, mapping, preferences, runner
from .serve_client import ServeClient, read_rgba

# The progressive passes, as fractions of the view's size; passes whose image would be
# smaller than MIN_SIDE pixels are skipped.
PASSES = (0.25, 0.5, 1.0)
MIN_SIDE = 16
# The viewport server's CPU priority below Blender's (POSIX nice): the interface comes first.
NICE = 5
# How often the main-thread timer looks for new images (seconds).
TICK = 0.05
# A session never drawn this long after it started is ended by the timer (its view went
# away before drawing, without its engine being freed yet).
FORGOTTEN_AFTER = 30.0

# Every open session, for the timer, `server_for` and closing them all.
_sessions: set = set()
_sessions_lock = threading.Lock()
# Servers being ended by a thread of their own (a session closed without waiting): thread ->
# client. Blender's exit waits for them, or they would be cut short with the interpreter (their
# threads are daemons) and leave their folder behind.
_closing: dict = {}
# Tests: every drawn frame's facts (image size and scale, rect, readback) when on.
record_draws = False


@dataclass(frozen=True)
class View:
    """What a viewport shows, as plain values (tests make one without a window): the size of
    the image and where it goes in the region (x, y from the bottom left), and the camera."""

    width: int
    height: int
    camera: Optional[mapping.CameraFacts]
    x: int = 0
    y: int = 0
    through_camera: bool = False


@dataclass
class SceneExport:
    """A scene read from the depsgraph on the main thread (`export.read_scene`), written to
    the session's scene file by its worker thread before the first request that needs it."""

    number: int
    exporter: Optional[export.Exporter]
    written: bool = False
    error: Optional[str] = None


@dataclass
class Job:
    generation: int
    scene: Path
    settings: dict  # at the view's full size
    view: View
    export: Optional[SceneExport] = None


@dataclass
class Image:
    generation: int
    scale: float
    pixels: np.ndarray  # (height, width, 4) uint8, top row first
    view: View
    seconds: float
    reply: dict = field(default_factory=dict)

    @property
    def width(self) -> int:
        return int(self.pixels.shape[1])

    @property
    def height(self) -> int:
        return int(self.pixels.shape[0])


def scaled(settings: dict, scale: float) -> dict:
    """The settings of a progressive pass: the size scaled (pixel-valued settings scale with
    it in the renderer), one sample per pixel below full size."""
    if scale >= 1.0:
        return dict(settings)
    s = dict(settings)
    s["width"] = max(1, round(settings["width"] * scale))
    s["height"] = max(1, round(settings["height"] * scale))
    s["spp"] = 1
    return s


def passes_for(width: int, height: int) -> list:
    """The passes a view of this size gets (always the full one)."""
    return [f for f in PASSES if f >= 1.0 or min(width, height) * f >= MIN_SIDE]


class ViewportSession:
    """One viewport's server, its worker thread and its latest image."""

    def __init__(self, binary: Path):
        self.client = ServeClient(binary, nice=NICE)
        self.cond = threading.Condition()
        self.generation = 0
        self.job: Optional[Job] = None
        self.running: Optional[int] = None  # the request id in flight
        self.image: Optional[Image] = None
        self.image_new = False
        self.error: Optional[str] = None
        self.status = ""
        self.closed = False
        self.scene_path = self.client.workspace / "scene.glb"
        self.scene_hash: Optional[str] = None  # of the scene file written last (server_for)
        self.export: Optional[SceneExport] = None  # the newest scene read
        self.meshes_read: dict = {}  # its meshes' arrays, for the next read (export.read_scene)
        self.export_warnings: list = []
        self.signature = None
        self.area: Optional[int] = None  # the 3D view's area, as_pointer()
        self.created = time.monotonic()
        self.last_draw: Optional[float] = None
        self.texture = None  # (image generation, scale, GPUTexture)
        # Diagnostics for the panel and the tests.
        self.counts = {"jobs": 0, "requests": 0, "images": 0, "cancelled": 0, "errors": 0, "exports": 0,
                       "draws": 0, "uploads": 0}
        self.history: list = []  # (generation, scale, seconds, reused) per image, the newest last
        self.main_thread: dict = {}  # the longest view_update and view_draw, seconds
        self.worker_times: dict = {}  # the longest scene write on the worker, seconds
        self.draws: list = []
        self.thread = threading.Thread(target=self._work, name="cubist-viewport", daemon=True)
        self.thread.start()
        with _sessions_lock:
            _sessions.add(self)
        _ensure_timer()

    # ------------------------------------------------------------------ main thread

    def submit(self, scene: Path, settings: dict, view: View, scene_export: Optional[SceneExport] = None) -> int:
        """Makes (scene, settings, view) the job to render, cancelling the request in flight;
        `scene_export`: what the worker writes to `scene` first, unless it was written."""
        with self.cond:
            self.generation += 1
            self.job = Job(self.generation, scene, settings, view, scene_export)
            running, self.running = self.running, None
            self.counts["jobs"] += 1
            self.status = "rendering"
            self.cond.notify_all()
        if running is not None:
            self.client.cancel(running)
        return self.generation

    def take_image(self) -> Optional[Image]:
        with self.cond:
            self.image_new = False
            return self.image

    def close(self, wait: bool = False) -> None:
        """Ends the worker and the server (without waiting, unless `wait`: the interface must
        not stall on it)."""
        with self.cond:
            if self.closed:
                return
            self.closed = True
            self.cond.notify_all()
        with _sessions_lock:
            _sessions.discard(self)
        if wait:
            self.client.close(timeout=2.0)
        else:
            closer = threading.Thread(target=_close_client, args=(self.client,), name="cubist-viewport-close",
                                      daemon=True)
            with _sessions_lock:
                _closing[closer] = self.client
            closer.start()

    # ------------------------------------------------------------------ worker thread

    def _newer(self, job: Job) -> bool:
        return self.closed or self.job is None or self.job.generation != job.generation

    def _work(self) -> None:
        done = 0
        while True:
            with self.cond:
                while not self.closed and (self.job is None or self.job.generation == done):
                    self.cond.wait()
                if self.closed:
                    return
                job = self.job
            done = job.generation
            try:
                self._render(job)
            except Exception as e:  # a bug of ours: shown in the view, never raised into Blender
                with self.cond:
                    self.error = f"internal error: {type(e).__name__}: {e}"
                    self.image_new = True

    def _write_scene(self, job: Job) -> bool:
        """Writes the job's scene (read on the main thread) to the scene file, unless it was
        written: the glTF arrays are made here, off Blender's main thread. Stops, False, when a
        newer scene was read meanwhile (its job writes that one); False with the error set when
        the export failed."""
        ex = job.export
        if ex is None or ex.written:
            return True
        if ex.error is None:
            def superseded() -> bool:
                current = self.job
                return self.closed or current is None or current.export is not ex

            with self.cond:
                self.status = "exporting"
            tmp = self.scene_path.with_name("scene.tmp.glb")
            try:
                t0 = time.perf_counter()
                ex.exporter.write(tmp, superseded)
                # Atomically: the server may be reading the previous one (F12 on this server).
                os.replace(tmp, self.scene_path)
                h = file_hash(self.scene_path)
            except export.ExportCancelled:
                return False
            except Exception as e:  # a full disk, a bug of ours: shown in the view
                ex.error = f"export failed: {type(e).__name__}: {e}"
            else:
                with self.cond:
                    ex.written, ex.exporter = True, None
                    self.scene_hash = h
                    self.worker_times["longest_scene_write"] = max(self.worker_times.get("longest_scene_write", 0.0),
                                                                   time.perf_counter() - t0)
                return True
            ex.exporter = None
        with self.cond:
            if not self._newer(job):
                self.error, self.status, self.image_new = ex.error, "", True
        return False

    def _render(self, job: Job) -> None:
        if not self._write_scene(job):
            return
        w, h = job.settings["width"], job.settings["height"]
        for scale in passes_for(w, h):
            settings = scaled(job.settings, scale)
            out = self.client.workspace / f"view_{int(scale * 100)}.rgba"
            with self.cond:
                if self._newer(job):
                    return
                # Sent under the lock: a job submitted meanwhile sees this request and cancels it.
                pending = self.client.render_request(settings, out, scene=job.scene)
                self.running = pending.id
                self.counts["requests"] += 1
                self.status = f"rendering {settings['width']}x{settings['height']}"
            t0 = time.monotonic()
            reply = pending.wait()
            with self.cond:
                if self.running == pending.id:
                    self.running = None
            if not reply.get("ok"):
                with self.cond:
                    if reply.get("cancelled"):
                        self.counts["cancelled"] += 1
                    else:
                        self.counts["errors"] += 1
                        self.error = str(reply.get("error"))
                        self.status = ""
                        self.image_new = True
                return
            pixels = read_rgba(out, reply["width"], reply["height"])
            with self.cond:
                self.image = Image(job.generation, scale, pixels, job.view, time.monotonic() - t0, reply)
                self.image_new = True
                self.error = None
                self.counts["images"] += 1
                self.history.append((job.generation, scale, reply["timings"].get("total"), reply.get("reused")))
                del self.history[:-200]
                if scale >= 1.0:
                    self.status = ""


def _close_client(client: ServeClient) -> None:
    try:
        client.close()
    finally:
        with _sessions_lock:
            _closing.pop(threading.current_thread(), None)


# ---------------------------------------------------------------------------------------------
# Scene, settings and view (main thread)


def export_scene(session: ViewportSession, depsgraph, keep_meshes: bool = False) -> bool:
    """Reads the depsgraph's scene (its meshes' arrays: only the main thread may read them)
    for the session's worker, which makes the glTF from them and writes it before rendering;
    False, with the session's error set, when there is nothing to render. `keep_meshes`: no
    mesh's data changed since the last read (objects moved, lights, materials): the meshes'
    arrays read then are used again."""
    if not export.has_geometry(depsgraph):
        session.error = f"scene '{depsgraph.scene_eval.name}' has nothing to render: add a mesh"
        return False
    exporter = export.read_scene(depsgraph, mesh_cache=session.meshes_read if keep_meshes else None)
    session.meshes_read = exporter.meshes_read
    session.counts["meshes_reused"] = session.counts.get("meshes_reused", 0) + exporter.stats.meshes_reused
    exporter.depsgraph = None  # the worker must not touch Blender's data
    number = session.export.number + 1 if session.export is not None else 1
    session.export = SceneExport(number, exporter)
    session.export_warnings = list(exporter.stats.warnings)
    session.counts["exports"] += 1
    return True


def file_hash(path: Path) -> str:
    h = hashlib.blake2b(digest_size=16)
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def view_camera_facts(view_matrix, is_perspective: bool, lens: float, view_distance: float) -> mapping.CameraFacts:
    """The view of a 3D viewport not looking through a camera, as a camera: its inverse view
    matrix, and the projection Blender draws it with (BKE_camera_params_from_view3d: a 36 mm
    sensor at twice the zoom, so 72 mm; orthographic views span 2 x distance x 36 / lens)."""
    m = [list(r) for r in view_matrix.inverted()]
    if is_perspective:
        return mapping.CameraFacts(matrix_world=m, type="PERSP", lens=lens, sensor_width=72.0, sensor_height=48.0)
    return mapping.CameraFacts(matrix_world=m, type="ORTHO", ortho_scale=2.0 * view_distance * 36.0 / lens)


def camera_rect(scene, cam, region, region_3d) -> Optional[tuple]:
    """The scene camera's frame in the region (x, y, width, height), as drawn in camera view."""
    from bpy_extras.view3d_utils import location_3d_to_region_2d

    corners = [cam.matrix_world @ v for v in cam.data.view_frame(scene=scene)]
    pts = [location_3d_to_region_2d(region, region_3d, c) for c in corners]
    if any(p is None for p in pts):
        return None
    xs, ys = [p.x for p in pts], [p.y for p in pts]
    x0, y0 = min(xs), min(ys)
    return x0, y0, max(xs) - x0, max(ys) - y0


def view_of(context, depsgraph) -> Optional[View]:
    """The View of the 3D view being drawn (None when its camera frame is off screen)."""
    region, r3d, space = context.region, context.region_data, context.space_data
    scene = depsgraph.scene_eval
    if r3d.view_perspective == "CAMERA" and scene.camera is not None:
        cam = export.scene_camera(depsgraph)
        rect = camera_rect(scene, cam, region, r3d)
        if rect is None or rect[2] < 2 or rect[3] < 2:
            return None
        r = scene.render
        rw, rh = mapping.render_size(r.resolution_x, r.resolution_y, r.resolution_percentage)
        # The render's aspect, at the frame's size on screen (at most the render's size).
        w = max(1, min(rw, round(rect[2])))
        h = max(1, round(w * rh / rw))
        return View(w, h, export.camera_facts(cam), round(rect[0]), round(rect[1]), True)
    facts = view_camera_facts(r3d.view_matrix, r3d.is_perspective, space.lens, r3d.view_distance)
    return View(region.width, region.height, facts)


def settings_for(scene, view: View) -> dict:
    """The settings of a view of `scene` (its panel, its world), at the view's size."""
    facts = mapping.SceneFacts(width=view.width, height=view.height, frame=scene.frame_current, camera=view.camera,
                               background=export.world_background(scene.world),
                               transparent=scene.render.film_transparent)
    settings = mapping.settings_from_panel(preferences.panel(scene.cubist), facts)
    settings["passes"] = []  # the view shows the picture only
    settings.pop("save_facets", None)
    return settings


def update(session: ViewportSession, depsgraph, view: Optional[View], content_changed: bool,
           keep_meshes: bool = False) -> bool:
    """Exports the scene if its content changed (or was never exported), then hands the job
    for `view` to the session unless it is the one it has. True when a job was submitted.
    `keep_meshes`: no mesh's data changed since the last export (export_scene)."""
    if content_changed or session.export is None:
        session.error = None
        try:
            if not export_scene(session, depsgraph, keep_meshes):
                return False
        except export.ExportCancelled:
            return False
    if view is None:
        return False
    # The panel's values as set now (the original scene: a property set from Python reaches the
    # evaluated copy only at the next evaluation).
    scene = depsgraph.scene
    try:
        settings = settings_for(scene, view)
    except runner.CubistError as e:
        session.error = str(e)
        session.signature = None
        return False
    signature = (session.export.number, json.dumps(settings, sort_keys=True), view)
    if signature == session.signature:
        return False
    session.signature = signature
    session.error = None
    session.submit(session.scene_path, settings, view, session.export)
    return True


def content_changed(depsgraph) -> bool:
    """Whether an update reached more than the scene datablock itself (the panel's values and
    the render settings live on the scene; they need no new export)."""
    for u in depsgraph.updates:
        if not isinstance(u.id, bpy.types.Scene):
            return True
    return False


def geometry_changed(depsgraph) -> bool:
    """Whether an update reached a mesh's data (its evaluated geometry was made again: edits,
    modifiers, a frame change of animated geometry): the meshes must be read again. Objects
    moved, lights, materials and the scene's settings leave the evaluated meshes as they were."""
    return any(u.is_updated_geometry for u in depsgraph.updates)


# ---------------------------------------------------------------------------------------------
# The engine's viewport methods (engine.py calls these)


def _binary() -> Path:
    prefs = preferences.addon_preferences()
    pref_path = bpy.path.abspath(prefs.binary_path) if prefs is not None and prefs.binary_path else ""
    return runner.find_binary(pref_path)


# Each viewport engine's session (or the error that kept it from starting), by id(engine):
# the engine's `__del__` runs once Blender has freed its data, when its attributes can no
# longer be read, but its id is still its own.
_by_engine: dict = {}


def session_of(engine, create: bool) -> Optional[ViewportSession]:
    session = _by_engine.get(id(engine))
    if isinstance(session, ViewportSession) and not session.closed:
        return session
    if not create:
        return None
    try:
        session = ViewportSession(_binary())
    except runner.CubistError as e:
        _by_engine[id(engine)] = str(e)
        return None
    _by_engine[id(engine)] = session
    return session


def view_update(engine, context, depsgraph) -> None:
    t0 = time.perf_counter()
    session = session_of(engine, create=True)
    if session is None:
        return
    changed = content_changed(depsgraph)
    keep_meshes = changed and not geometry_changed(depsgraph)
    update(session, depsgraph, view_of(context, depsgraph), changed, keep_meshes=keep_meshes)
    _main_thread_time(session, "view_update", t0)


def _main_thread_time(session: ViewportSession, what: str, t0: float) -> None:
    """The longest time a view_update or view_draw held the main thread (the panel, tests)."""
    dt = time.perf_counter() - t0
    key = f"longest_{what}"
    session.main_thread[key] = max(session.main_thread.get(key, 0.0), dt)


def view_draw(engine, context, depsgraph) -> None:
    t0 = time.perf_counter()
    session = session_of(engine, create=False)
    region = context.region
    if session is None:
        message = _by_engine.get(id(engine))
        if isinstance(message, str):
            draw_text(region, [f"Cubist: {message}"])
        return
    session.area = context.area.as_pointer() if context.area is not None else None
    session.last_draw = time.monotonic()
    view = view_of(context, depsgraph)
    update(session, depsgraph, view, False)  # the view moved: a new job
    image = session.take_image()
    if image is not None:
        target = view or image.view
        draw_image(session, image, target.x, target.y, target.width, target.height)
    lines = []
    if session.error:
        lines.append(f"Cubist: {session.error}")
    elif session.status:
        lines.append(f"Cubist: {session.status}")
    if lines:
        draw_text(region, lines)
    session.counts["draws"] += 1
    _main_thread_time(session, "view_draw", t0)


def free(engine_id: int) -> None:
    """The viewport engine `id(engine)` is freed (its view left Rendered shading, or F12's
    engine ended): its session, if it has one, ends."""
    session = _by_engine.pop(engine_id, None)
    if isinstance(session, ViewportSession):
        session.close()


# ---------------------------------------------------------------------------------------------
# Drawing (main thread, in view_draw: Blender's GPU context)


def gpu_pixels(pixels: np.ndarray) -> np.ndarray:
    """8-bit RGBA rows, top row first, as the GPU texture's data: float, rows bottom-up,
    alpha premultiplied (the ALPHA_PREMULT blend)."""
    px = pixels[::-1].astype(np.float32) / 255.0
    px[..., :3] *= px[..., 3:4]
    return np.ascontiguousarray(px).reshape(-1)


def texture_of(session: ViewportSession, image: Image):
    """The image as a GPU texture, uploaded once per image."""
    import gpu

    key = (image.generation, image.scale, id(image.pixels))
    if session.texture is not None and session.texture[0] == key:
        return session.texture[1]
    flat = gpu_pixels(image.pixels)
    buf = gpu.types.Buffer("FLOAT", flat.size, flat)
    tex = gpu.types.GPUTexture((image.width, image.height), format="RGBA16F", data=buf)
    session.texture = (key, tex)
    session.counts["uploads"] += 1
    return tex


def draw_image(session: ViewportSession, image: Image, x: int, y: int, width: int, height: int) -> None:
    """Draws the image over (x, y, width, height) of the region. The picture's own sRGB colours
    are drawn as they are: the painting as F12 shows it with the Standard view transform (which
    the add-on sets, docs/blender.md "Colours")."""
    import gpu
    from gpu_extras.presets import draw_texture_2d

    tex = texture_of(session, image)
    gpu.state.blend_set("ALPHA_PREMULT")
    draw_texture_2d(tex, (x, y), width, height)
    gpu.state.blend_set("NONE")
    if record_draws:
        entry = {"generation": image.generation, "scale": image.scale, "image": [image.width, image.height],
                 "rect": [x, y, width, height]}
        try:
            fb = gpu.state.active_framebuffer_get()
            cx, cy = x + width // 2, y + height // 2
            entry["centre"] = [cx, cy]
            entry["readback"] = [float(v) for v in fb.read_color(cx, cy, 1, 1, 4, 0, "FLOAT").to_list()[0][0]]
        except Exception as e:  # readback is a test aid only
            entry["readback_error"] = f"{type(e).__name__}: {e}"
        session.draws.append(entry)
        del session.draws[:-100]


def draw_text(region, lines: list) -> None:
    import blf

    font = 0
    try:
        blf.size(font, 13)
    except TypeError:  # Blender 3.x: blf.size(fontid, size, dpi)
        blf.size(font, 13, 72)
    blf.color(font, 1.0, 1.0, 1.0, 1.0)
    y = 12
    for line in reversed(lines):
        for chunk in _wrap(line, max(20, region.width // 8)):
            blf.position(font, 12, y, 0)
            blf.draw(font, chunk)
            y += 18


def _wrap(text: str, width: int) -> list:
    words, out, cur = text.split(), [], ""
    for w in words:
        if cur and len(cur) + 1 + len(w) > width:
            out.append(cur)
            cur = w
        else:
            cur = f"{cur} {w}" if cur else w
    if cur:
        out.append(cur)
    return list(reversed(out))


# ---------------------------------------------------------------------------------------------
# The timer, F12's reuse, closing


def _rendered_areas() -> set:
    out = set()
    wm = bpy.context.window_manager
    if wm is None:
        return out
    for window in wm.windows:
        if window.scene is None or window.scene.render.engine != "CUBIST":
            continue
        for area in window.screen.areas:
            if area.type == "VIEW_3D":
                space = area.spaces.active
                if getattr(space, "shading", None) is not None and space.shading.type == "RENDERED":
                    out.add(area.as_pointer())
    return out


def _tick():
    with _sessions_lock:
        sessions = list(_sessions)
    if not sessions:
        return None  # the timer ends; the next session starts it again
    try:
        rendered = _rendered_areas()
    except Exception:
        return TICK
    redraw = set()
    now = time.monotonic()
    for s in sessions:
        never_drawn = s.last_draw is None and now - s.created > FORGOTTEN_AFTER
        if (s.area is not None and s.area not in rendered) or never_drawn:
            s.close()
        elif s.image_new:
            redraw.add(s.area)
    if redraw:
        _redraw_views(redraw)
    return TICK


def _redraw_views(areas: set) -> None:
    """Tags for redraw the 3D views of `areas` (as_pointer()) only: every redraw of a view costs
    Blender's main thread a whole draw of it (0.1-0.9 s under Xvfb's software OpenGL on a loaded
    2-core machine, docs/blender.md), so views in Solid shading and views with nothing new are
    left alone. None in `areas`: a session not drawn yet, whose area is unknown; all 3D views."""
    for window in bpy.context.window_manager.windows:
        for area in window.screen.areas:
            if area.type == "VIEW_3D" and (None in areas or area.as_pointer() in areas):
                area.tag_redraw()


def _ensure_timer() -> None:
    if not bpy.app.timers.is_registered(_tick):
        bpy.app.timers.register(_tick, first_interval=TICK, persistent=True)


def server_for(glb: Path) -> Optional[ServeClient]:
    """A running viewport server whose scene is the one in `glb` (the same bytes), for F12 and
    Render Animation (any thread); None when there is none."""
    with _sessions_lock:
        sessions = [s for s in _sessions if not s.closed and s.scene_hash is not None and s.client.alive()]
    if not sessions:
        return None
    try:
        h = file_hash(glb)
    except OSError:
        return None
    return next((s.client for s in sessions if s.scene_hash == h), None)


def close_all(wait: bool = False) -> None:
    with _sessions_lock:
        sessions = list(_sessions)
    for s in sessions:
        s.close(wait=wait)
    _by_engine.clear()


@bpy.app.handlers.persistent
def _file_loading(*_args):
    close_all()


def end_all():
    """Every server ends and its folder goes, also those being ended by a thread of their own
    (a view's engine freed a moment before: Blender quitting frees them first)."""
    close_all(wait=True)
    with _sessions_lock:
        closing = list(_closing.items())
    for closer, client in closing:
        closer.join(timeout=3.0)
        shutil.rmtree(client.workspace, ignore_errors=True)


def register():
    bpy.app.handlers.load_pre.append(_file_loading)
    atexit.register(end_all)


def unregister():
    """Also what Blender does at quit: Ctrl+Q disables every add-on (`addon_utils.disable_all`)
    before Python's exit handlers run, so unregistering is where servers and folders go."""
    if _file_loading in bpy.app.handlers.load_pre:
        bpy.app.handlers.load_pre.remove(_file_loading)
    atexit.unregister(end_all)
    end_all()
    if bpy.app.timers.is_registered(_tick):
        bpy.app.timers.unregister(_tick)


__all__ = ["View", "ViewportSession", "close_all", "server_for", "view_draw", "view_update"]


def render_on_server(client: ServeClient, glb: Path, out: Path, settings: dict, on_progress, should_cancel) -> list:
    """F12's render sent to a viewport's server (`server_for`): the picture and passes written
    as `cubist render` writes them; returns the warnings. Raises runner.Cancelled,
    runner.RendererError with the server's message, or serve_client.ServerGone (then the
    caller runs the binary itself)."""
    reply = client.render(settings, out, scene=glb, passes=settings.get("passes", []), on_progress=on_progress,
                          should_cancel=should_cancel)
    return list(reply.get("warnings", []))
