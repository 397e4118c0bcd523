"""F12 and Render Animation on the session's renderer (server.py): a coarse preview first,
then the picture.

A single F12 sends two requests at once: the preview (a quarter of the size, one sample per
pixel, no passes, nothing saved) and the picture (`.rgba`, raw pixels: no PNG to encode and
decode; its passes as PNG beside it). The server runs them in that order, so the preview comes
in a fraction of the picture's time and is shown while the picture renders. Render Animation
sends the picture alone: each frame after the first reuses what the server kept. The preview is
left out when the picture is expected within PREVIEW_WORTH seconds (`wants_preview`: the steps a
change reaches, at what they cost last time) or was rendered ahead (ahead.py): it would only
delay it.

No bpy here: the engine hands in its callbacks (progress, cancel, the preview's display), and
tests/python/test_addon_serve.py runs this against the real binary.
"""

from __future__ import annotations

import hashlib
import threading
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Optional

import numpy as np

from . import server
from .frame_job import FILE_KEYS
from .schema import SETTINGS
from .runner.errors import Cancelled, RendererError
from .serve_client import ServeClient, ServerError, ServerGone, ServerHung, read_rgba

# The preview's size, as a fraction of the picture's (the viewport's first pass).
PREVIEW_SCALE = 0.25
# A preview is rendered only for a picture expected to take longer than this (seconds on the
# session's renderer, `expected_seconds`): a picture that comes sooner needs none, and the
# preview's own render and display would delay it.
PREVIEW_WORTH = 0.5


class NoServe(Exception):
    """The binary has no `serve` command (older than the add-on): run it once per frame."""


@dataclass
class Outcome:
    image: Path  # the picture, `.rgba`
    width: int
    height: int
    reply: dict = field(default_factory=dict)
    preview_reply: Optional[dict] = None
    pid: int = 0


def preview_settings(settings: dict) -> dict:
    """The preview's settings: the picture's at PREVIEW_SCALE of its size (pixel-valued
    settings scale with it in the renderer), one sample per pixel, no passes, nothing saved."""
    s = dict(settings)
    s["width"] = max(1, round(settings["width"] * PREVIEW_SCALE))
    s["height"] = max(1, round(settings["height"] * PREVIEW_SCALE))
    s["spp"] = 1
    s["passes"] = []
    s.pop("save_facets", None)
    return s


