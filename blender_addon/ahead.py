"""Render ahead: F12's picture prepared while the scene is still, so that F12 finds it done.

Once the scene has had no depsgraph update for IDLE seconds (IDLE_SETTINGS when only the
scene's own settings changed: a panel value; a `bpy.app.timers` timer on the main thread, armed
by each update), F12's job is sent to the session's renderer (server.py): the
scene as it is now, with the settings F12 would send (frame_job.py), at F12's size. The renderer
keeps every stage's output, so F12 then re-runs nothing, and when the scene and the panel are
still the same it hands the finished picture back at once (the engine skips its coarse preview:
`claim`). Any edit cancels the prepare in flight (the renderer keeps the stages it finished),
and the next still moment sends the new job: the last edit wins, nothing queues.

The renderer runs a prepare on its lower-priority threads (`background`, docs/serve.md), so the
interface keeps the cores first.

What it never does: start a renderer for a scene whose engine is not Cubist; run while a render
job runs or a 3D view renders in Rendered shading (the view has the renderer); send again,
before the next edit, a job the user stopped with Esc; write anything beside the .blend (no
layout saved, the saliency cache only into a folder F12 made already);
hold the interface longer than READ_BUDGET: the main thread only reads the scene's arrays
(export.read_scene; the arrays of meshes unchanged since the last read are reused), and the
worker thread writes the file and waits for the renderer. A scene whose reading takes longer is
not rendered ahead until its geometry changes. Its files (the scene, the picture) are in the
renderer's own temporary folder (serve_client.py), removed with it when Blender quits.

F12 stays correct without it: F12 always exports and sends its own job; a prepare only fills the
renderer's kept outputs, which are keyed by content (a prepare of another scene or settings is
simply not reused). The preference `render_ahead` (Preferences > Add-ons > Cubist) turns it off.
"""

from __future__ import annotations

import json
import threading
import time
import traceback
from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional

import numpy as np

import bpy

from . import export, frame_job, picture, preferences, runner, serve_render, server
from .serve_client import Pending, ServeClient, read_rgba

# Seconds without a depsgraph update before F12's job is prepared; after a change of the
# scene's own settings alone (a panel value, the resolution: the job's settings, not its
# scene), without any update for IDLE_SETTINGS seconds, so that the picture of a value typed in
# the panel is under way before F12 is pressed.
IDLE = 1.0
IDLE_SETTINGS = 0.3
# The longest the main thread may spend reading the scene for a prepare; a scene that takes
# longer is left to F12 (tried again after its geometry changes).
READ_BUDGET = 0.1
ENGINE_ID = "CUBIST"


@dataclass
class Prepare:
    """One prepare: F12's job as it was after an edit, sent to the session's renderer."""

    number: int
    edits: int  # the edit count it was read at
    cancelled: threading.Event = field(default_factory=threading.Event)
    done: threading.Event = field(default_factory=threading.Event)
    key: Optional[str] = None  # job_key of what it sent
    client: Optional[ServeClient] = None
    pending: Optional[Pending] = None
    reply: Optional[dict] = None
    claimed: bool = False  # an F12 waits for it: edits no longer cancel it
    pixels: Optional[np.ndarray] = None  # the prepared picture, 8-bit, top row first
    rect: Optional[np.ndarray] = None  # as the render result's (h, w, 4) floats (picture.result_rect)
    skipped: Optional[str] = None  # why nothing was sent
    seconds: dict = field(default_factory=dict)  # where its time went (diagnostics, tests)

    @property
    def ok(self) -> bool:
        return self.done.is_set() and bool(self.reply and self.reply.get("ok"))


@dataclass
class Claim:
    """What F12 found (`claim`): `status` "ready" (the prepared job is F12's and finished: every
    stage kept) or "running" (it is F12's and still rendering: F12's request waits behind it)."""

    status: str
    prepare: Prepare


_lock = threading.Lock()
_edits = 0  # depsgraph updates seen
_last_edit = 0.0
_last_content_edit = 0.0  # the last update that reached more than the scene's own settings
_geometry_dirty = True  # a mesh's data changed since the last read: read every mesh again
_meshes_read: dict = {}  # the last read's meshes' arrays (export.read_scene's mesh_cache)
_too_large = False  # the last read went over READ_BUDGET (and no geometry changed since)
_current: Optional[Prepare] = None  # the newest prepare
# The edit count when the user cancelled a render (Esc): that job is not prepared again behind
# their back, only once the scene or a setting changes.
_held_at: Optional[int] = None
_numbers = 0
_threads: set = set()
# Diagnostics for the tests and the benchmarks: prepares sent, cancelled, and the last reason
# one was not made.
counts = {"reads": 0, "sent": 0, "cancelled": 0, "reused": 0, "skipped": 0}
last_skip: Optional[str] = None


