"""Python threads take turns at Blender's callbacks while a render runs, so the render thread
cannot leave Blender's Python write guard stuck.

Blender keeps one global "writes disallowed" flag for all Python (bpy_rna `rna_disallow_writes`).
Every Python callback it makes (a panel's `draw`, an engine's `render`, a class's `__init__`)
saves the flag, sets it for the callback (draws: writes disallowed) and restores the saved value
when the callback returns. The flag is not per thread. In the interface `render()` runs on the
render-job thread: if the main thread was inside a panel's draw when the render thread entered
its callback (Python hands the GIL to a waiting thread every 5 ms, mid-function), the render
thread saved "disallowed" and restores it when the render ends, long after the draw ended.
From then on the main thread's timers, handlers and add-ons fail with "Writing to ID classes in
this context is not allowed", and Blender cannot even unregister add-ons when it quits. Slow
panels and render_pre handlers that wait (other add-ons have both) make this likely.

While a frame renders (render_pre to render_post or cancel) the switch interval is long: a
thread holding the GIL keeps it until it gives it up, which Blender does at the end of every
callback, and which the render thread does whenever it waits (on the renderer's output, on
`yield_turn`). A callback then runs whole, never interleaved with another thread's, and each
restores the flag it found. The render thread gives up the GIL between exported objects, so the
interface keeps drawing during a long export."""

import sys
import time

import bpy

# How long a thread may keep the GIL while another waits, during a render: longer than any
# callback takes, so that none is cut in two (Python's default is 5 ms).
RENDER_SWITCH_INTERVAL = 5.0

_saved_interval = None


def _long_turns(*_args) -> None:
    global _saved_interval
    if _saved_interval is None:
        _saved_interval = sys.getswitchinterval()
    sys.setswitchinterval(RENDER_SWITCH_INTERVAL)


def _short_turns(*_args) -> None:
    global _saved_interval
    if _saved_interval is not None:
        sys.setswitchinterval(_saved_interval)
        _saved_interval = None


def yield_turn() -> None:
    """Gives up the GIL for a moment, so that a waiting thread (the interface) runs its callback."""
    time.sleep(0)


_HANDLERS = (("render_pre", _long_turns), ("render_post", _short_turns), ("render_cancel", _short_turns),
             ("render_complete", _short_turns))


def register():
    for name, fn in _HANDLERS:
        fn = bpy.app.handlers.persistent(fn)
        handlers = getattr(bpy.app.handlers, name)
        if fn not in handlers:
            handlers.append(fn)


def unregister():
    for name, fn in _HANDLERS:
        handlers = getattr(bpy.app.handlers, name)
        if fn in handlers:
            handlers.remove(fn)
    _short_turns()
