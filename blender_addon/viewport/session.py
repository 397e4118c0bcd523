"""One viewport's session: its worker thread, its latest job and image, and its folder.

Each 3D view in Rendered shading has a session; every session sends its requests to the
session-wide renderer (server.py), which keeps the scene, BVH, saliency and each stage's output
between requests, so a panel change re-runs only the stages it reaches.

The worker thread writes the job's scene file first when it was not written (the glTF arrays
are made there: triangles, welding, the buffer; a newer scene read meanwhile stops it), then
renders the latest job progressively, 1/4, 1/2 then full resolution, each a request to the
server; a newer job cancels the running request, so edits never queue up: the last one wins.
A renderer that dies or stops answering is an error shown in the view; the next job starts
another (server.client). Blender's API is never used here.
"""

from __future__ import annotations

import os
import shutil
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional

import numpy as np

from .. import export, server
from ..runner.errors import CubistError
from ..serve_client import ServeClient, ServerGone, ServerHung, read_rgba
from .view import View

# The progressive passes, as fractions of the view's size; passes whose image would be
# smaller than MIN_SIDE pixels are skipped.
PASSES = (0.25, 0.5, 1.0)
MIN_SIDE = 16

# Every open session, for the timer and closing them all; and the sessions closed whose worker
# has not ended yet (Blender's exit waits for them: their threads are daemons, cut short with
# the interpreter, which would leave their folder behind).
sessions: set = set()
ending: set = set()
sessions_lock = threading.Lock()


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
    """One viewport's worker thread, its folder (scene file and images) and its latest image."""

    def __init__(self, binary: Path):
        self.binary = Path(binary)
        server.client(self.binary)  # started now: a binary that cannot start is reported at once
        self.workspace = Path(tempfile.mkdtemp(prefix="cubist-view-"))
        self.cond = threading.Condition()
        self.generation = 0
        self.job: Optional[Job] = None
        self.running: Optional[tuple] = None  # (client, request id) in flight
        self.image: Optional[Image] = None
        self.image_new = False
        self.error: Optional[str] = None
        self.status = ""
        self.closed = False
        self.scene_path = self.workspace / "scene.glb"
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
        with sessions_lock:
            sessions.add(self)

    @property
    def client(self) -> Optional[ServeClient]:
        """The session-wide server, if one runs."""
        return server.current()

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
            running[0].cancel(running[1])
        return self.generation

    def take_image(self) -> Optional[Image]:
        with self.cond:
            self.image_new = False
            return self.image

    def close(self, wait: bool = False) -> None:
        """Ends the worker (cancelling its request) and removes the session's folder; the
        session-wide server stays for F12 and the other views. `wait`: until the worker ended."""
        with self.cond:
            if self.closed:
                return
            self.closed = True
            running, self.running = self.running, None
            self.cond.notify_all()
        with sessions_lock:
            sessions.discard(self)
            ending.add(self)
        if running is not None:
            running[0].cancel(running[1])
        if wait:
            self.join()

    def join(self) -> None:
        """Waits for the worker to end (it ends soon after `close`); its folder is gone then."""
        self.thread.join(timeout=10.0)
        shutil.rmtree(self.workspace, ignore_errors=True)
        with sessions_lock:
            ending.discard(self)

    # ------------------------------------------------------------------ worker thread

    def _newer(self, job: Job) -> bool:
        return self.closed or self.job is None or self.job.generation != job.generation

    def _work(self) -> None:
        done = 0
        try:
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
                    self._fail(job, f"internal error: {type(e).__name__}: {e}")
        finally:
            # The folder goes with the worker: nothing writes into it any more.
            shutil.rmtree(self.workspace, ignore_errors=True)
            with sessions_lock:
                ending.discard(self)

    def _fail(self, job: Job, message: str) -> None:
        with self.cond:
            if not self._newer(job):
                self.counts["errors"] += 1
                self.error, self.status, self.image_new = message, "", True

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
                # Atomically: the server may be reading the previous one.
                os.replace(tmp, self.scene_path)
            except export.ExportCancelled:
                return False
            except Exception as e:  # a full disk, a bug of ours: shown in the view
                ex.error = f"export failed: {type(e).__name__}: {e}"
            else:
                with self.cond:
                    ex.written, ex.exporter = True, None
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
        try:
            client = server.client(self.binary)
        except ServerGone as e:
            self._fail(job, str(e))
            return
        w, h = job.settings["width"], job.settings["height"]
        for scale in passes_for(w, h):
            settings = scaled(job.settings, scale)
            out = self.workspace / f"view_{int(scale * 100)}.rgba"
            with self.cond:
                if self._newer(job):
                    return
                # Sent under the lock: a job submitted meanwhile sees this request and cancels it.
                pending = client.render_request(settings, out, scene=job.scene)
                self.running = (client, pending.id)
                self.counts["requests"] += 1
                self.status = f"rendering {settings['width']}x{settings['height']}"
            t0 = time.monotonic()
            try:
                reply = client.await_reply(pending)
            except ServerHung as e:
                server.forget(client)
                reply = {"ok": False, "error": str(e)}
            with self.cond:
                if self.running is not None and self.running[1] == pending.id:
                    self.running = None
            if not reply.get("ok"):
                if reply.get("cancelled"):
                    with self.cond:
                        self.counts["cancelled"] += 1
                else:
                    self._fail(job, str(reply.get("error")))
                return
            try:
                pixels = read_rgba(out, reply["width"], reply["height"])
            except (OSError, ValueError, CubistError) as e:  # the folder went (closed), or a short file
                self._fail(job, f"cannot read the renderer's image: {e}")
                return
            with self.cond:
                self.image = Image(job.generation, scale, pixels, job.view, time.monotonic() - t0, reply)
                self.image_new = True
                self.error = None
                self.counts["images"] += 1
                self.history.append((job.generation, scale, reply["timings"].get("total"), reply.get("reused")))
                del self.history[:-200]
                if scale >= 1.0:
                    self.status = ""


__all__ = ["Image", "Job", "PASSES", "SceneExport", "ViewportSession", "ending", "passes_for", "scaled",
           "sessions"]
