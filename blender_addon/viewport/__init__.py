"""The Cubist viewport: a 3D view in Rendered shading shows the cubist render of what it sees,
through the scene camera when it looks through it, from the view otherwise.

One module a concept:
- `session`: a view's session, its worker thread and images, on the session-wide renderer
  (server.py): a panel change re-runs only the stages it reaches;
- `view`: what a view shows, as the renderer's camera and settings;
- `updates`: what a change in Blender does (the scene read again, a job for the session);
- `drawing`: the image and messages drawn in the view (Blender's GPU context);
- `timer`: redraws the views with a new image, ends the sessions of views left Rendered shading;
- here: the engine's viewport methods (engine.py calls them) and the sessions' lifetime.

Threads: Blender's API is used on the main thread only (`view_update`, `view_draw`, the timer);
each session's worker writes the scene file and talks to the renderer.

A session ends when its view leaves Rendered shading (the engine is freed, or the timer sees
it), a file is loaded, Blender quits or the add-on is disabled; the renderer stays for F12 and
the other views until Blender quits (server.py).
"""

from __future__ import annotations

import atexit
import time
from pathlib import Path
from typing import Optional

import bpy

from .. import ahead, preferences, runner, server
from . import drawing, timer
from .drawing import gpu_pixels
from .session import Job, SceneExport, ViewportSession, ending, passes_for, scaled, sessions, sessions_lock
from .updates import content_changed, export_scene, geometry_changed, update
from .view import View, camera_rect, settings_for, view_camera_facts, view_of


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
    timer.ensure()
    return session


def view_update(engine, context, depsgraph) -> None:
    t0 = time.perf_counter()
    ahead.cancel()  # the view has the renderer now (render ahead waits while views render)
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
            drawing.draw_text(region, [f"Cubist: {message}"])
        return
    session.area = context.area.as_pointer() if context.area is not None else None
    session.last_draw = time.monotonic()
    view = view_of(context, depsgraph)
    update(session, depsgraph, view, False)  # the view moved: a new job
    image = session.take_image()
    if image is not None:
        drawing.draw_image(session, image, *(view or image.view).rect())
    lines = []
    if session.error:
        lines.append(f"Cubist: {session.error}")
    elif session.status:
        lines.append(f"Cubist: {session.status}")
    if lines:
        drawing.draw_text(region, lines)
    session.counts["draws"] += 1
    _main_thread_time(session, "view_draw", t0)


def free(engine_id: int) -> None:
    """The viewport engine `id(engine)` is freed (its view left Rendered shading, or F12's
    engine ended): its session, if it has one, ends."""
    session = _by_engine.pop(engine_id, None)
    if isinstance(session, ViewportSession):
        session.close()


def close_all(wait: bool = False) -> None:
    with sessions_lock:
        current = list(sessions)
    for s in current:
        s.close(wait=wait)
    _by_engine.clear()


@bpy.app.handlers.persistent
def _file_loading(*_args):
    close_all()


def end_all():
    """Every session ends, its worker and folder with it (the renderer is ended by the engine,
    which uses it too)."""
    close_all(wait=True)
    with sessions_lock:
        closed = list(ending)
    for s in closed:
        s.join()


def register():
    bpy.app.handlers.load_pre.append(_file_loading)
    atexit.register(end_all)


def unregister():
    """Also what Blender does at quit: Ctrl+Q disables every add-on (`addon_utils.disable_all`)
    before Python's exit handlers run, so unregistering is where sessions and folders go."""
    if _file_loading in bpy.app.handlers.load_pre:
        bpy.app.handlers.load_pre.remove(_file_loading)
    atexit.unregister(end_all)
    end_all()
    timer.stop()


__all__ = ["Job", "SceneExport", "View", "ViewportSession", "camera_rect", "close_all", "content_changed", "export_scene",
           "geometry_changed", "gpu_pixels", "passes_for", "scaled", "server", "settings_for", "update",
           "view_camera_facts", "view_draw", "view_of", "view_update"]
