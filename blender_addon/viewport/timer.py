"""The viewport's timer (`bpy.app.timers`, main thread): it tags a 3D view for redraw when its
session has a new image (how the image reaches the screen) and ends the sessions whose view
left Rendered shading."""

from __future__ import annotations

import time

import bpy

from .session import sessions, sessions_lock

# How often the timer looks for new images (seconds).
TICK = 0.05
# A session never drawn this long after it started is ended by the timer (its view went
# away before drawing, without its engine being freed yet).
FORGOTTEN_AFTER = 30.0


def rendered_areas() -> set:
    """The 3D views (as_pointer()) in Rendered shading with the Cubist engine."""
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


def tick():
    with sessions_lock:
        current = list(sessions)
    if not current:
        return None  # the timer ends; the next session starts it again
    try:
        rendered = rendered_areas()
    except Exception:
        return TICK
    redraw = set()
    now = time.monotonic()
    for s in current:
        never_drawn = s.last_draw is None and now - s.created > FORGOTTEN_AFTER
        if (s.area is not None and s.area not in rendered) or never_drawn:
            s.close()
        elif s.image_new:
            redraw.add(s.area)
    if redraw:
        redraw_views(redraw)
    return TICK


def redraw_views(areas: set) -> None:
    """Tags for redraw the 3D views of `areas` (as_pointer()) only: every redraw of a view costs
    Blender's main thread a whole draw of it (0.1-0.9 s under Xvfb's software OpenGL on a loaded
    2-core machine, docs/blender.md), so views in Solid shading and views with nothing new are
    left alone. None in `areas`: a session not drawn yet, whose area is unknown; all 3D views."""
    for window in bpy.context.window_manager.windows:
        for area in window.screen.areas:
            if area.type == "VIEW_3D" and (None in areas or area.as_pointer() in areas):
                area.tag_redraw()


def ensure() -> None:
    if not bpy.app.timers.is_registered(tick):
        bpy.app.timers.register(tick, first_interval=TICK, persistent=True)


def stop() -> None:
    if bpy.app.timers.is_registered(tick):
        bpy.app.timers.unregister(tick)