def job_key(digest: str, settings: dict) -> str:
    """What makes two jobs the same picture on the same kept outputs: the scene file's content
    and the settings, but for where files go (frame_job.FILE_KEYS: F12 saves the layout, a
    prepare may leave the saliency cache out)."""
    s = {k: v for k, v in settings.items() if k not in frame_job.FILE_KEYS}
    return digest + "\n" + json.dumps(s, sort_keys=True, default=str)


def enabled() -> bool:
    prefs = preferences.addon_preferences()
    return bool(getattr(prefs, "render_ahead", True)) if prefs is not None else False


def current() -> Optional[Prepare]:
    return _current


# ------------------------------------------------------------------------------ F12's side


def claim(digest: str, settings: dict) -> Optional[Claim]:
    """Called by a render (any thread) with the job it is about to send. When the newest
    prepare is that job on the running renderer, it is F12's from now on (edits no longer
    cancel it); a prepare of another job still rendering is cancelled, so the render does not
    wait behind it. None when nothing prepared is of use."""
    key = job_key(digest, settings)
    with _lock:
        p = _current
        if p is None:
            return None
        same = p.key == key and not p.cancelled.is_set() and p.client is not None and p.client is server.current()
        if same and p.ok:
            p.claimed = True
            return Claim("ready", p)
        if same and not p.done.is_set():
            p.claimed = True
            return Claim("running", p)
    cancel()
    return None


def release(p: Prepare) -> None:
    """The render that claimed `p` while it rendered was cancelled (Esc): `p` stops too."""
    with _lock:
        if p.done.is_set() or p.cancelled.is_set():
            return
        p.cancelled.set()
        client, pending = p.client, p.pending
    if client is not None and pending is not None:
        client.cancel(pending.id)


# ------------------------------------------------------------------------------ main thread


def cancel() -> None:
    """The newest prepare is cancelled unless a render claimed it (an edit, another render, the
    viewport). The renderer keeps the stages it finished."""
    with _lock:
        p = _current
        if p is None or p.claimed or p.done.is_set() or p.cancelled.is_set():
            return
        p.cancelled.set()
        counts["cancelled"] += 1
        client, pending = p.client, p.pending
    if client is not None and pending is not None:
        client.cancel(pending.id)


def hold() -> None:
    """A render was cancelled (Esc; any thread): nothing is prepared until the next edit."""
    global _held_at
    with _lock:
        _held_at = _edits


def _skip(why: str) -> None:
    global last_skip
    last_skip = why
    counts["skipped"] += 1


@bpy.app.handlers.persistent
def _depsgraph_updated(scene, depsgraph=None):
    global _edits, _last_edit, _last_content_edit, _geometry_dirty, _too_large
    _edits += 1
    _last_edit = time.monotonic()
    updates = list(getattr(depsgraph, "updates", ())) if depsgraph is not None else []
    if not updates or any(not isinstance(u.id, bpy.types.Scene) for u in updates):
        _last_content_edit = _last_edit
    if any(u.is_updated_geometry for u in updates):
        _geometry_dirty, _too_large = True, False
    cancel()
    arm()


@bpy.app.handlers.persistent
def _file_loaded(*_args):
    global _geometry_dirty, _too_large, _meshes_read
    _geometry_dirty, _too_large, _meshes_read = True, False, {}
    arm()


@bpy.app.handlers.persistent
def _file_closing(*_args):
    forget()


def arm() -> None:
    """The next still moment prepares F12's job (main thread). Not without an interface
    (`blender -b`, bpy as a module): no one presses F12 there."""
    if not bpy.app.background and not bpy.app.timers.is_registered(_tick):
        bpy.app.timers.register(_tick, first_interval=IDLE_SETTINGS, persistent=True)


def _tick():
    """The timer: waits until the scene has been still (IDLE, IDLE_SETTINGS), then prepares."""
    wait = max(_last_edit + IDLE_SETTINGS, _last_content_edit + IDLE) - time.monotonic()
    if wait > 0.0:
        return wait
    if bpy.app.is_job_running("RENDER"):
        return IDLE  # after the render (a render job changes nothing F12 reads)
    try:
        prepare(bpy.context.scene)
    except Exception:  # never an error for the user: F12 renders as without it
        _skip("internal error: " + traceback.format_exc(limit=3))
    return None


