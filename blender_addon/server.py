"""The session's renderer: one `cubist serve` process (serve_client.py) per Blender session,
shared by F12, Render Animation and every 3D view in Rendered shading.

It keeps the scene, its BVH, each mesh's saliency and every stage's output between requests
(docs/serve.md), so a second F12 with one panel change re-runs only what that change reaches,
each frame of an animation reuses what did not change, and F12 after the viewport finds the
scene loaded. It is started on first use, started again by the next
request when it died or hung (serve_client.ServerHung) or when the binary in the preferences
changed, and ended when Blender quits, a file loads or the add-on is disabled.

Any thread may ask for it (the render thread, a viewport's worker): `client()` is guarded by a
lock. It runs at Blender's own CPU priority: F12 is waited for, and a lower one (nice 5, as the
viewport's own servers had) made it 2-3x slower whenever anything else ran on the machine,
while the interface stays responsive without it (the work is off Blender's main thread;
tests/python/test_blender_viewport.py measures it).
"""

from __future__ import annotations

import shutil
import threading
from pathlib import Path
from typing import Optional

from .serve_client import ServeClient

NICE = 0

_lock = threading.RLock()  # client() closes the old server under it (_close_later)
_client: Optional[ServeClient] = None
# Diagnostics (panel, tests): servers started this session and the running one's pid.
started = 0
# Servers being ended by a thread of their own (replaced ones): Blender's exit waits for them,
# or their daemon threads would be cut short and leave their folder behind.
_closing: dict = {}


def client(binary: Path) -> ServeClient:
    """The running server for `binary`: started when there is none, the last one died or was
    killed as hung, or the binary is another one. Raises ServerGone when it cannot start."""
    global _client, started
    binary = Path(binary)
    with _lock:
        old = _client
        if old is not None and old.alive() and old.binary == binary:
            return old
        _client = None
        if old is not None:
            _close_later(old)
        _client = ServeClient(binary, nice=NICE)
        started += 1
        return _client


def current() -> Optional[ServeClient]:
    """The server if one runs (without starting one)."""
    c = _client
    return c if c is not None and c.alive() else None


def forget(c: ServeClient) -> None:
    """`c` misbehaved (hung, or answered nonsense): it is killed and the next request starts
    another."""
    global _client
    with _lock:
        if _client is c:
            _client = None
    c.kill()
    _close_later(c)


def _close_later(c: ServeClient) -> None:
    def close():
        try:
            c.close(timeout=2.0)
        finally:
            with _lock:
                _closing.pop(threading.current_thread(), None)

    t = threading.Thread(target=close, name="cubist-server-close", daemon=True)
    with _lock:
        _closing[t] = c
    t.start()


def shutdown() -> None:
    """Ends the server and waits for those being ended (quit, file load, add-on disabled):
    no process and no folder of theirs is left."""
    global _client
    with _lock:
        c, _client = _client, None
        closing = list(_closing.items())
    if c is not None:
        c.close(timeout=2.0)
    for t, old in closing:
        t.join(timeout=10.0)
        old.kill()
        shutil.rmtree(old.workspace, ignore_errors=True)


__all__ = ["client", "current", "forget", "shutdown"]
