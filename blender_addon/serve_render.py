"""F12 and Render Animation on the session's renderer (server.py): a coarse preview first,
then the picture.

A single F12 sends two requests at once: the preview (a quarter of the size, one sample per
pixel, no passes, nothing saved) and the picture (`.rgba`, raw pixels: no PNG to encode and
decode; its passes as PNG beside it). The server runs them in that order, so the preview comes
in a fraction of the picture's time and is shown while the picture renders. Render Animation
sends the picture alone: each frame after the first reuses what the server kept.

No bpy here: the engine hands in its callbacks (progress, cancel, the preview's display), and
tests/python/test_addon_serve.py runs this against the real binary.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Optional

import numpy as np

from . import server
from .runner.errors import Cancelled, RendererError
from .serve_client import ServeClient, ServerError, ServerGone, ServerHung, read_rgba

# The preview's size, as a fraction of the picture's (the viewport's first pass).
PREVIEW_SCALE = 0.25


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


def render(binary: Path, scene: Path, folder: Path, settings: dict,
           on_progress: Callable[[str, float], None], should_cancel: Callable[[], bool],
           on_preview: Optional[Callable[[np.ndarray], None]] = None,
           on_start: Callable[[ServeClient], None] = lambda c: None) -> Outcome:
    """Renders `scene` with `settings` on the session's renderer into `folder` (its passes as
    `render.<pass>.png`). `on_preview(pixels)`, when given, gets the preview ((h, w, 4) uint8,
    top row first) as soon as it comes; `on_start(client)` when the requests are sent. Raises Cancelled, RendererError (the renderer's
    message, a renderer that died or hung: the next render starts another) or NoServe."""
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
    return outcome


def warnings_of(outcome: Outcome) -> list:
    return list(outcome.reply.get("warnings", []))


__all__ = ["NoServe", "Outcome", "PREVIEW_SCALE", "preview_settings", "render", "warnings_of"]