def _viewport_renders() -> bool:
    from .viewport import session  # the viewport imports this module

    with session.sessions_lock:
        return any(not s.closed for s in session.sessions)


def prepare(scene) -> Optional[Prepare]:
    """Reads `scene` and sends F12's job to the session's renderer from a worker thread (main
    thread). None, with `last_skip` saying why, when it does not."""
    global _geometry_dirty, _meshes_read, _too_large, _current, _numbers
    if scene is None or not enabled():
        return None
    if scene.render.engine != ENGINE_ID:
        _skip("the render engine is not Cubist")
        return None
    if _viewport_renders():
        _skip("a 3D view renders in Rendered shading")
        return None
    if _held_at == _edits:
        _skip("the last render was cancelled: nothing is prepared until the next edit")
        return None
    p = _current
    if p is not None and p.edits == _edits and not p.cancelled.is_set():
        return p  # nothing changed since it was made
    if _too_large and not _geometry_dirty:
        _skip(f"reading the scene takes more than {READ_BUDGET} s")
        return None
    prefs = preferences.addon_preferences()
    pref_path = bpy.path.abspath(prefs.binary_path) if prefs is not None and prefs.binary_path else ""
    try:
        binary = runner.find_binary(pref_path)
    except runner.CubistError as e:
        _skip(str(e))  # F12 says so
        return None
    depsgraph = bpy.context.evaluated_depsgraph_get()
    edits = _edits  # the read below sees the scene as of every edit so far
    if export.scene_camera(depsgraph) is None or not export.has_geometry(depsgraph):
        _skip("no camera or nothing to render")
        return None
    t0 = time.perf_counter()
    try:
        exporter = export.read_scene(depsgraph, lambda: time.perf_counter() - t0 > READ_BUDGET,
                                     mesh_cache=None if _geometry_dirty else _meshes_read)
    except export.ExportCancelled:
        _too_large, _geometry_dirty, _meshes_read = True, False, {}
        _skip(f"reading the scene takes more than {READ_BUDGET} s")
        return None
    read_seconds = time.perf_counter() - t0
    _meshes_read, _geometry_dirty, _too_large = exporter.meshes_read, False, False
    exporter.depsgraph = None  # the worker must not touch Blender's data
    counts["reads"] += 1
    from . import engine  # the engine imports this module

    props = scene.cubist
    folder = engine.layout_folder(props)
    inputs = frame_job.FrameInputs(
        panel=preferences.panel(props), facts=export.scene_facts(depsgraph), scene_name=scene.name,
        frame=scene.frame_current, layout_frame=props.layout_frame, static_facets=props.static_facets,
        use_saliency_cache=props.use_saliency_cache, folder=folder, binary=binary)
    # The saliency cache goes where F12 would put it, but no folder is made beside a .blend
    # for it: an unsaved file's folder is temporary, a saved file's exists once F12 made it.
    keep_cache = not bpy.data.filepath or folder.is_dir()
    with _lock:
        _numbers += 1
        p = Prepare(_numbers, edits)
        p.seconds["read"] = round(read_seconds, 4)
        previous, _current = _current, p
    t = threading.Thread(target=_work, args=(p, previous, exporter, inputs, keep_cache),
                         name="cubist-render-ahead", daemon=True)
    with _lock:
        _threads.add(t)
    t.start()
    return p


# ------------------------------------------------------------------------------ worker thread


def _work(p: Prepare, previous: Optional[Prepare], exporter, inputs: frame_job.FrameInputs, keep_cache: bool) -> None:
    try:
        _send_and_wait(p, previous, exporter, inputs, keep_cache)
    except Exception as e:  # noqa: BLE001 - F12 renders as without it, and reports its own errors
        p.skipped = f"{type(e).__name__}: {e}"
    finally:
        p.done.set()
        with _lock:
            _threads.discard(threading.current_thread())