def scene_digest(path: Path) -> str:
    """The scene file's content, as a short hash: which scene a render or a prepare sent."""
    h = hashlib.blake2b(digest_size=16)
    with open(path, "rb") as f:
        for chunk in iter(lambda: f.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


# The pipeline's steps in order, as the replies' `timings` name them (docs/serve.md), and the
# first one a change of each settings group reaches ("What a change re-runs"); any other group
# (camera, image, shading, saliency, the preset) re-runs from the pre-render. Keys that only say
# where files go (frame_job.FILE_KEYS) reach none.
STEPS = ("pre-render", "saliency", "faceting", "imprecision", "re-trace", "anti-aliasing", "paint", "encode")
_GROUP_STEP = {"Painterly effects": "paint", "Spatial imprecision": "imprecision", "Facets": "faceting",
               "Outputs": "encode"}
_NO_STEP = FILE_KEYS


@dataclass
class _Costs:
    pid: int  # the renderer that kept those outputs
    digest: str
    settings: dict
    seconds: dict  # step -> its last time at this size (0.0: it does not run)


_costs: dict = {}  # (width, height) -> the last picture's _Costs
_costs_lock = threading.Lock()


def _first_step(key: str) -> int:
    if key in _NO_STEP:
        return len(STEPS)
    group = SETTINGS.get(key, {}).get("group")
    return STEPS.index(_GROUP_STEP.get(group, "pre-render"))


def remember(pid: int, digest: str, settings: dict, reply: dict) -> None:
    """A picture's reply from the renderer `pid` (F12, a frame, a prepare): what each step
    cost, for `expected_seconds`."""
    timings, reused = reply.get("timings") or {}, set(reply.get("reused") or [])
    size = (reply.get("width"), reply.get("height"))
    with _costs_lock:
        old = _costs.get(size)
        seconds = dict(old.seconds) if old is not None and (old.pid, old.digest) == (pid, digest) else {}
        for step in STEPS:
            t = timings.get(step)
            if step == "pre-render" and t is not None:
                t += timings.get("framing", 0.0)
            if t is not None:
                seconds[step] = float(t)
            elif step not in reused:
                seconds[step] = 0.0  # neither run nor kept: not a step of these settings
        _costs[size] = _Costs(pid, digest, dict(settings), seconds)


def expected_seconds(digest: str, settings: dict) -> Optional[float]:
    """How long the picture of `settings` should take on the session's renderer: the steps its
    changes since the last picture of this size reach, at what they cost then. None when it is
    not known (another scene or size, another renderer than the running one, a step never
    timed)."""
    with _costs_lock:
        c = _costs.get((settings.get("width"), settings.get("height")))
    running = server.current()
    if c is None or c.digest != digest or running is None or running.pid != c.pid:
        return None
    changed = [k for k in set(settings) | set(c.settings) if settings.get(k) != c.settings.get(k)]
    first = min((_first_step(k) for k in changed), default=len(STEPS))
    total = 0.0
    for step in STEPS[first:]:
        if step not in c.seconds:
            return None
        total += c.seconds[step]
    return total


def wants_preview(digest: str, settings: dict) -> bool:
    """Whether F12 should show a coarse preview first: only when the picture is not expected
    within PREVIEW_WORTH seconds."""
    expected = expected_seconds(digest, settings)
    return expected is None or expected > PREVIEW_WORTH


def render(binary: Path, scene: Path, folder: Path, settings: dict,
           on_progress: Callable[[str, float], None], should_cancel: Callable[[], bool],
           on_preview: Optional[Callable[[np.ndarray], None]] = None,
           on_start: Callable[[ServeClient], None] = lambda c: None, digest: Optional[str] = None) -> Outcome:
    """Renders `scene` with `settings` on the session's renderer into `folder` (its passes as
    `render.<pass>.png`). `on_preview(pixels)`, when given, gets the preview ((h, w, 4) uint8,
    top row first) as soon as it comes; `on_start(client)` when the requests are sent; `digest`
    (scene_digest of `scene`), when given, records what the picture cost (`expected_seconds`).
    Raises Cancelled, RendererError (the renderer's message, a renderer that died or hung: the
    next render starts another) or NoServe."""
    try:
        client = server.client(binary)
    except ServerGone as e:
        raise RendererError(str(e), 1) from None
    on_start(client)
    image = folder / "render.rgba"
    requests: list = []

    def cancelled() -> bool:
        if should_cancel():
            for p in requests[1:]:  # the first is cancelled by await_reply
                client.cancel(p.id)
            return True
        return False

    client.set_progress(on_progress)
    try:
        pre = None
        if on_preview is not None:
            pre = client.render_request(preview_settings(settings), folder / "preview.rgba", scene=scene, passes=[])
            requests.append(pre)
        full = client.render_request(settings, image, scene=scene, passes=list(settings.get("passes", [])),
                                     progress=True)
        requests.append(full)
        outcome = Outcome(image, 0, 0, pid=client.pid)
        if pre is not None:
            reply = client.await_reply(pre, cancelled)
            outcome.preview_reply = reply
            if reply.get("ok") and not full.done():
                # (A picture that is already there, all its stages kept, needs no preview.)
                on_preview(read_rgba(folder / "preview.rgba", reply["width"], reply["height"]))
            elif reply.get("cancelled"):
                client.cancel(full.id)
                client.await_reply(full)
                raise Cancelled()
            # A failed preview: the picture fails the same way, with its own message.
        reply = client.await_reply(full, cancelled)
    except ServerHung as e:
        server.forget(client)
        raise RendererError(str(e), 1) from None
    finally:
        client.set_progress(None)
    try:
        client.check(reply)
    except ServerError as e:
        raise RendererError(str(e), 1) from None
    except ServerGone as e:
        if "no `serve` command" in str(e):
            raise NoServe(str(e)) from None
        raise RendererError(f"{e} (the next render starts it again)", 1) from None
    outcome.reply, outcome.width, outcome.height = reply, reply["width"], reply["height"]
    if digest is not None:
        remember(client.pid, digest, settings, reply)
    return outcome


def warnings_of(outcome: Outcome) -> list:
    return list(outcome.reply.get("warnings", []))


__all__ = ["NoServe", "Outcome", "PREVIEW_SCALE", "PREVIEW_WORTH", "STEPS", "expected_seconds", "preview_settings",
           "remember", "render", "scene_digest", "wants_preview", "warnings_of"]