def _send_and_wait(p: Prepare, previous: Optional[Prepare], exporter, inputs: frame_job.FrameInputs,
                   keep_cache: bool) -> None:
    t0 = time.perf_counter()
    try:
        client = server.client(inputs.binary)  # (the scene's engine is Cubist: prepare checked)
    except runner.CubistError as e:
        p.skipped = str(e)
        return
    folder = client.workspace  # removed with the renderer
    glb = folder / f"ahead-{p.number}.glb"
    exporter.write(glb)
    digest = serve_render.scene_digest(glb)
    fs = frame_job.frame_settings(inputs)
    source = None
    if fs.needs_source:
        if inputs.frame != inputs.layout_frame:
            p.skipped = "the facet layout comes from another frame"
            return
        source = runner.layout_source(glb, fs.settings)
    state = frame_job.layout_state(fs, source, inputs.frame, inputs.layout_frame)
    settings = dict(state.plan.settings)
    settings.pop("save_facets", None)  # F12 saves the layout (the prepare writes nothing beside the .blend)
    if not keep_cache:
        settings.pop("saliency_cache", None)
    if state.plan.prepass_frame is not None or not frame_job.renders_on_server(settings):
        p.skipped = "this frame is rendered by the binary alone"
        return
    p.key = job_key(digest, settings)
    p.seconds["write"] = round(time.perf_counter() - t0, 4)
    if previous is not None and previous.key == p.key and previous.ok and previous.client is client:
        # The same job as the last prepare (an update that changed nothing F12 reads).
        p.client, p.reply, p.pixels, p.rect = previous.client, previous.reply, previous.pixels, previous.rect
        counts["reused"] += 1
        _remove_older(folder, p.number, keep=previous.number)
        return
    out = folder / f"ahead-{p.number}.rgba"
    with _lock:
        if p.cancelled.is_set():
            return
        p.client = client
        # On the renderer's lower-priority threads: the interface keeps the cores first.
        p.pending = client.render_request(settings, out, scene=glb, passes=list(settings.get("passes", [])),
                                          progress=True, background=True)
        counts["sent"] += 1
    # Wait without reading the progress (an F12 that claims this prepare reads it) and without
    # a hang check (F12's own request has one): until the reply, a cancel, or the end.
    while p.pending.wait(0.1) is None:
        if p.cancelled.is_set() or _closing.is_set():
            return
    p.reply = p.pending.reply
    p.seconds["render"] = round(time.perf_counter() - t0, 4)
    if not p.reply.get("ok"):
        return
    serve_render.remember(client.pid, digest, settings, p.reply)
    _remove_older(folder, p.number)
    if not p.claimed:  # (a claimed one: F12 converts its own picture, the GIL is its own)
        pixels = read_rgba(out, p.reply["width"], p.reply["height"])
        rect = picture.result_rect(pixels, (0, 0, pixels.shape[1], pixels.shape[0]))
        p.pixels, p.rect = pixels, rect.reshape(pixels.shape[0], pixels.shape[1], 4)
    p.seconds["done"] = round(time.perf_counter() - t0, 4)


def _remove_older(folder: Path, number: int, keep: Optional[int] = None) -> None:
    """The files of earlier prepares (their scenes, pictures and passes)."""
    for f in folder.glob("ahead-*"):
        n = f.name.split("-", 1)[1].split(".", 1)[0]
        if n.isdigit() and int(n) < number and int(n) != keep:
            f.unlink(missing_ok=True)


# ------------------------------------------------------------------------------ lifetime

_closing = threading.Event()


def forget() -> None:
    """A file is closing: what was prepared is of another scene."""
    global _current, _held_at
    cancel()
    with _lock:
        _current, _held_at = None, None


def shutdown() -> None:
    """The add-on is disabled or Blender quits: the prepare in flight is cancelled and its
    thread ended (before the renderer ends, which removes the files)."""
    global _current
    _closing.set()
    cancel()
    with _lock:
        threads = list(_threads)
        _current = None
    for t in threads:
        t.join(timeout=5.0)
    _closing.clear()


def preference_changed(prefs, _context=None) -> None:
    if prefs.render_ahead:
        arm()
    else:
        forget()


def register():
    bpy.app.handlers.depsgraph_update_post.append(_depsgraph_updated)
    bpy.app.handlers.load_post.append(_file_loaded)
    bpy.app.handlers.load_pre.append(_file_closing)
    arm()


def unregister():
    for handlers, h in ((bpy.app.handlers.depsgraph_update_post, _depsgraph_updated),
                        (bpy.app.handlers.load_post, _file_loaded), (bpy.app.handlers.load_pre, _file_closing)):
        if h in handlers:
            handlers.remove(h)
    if bpy.app.timers.is_registered(_tick):
        bpy.app.timers.unregister(_tick)
    shutdown()


__all__ = ["Claim", "IDLE", "IDLE_SETTINGS", "Prepare", "READ_BUDGET", "arm", "cancel", "claim", "counts", "current", "enabled",
           "forget", "hold", "job_key", "prepare", "release", "shutdown"]
