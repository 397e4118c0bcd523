"""The Cubist render engine: F12 and Render Animation export the scene, render it on the
session's renderer (server.py, serve_render.py: a coarse preview first for F12, then the
picture) or, for frames whose facets follow a key frame and binaries without `serve`, with the
`cubist` binary run once (runner.py), stream the progress, and hand the picture and passes back
to Blender.

The render thread. In Blender's interface F12 and Render Animation call `render()` on the
render-job thread while the interface keeps running on the main thread, so
everything reached from `render()` reads only the depsgraph it receives and the engine's own
API: no `bpy.ops`, no `bpy.context` (it belongs to the main thread's window), no
`temp_override`, no `scene.frame_set`, nothing added to or removed from `bpy.data`. Another
frame (the facet layout's) is evaluated with `RenderEngine.frame_set`, which re-evaluates this
render's own depsgraph, as Cycles does for motion blur. Images are read with pngio.

Facets across frames. Every frame is rendered on its own. Static facets load the layout
frame's layout (runner.layouts); facets that follow the scene (Facet Motion: Follow) load it
with the follow data saved beside it, and the binary carries each frame's facets from that key
frame in one step. A frame other than the layout frame whose layout is missing or stale first
has it computed on the layout frame, so F12 on any frame, Render Animation and farm chunks on
other machines render the same frame byte for byte."""

import atexit
import shutil
import time
import traceback
from pathlib import Path

import numpy as np

import bpy

from . import (ahead, chosen, export, frame_job, mapping, picture, pngio, preferences, runner, serve_client, serve_render,
               server, turns, viewport)
from .preferences import addon_preferences
from .preferences import panel as _panel

ENGINE_ID = "CUBIST"

# The last run, for diagnostics (the panel's status line and the tests): the renderer's
# process id and exit code, the temporary workspace, the settings sent, the warnings.
last_run: dict = {}
# One entry per rendered frame (frame, settings sent, layout, error), the newest last.
history: list = []
HISTORY_LIMIT = 1000
# The layout frame's source (runner.layout_source) per render job, for frames other than the
# layout frame: cleared when a job starts (render_init).
_job_sources: dict = {}
# Tests simulate Blender's cancel (Esc, which test_break() reports) with a callable here.
cancel_hook = None
# Tests and benchmarks: a folder where each exported scene and the settings sent with it are
# copied (frame_NNNN.glb + settings_NNNN.json, layout_NNNN.glb + layout_NNNN.json), to render
# them with the CLI and compare. None: nothing is kept.
keep_exports = None
def layout_folder(props) -> Path:
    """The layout and saliency cache folder: the panel's, else `cubist/` beside the .blend,
    else (unsaved file) a folder in the system's temporary directory."""
    if props.layout_folder:
        return Path(bpy.path.abspath(props.layout_folder))
    if bpy.data.filepath:
        return Path(bpy.path.abspath("//cubist"))
    return unsaved_folder()


def unsaved_folder() -> Path:
    """An unsaved file's layouts and caches: per Blender session (another unsaved scene must
    not pick up this one's layout), removed when the file closes or Blender quits."""
    import os
    import tempfile

    return Path(tempfile.gettempdir()) / f"cubist-unsaved-{os.getpid()}"


def remove_unsaved_folder() -> None:
    """Removes this session's unsaved-file folder: its layouts belong to a file that is being
    closed (a new or another file is loading, or Blender quits) and that nobody can reopen."""
    global _unsaved_closed
    _unsaved_closed += 1
    shutil.rmtree(unsaved_folder(), ignore_errors=True)


# How many times the unsaved file's folder was removed: a render that used it and ends after
# a removal (File > New or quitting during the render) removes what it wrote there since.
_unsaved_closed = 0


def remove_orphaned_folders() -> None:
    """Removes the unsaved-file folders of Blender sessions that ended without removing theirs
    (killed, crashed): `cubist-unsaved-PID` whose process is gone."""
    import os
    import tempfile

    for p in Path(tempfile.gettempdir()).glob("cubist-unsaved-*"):
        pid = p.name.rsplit("-", 1)[-1]
        if pid.isdigit() and int(pid) != os.getpid() and not _process_exists(int(pid)):
            shutil.rmtree(p, ignore_errors=True)


def _process_exists(pid: int) -> bool:
    import os

    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OSError):
        return True  # another user's process, or a platform without signals: left alone
    return True


def current_layout_path(scene) -> Path:
    """The layout file the scene's current settings use (for the panel and the recompute button)."""
    props = scene.cubist
    r = scene.render
    w, h = mapping.render_size(r.resolution_x, r.resolution_y, r.resolution_percentage)
    facts = mapping.SceneFacts(width=w, height=h, frame=props.layout_frame)
    settings = mapping.settings_from_panel(_panel(props), facts)
    return runner.layout_path(layout_folder(props), scene.name, {**settings, "seed": props.seed}, props.layout_frame)


class CubistRenderEngine(bpy.types.RenderEngine):
    bl_idname = ENGINE_ID
    bl_label = "Cubist"
    bl_use_preview = False
    bl_use_postprocess = True
    # Material Preview shading stays EEVEE's; Rendered shading is ours (view_update, view_draw).
    bl_use_eevee_viewport = True

    def view_update(self, context, depsgraph):
        viewport.view_update(self, context, depsgraph)

    def view_draw(self, context, depsgraph):
        viewport.view_draw(self, context, depsgraph)

    def __del__(self):
        viewport.free(id(self))

    def update_render_passes(self, scene=None, renderlayer=None):
        self.register_pass(scene, renderlayer, "Combined", 4, "RGBA", "COLOR")
        props = getattr(scene, "cubist", None)
        if props is None:
            return
        for toggle, _name, bname, channels, chan_id, kind in mapping.PASSES:
            if getattr(props, toggle):
                self.register_pass(scene, renderlayer, bname, channels, chan_id, kind)

    def render(self, depsgraph):
        scene = depsgraph.scene_eval
        last_run.clear()
        last_run["frame"] = scene.frame_current
        self._t0 = time.monotonic()
        self._result = None  # begun by the preview, ended with the picture (or cancelled)
        self._image = None  # the server's outcome (serve_render.Outcome), else the PNG `out`
        self._claim = None  # what was rendered ahead of this render (ahead.claim)
        last_run["timeline"] = []
        unsaved_closed = _unsaved_closed
        try:
            self._render(depsgraph, scene)
        except (runner.Cancelled, export.ExportCancelled):
            last_run["cancelled"] = True
            ahead.hold()  # the user stopped this job: it is not rendered again unasked
        except runner.CubistError as e:
            last_run["error"] = str(e)
            self.report({"ERROR"}, f"Cubist: {e}")
        except OSError as e:  # a full disk, a folder that went: where and why
            where = e.filename or last_run.get("workspace")
            last_run["error"] = f"cannot write {'in ' if not e.filename else ''}{where}: {e.strerror or e}"
            self.report({"ERROR"}, f"Cubist: {last_run['error']}")
        except Exception as e:  # a bug of ours: still a clear message, never a crash
            traceback.print_exc()
            last_run["error"] = f"{type(e).__name__}: {e}"
            self.report({"ERROR"}, f"Cubist: internal error: {type(e).__name__}: {e}")
        finally:
            if self._result is not None:
                # A preview shown, no picture (cancelled, failed): the preview, which Blender
                # merged into its Render Result when it was shown, is wiped, so no coarse
                # picture is ever saved or taken for the render.
                try:
                    _, _, rw, rh = self._preview_region
                    _set_rect(_combined(self._result.layers[0]), np.zeros((rw * rh, 4), dtype=np.float32))
                    self.update_result(self._result)
                finally:
                    self.end_result(self._result, cancel=True)
                    self._result = None
            if _unsaved_closed != unsaved_closed:
                # The file closed (or Blender quits) while this frame rendered: what the render
                # wrote into the unsaved file's folder since belongs to nobody.
                shutil.rmtree(unsaved_folder(), ignore_errors=True)
            entry = {k: last_run.get(k) for k in ("frame", "settings", "layout", "prepass", "error", "cancelled",
                                                  "warnings")}
            history.append(entry)
            del history[:-HISTORY_LIMIT]
            self._mark("returned")

    # -----------------------------------------------------------------------------------------

    def _mark(self, what: str) -> None:
        """Where the time of a render goes (BENCHMARKS.md, the windowed test): seconds since
        render() began."""
        t0 = getattr(self, "_t0", None)  # set by render(); absent when a part is run on its own
        if t0 is not None:
            last_run.setdefault("timeline", []).append((what, round(time.monotonic() - t0, 4)))

    def _show_preview(self, pixels) -> None:
        """The coarse preview, blown up to the picture's size, in the Render Result while the
        picture renders (as Cycles shows its first samples)."""
        scene_render = self._scene_render
        w, h = self._size
        region_ = region(scene_render, w, h)
        if self._result is None:
            self._result = self.begin_result(0, 0, region_[2], region_[3], layer=self._layer_name)
            self._preview_region = region_
        _set_rect(_combined(self._result.layers[0]), picture.preview_rect(pixels, w, h, region_))
        self.update_result(self._result)
        self._mark("preview shown")
        last_run["preview_seconds"] = dict(last_run.get("timeline", [])).get("preview shown")

    def _put_picture(self, layer, pixels, region_: tuple) -> None:
        """8-bit pixels (top row first, the whole frame) into the layer's Combined pass over
        `region_`, as Blender decodes an sRGB PNG (picture.result_rect)."""
        _set_rect(_combined(layer), picture.result_rect(pixels, region_))

    def _cancelled(self) -> bool:
        # Asked between exported objects and while the renderer runs: the interface may draw
        # now (turns.py: while a frame renders, a thread keeps the GIL until it gives it up).
        turns.yield_turn()
        if bool(self.test_break()) or (cancel_hook is not None and bool(cancel_hook())):
            last_run.setdefault("cancel_seen", time.monotonic())  # when (diagnostics, UI test)
            claim = getattr(self, "_claim", None)
            if claim is not None and claim.status == "running":
                ahead.release(claim.prepare)  # this render waited behind it: it stops too
            return True
        return False

    def _run(self, binary: Path, glb: Path, out: Path, settings: dict, cfg: Path, frame: int, span,
             preview: bool = False) -> list:
        runner.write_settings(cfg, settings)
        last_run["settings_json"] = cfg.read_text(encoding="utf-8")
        if keep_exports is not None:
            Path(keep_exports).mkdir(parents=True, exist_ok=True)
            shutil.copyfile(cfg, Path(keep_exports) / f"{cfg.stem}_{frame:04d}.json")
        tracker = runner.ProgressTracker(*span)

        def progress(stage, fraction):
            last_run["progress_lines"] = last_run.get("progress_lines", 0) + 1
            f = tracker.update(stage, fraction)
            values = last_run.setdefault("progress", [])
            if len(values) < 10000:
                values.append(f)
            self.update_progress(f)
            self.update_stats("Cubist", f"Frame {frame} | {stage} {int(round(fraction * 100))}%")

        def started(proc):
            last_run["pid"] = proc.pid
            last_run["process"] = proc

        # The session's renderer (server.py), which keeps what it computed between renders; a
        # frame whose facets follow a saved key frame is the binary's alone (its frames route).
        if frame_job.renders_on_server(settings):
            digest = serve_render.scene_digest(glb)
            # What was rendered ahead (ahead.py): this job, finished or under way, needs no
            # preview; another one under way is cancelled, not waited for.
            self._claim = ahead.claim(digest, settings)
            last_run["ahead"] = self._claim.status if self._claim is not None else None
            if preview:
                preview = self._claim is None and serve_render.wants_preview(digest, settings)
                last_run["preview"] = preview
            self._mark("sent")
            try:
                outcome = serve_render.render(binary, glb, out.parent, settings, progress, self._cancelled,
                                              on_preview=self._show_preview if preview else None,
                                              on_start=lambda c: last_run.update(server=c.pid), digest=digest)
            except serve_render.NoServe:
                pass  # an older binary: it runs on its own below
            except runner.RendererError as e:
                raise runner.RendererError(str(e).replace(str(glb), "the exported scene"), e.returncode) from None
            else:
                # The reply says the picture is done; its last progress line comes on another
                # pipe and may not have been read yet.
                progress("done", 1.0)
                last_run["server"] = outcome.pid
                last_run["timings"] = outcome.reply.get("timings")
                last_run["reused"] = outcome.reply.get("reused")
                last_run["scene_load"] = outcome.reply.get("scene")
                # What the renderer chose for the panel's Auto values (the panel shows them).
                last_run["chosen"] = chosen.from_report(f"camera: {outcome.reply.get('camera', '')}")
                if outcome.preview_reply is not None:
                    last_run["preview_timings"] = outcome.preview_reply.get("timings")
                self._mark("reply")
                self._image = outcome
                return list(outcome.reply.get("warnings", []))
        try:
            result = runner.run(runner.build_argv(binary, glb, out, cfg), progress, self._cancelled,
                                on_start=started)
        except runner.RendererError as e:
            # The scene file is ours, in a temporary folder: name it as the user knows it.
            message = (str(e).replace(f"settings {cfg}", "the settings").replace(str(cfg), "the settings")
                       .replace(str(glb), "the exported scene"))
            raise runner.RendererError(message, e.returncode) from None
        finally:
            proc = last_run.get("process")
            if proc is not None:
                last_run["returncode"] = proc.poll()
        if not out.is_file():
            raise runner.CubistError("the renderer finished without writing an image")
        return result.warnings

    def _export(self, depsgraph, path: Path, frame: int, warnings: list):
        """Writes the depsgraph's scene as it is now evaluated; returns its settings facts."""
        stats = export.export_glb(depsgraph, path, self._cancelled, self.camera_override)
        warnings += stats.warnings
        last_run.setdefault("exports", []).append({"frame": frame, "seconds": stats.seconds,
                                                   "triangles": stats.triangles, "meshes": stats.meshes,
                                                   "instances": stats.instances})
        if keep_exports is not None:
            Path(keep_exports).mkdir(parents=True, exist_ok=True)
            shutil.copyfile(path, Path(keep_exports) / f"{path.stem}_{frame:04d}.glb")
        return export.scene_facts(depsgraph, self.camera_override)

    def _export_frame(self, depsgraph, frame: int, back_to: int, path: Path, warnings: list):
        """Exports another frame of the scene: this render's depsgraph is evaluated there
        (RenderEngine.frame_set, safe on the render thread) and then back at `back_to`."""
        self.frame_set(frame, 0.0)
        try:
            return self._export(depsgraph, path, frame, warnings)
        finally:
            self.frame_set(back_to, 0.0)

    def _render(self, depsgraph, scene):
        props = scene.cubist
        frame = scene.frame_current
        prefs = addon_preferences()
        pref_path = bpy.path.abspath(prefs.binary_path) if prefs is not None and prefs.binary_path else ""
        binary = runner.find_binary(pref_path)
        if export.scene_camera(depsgraph, self.camera_override) is None:
            raise runner.CubistError("the scene has no active camera")
        if not export.has_geometry(depsgraph):
            raise runner.CubistError(f"scene '{scene.name}' has nothing to render: add a mesh")
        panel = _panel(props)
        folder = layout_folder(props)
        view_layer = depsgraph.view_layer
        warnings: list = []

        self.update_stats("Cubist", f"Frame {frame} | exporting")
        with runner.Workspace() as tmp:
            last_run["workspace"] = tmp
            glb = tmp / "frame.glb"
            facts = self._export(depsgraph, glb, frame, warnings)
            self._mark("exported")
            self._size, self._scene_render, self._layer_name = (facts.width, facts.height), scene.render, view_layer.name
            warnings += facts.warnings
            if self._cancelled():
                raise runner.Cancelled()

            fs = frame_job.frame_settings(frame_job.FrameInputs(
                panel=panel, facts=facts, scene_name=scene.name, frame=frame, layout_frame=props.layout_frame,
                static_facets=props.static_facets, use_saliency_cache=props.use_saliency_cache, folder=folder,
                binary=binary))
            settings, layout, follow, cache = fs.settings, fs.layout, fs.follow, fs.cache
            try:
                if layout is not None:
                    folder.mkdir(parents=True, exist_ok=True)
            except OSError as e:
                where = folder if layout is not None and not folder.is_dir() else cache
                raise runner.CubistError(f"cannot create the folder {where}: {e.strerror}") from None

            # A Segment or planes layout follows what the layout frame shows, and follow data
            # is the layout frame's scene and camera: reused only while that is unchanged
            # (runner.layout_source), so a moved camera or object gives new facets.
            source = None
            pre_glb = pre_settings = None
            if fs.needs_source:
                if frame == props.layout_frame:
                    source = runner.layout_source(glb, settings)
                    _job_sources[(scene.name, frame, str(layout))] = source
                else:
                    source, pre_glb, pre_settings = self._layout_frame_source(depsgraph, scene, panel,
                                                                              props.layout_frame, layout, tmp,
                                                                              warnings)
            state = frame_job.layout_state(fs, source, frame, props.layout_frame)
            broken, current, plan = state.broken, state.current, state.plan
            if broken is not None:
                warnings.append(f"the facet layout {layout.name} could not be read ({broken}): computed again")
            if layout is not None and not current:
                runner.forget_source(layout)
            span = (0.0, 1.0)
            last_run["prepass"] = plan.prepass_frame
            if plan.prepass_frame is not None:
                # This frame is not the layout frame: compute the layout there first, so every
                # process and machine (farm chunks) gets the same one.
                self.update_stats("Cubist", f"Frame {frame} | facet layout from frame {plan.prepass_frame}")
                if pre_glb is None:
                    pre_glb = tmp / "layout.glb"
                    pre_facts = self._export_frame(depsgraph, plan.prepass_frame, frame, pre_glb, warnings)
                    pre_settings = mapping.settings_from_panel(panel, pre_facts)
                pre = dict(pre_settings)
                if "saliency_cache" in settings:
                    pre["saliency_cache"] = settings["saliency_cache"]
                pre = runner.layout_prepass(pre, layout)
                warnings += self._run(binary, pre_glb, tmp / "layout.png", pre, tmp / "layout.json",
                                      plan.prepass_frame, (0.0, 0.5))
                if source is not None and layout.is_file():
                    runner.record_source(layout, source)
                span = (0.5, 1.0)
            if layout is not None and follow and "facets" in plan.settings and not (
                    layout.is_file() and runner.follow_path(layout).is_file()):
                # Facets computed for this frame alone would differ from the other frames'.
                raise runner.CubistError(f"the renderer did not save the facet layout and follow data of frame "
                                         f"{props.layout_frame} ({layout.name})")
            if "facets" in plan.settings and not Path(plan.settings["facets"]).is_file():
                warnings.append("the renderer did not save a facet layout: facets are computed for this frame")
                del plan.settings["facets"]

            out = tmp / "render.png"
            last_run["settings"] = dict(plan.settings)
            try:
                warnings += self._run(binary, glb, out, plan.settings, tmp / "settings.json", frame, span,
                                      preview=not self.is_animation)
            except runner.RendererError as e:
                if follow and layout is not None and "triangles" in str(e):
                    # What to do about it, in the panel's words.
                    raise runner.RendererError(f"{e} (Facet Motion Follow needs the Layout Frame's meshes in "
                                               f"every frame; Static does not)", e.returncode) from None
                raise
            if "save_facets" in plan.settings:
                if not Path(plan.settings["save_facets"]).is_file():
                    warnings.append("the renderer did not save a facet layout: later frames compute their own")
                elif source is not None:
                    runner.record_source(layout, source)
            last_run["layout"] = str(layout) if layout is not None else None
            self._deliver(scene, view_layer, facts, out, plan.settings, warnings)
        last_run["warnings"] = warnings
        for w in dict.fromkeys(warnings):
            self.report({"WARNING"}, f"Cubist: {w}")

    def _layout_frame_source(self, depsgraph, scene, panel, layout_frame: int, layout: Path, tmp: Path,
                             warnings: list):
        """(source, exported scene, settings) of the layout frame, seen from another frame; the
        scene and settings are None when the source is known already. The layout frame is
        exported once per render job (F12, or a whole Render Animation) and its source kept:
        nothing is edited while a job runs."""
        key = (scene.name, layout_frame, str(layout))
        if key in _job_sources:
            return _job_sources[key], None, None
        self.update_stats("Cubist", f"Frame {scene.frame_current} | checking the facet layout of frame {layout_frame}")
        glb = tmp / "layout.glb"
        facts = self._export_frame(depsgraph, layout_frame, scene.frame_current, glb, warnings)
        settings = mapping.settings_from_panel(panel, facts)
        _job_sources[key] = runner.layout_source(glb, settings)
        return _job_sources[key], glb, settings

    def _deliver(self, scene, view_layer, facts, out: Path, settings: dict, warnings: list):
        """Loads the picture and passes into the render result, only once all are read, so a
        failure never shows half a result."""
        w, h = facts.width, facts.height
        # Render Region: the whole frame is rendered (facets and framing depend on it) and the
        # region is handed back, as Blender expects (its pixel rounding: truncation).
        x0, y0, rw, rh = region(scene.render, w, h)
        passes = {}
        for toggle, name, bname, channels, _chan, _kind in mapping.PASSES:
            if name not in settings.get("passes", []):
                continue
            path = runner.pass_path(out, name)
            if not path.is_file():
                warnings.append(f"the renderer wrote no {name} pass")
                continue
            px = _read_pass(path, w, h, channels, integer=(name == "facet-ids"))
            px = px.reshape(h, w, channels)[y0:y0 + rh, x0:x0 + rw].reshape(rw * rh, channels)
            passes[bname] = px.copy()
        pixels = None
        rect = None
        if self._image is not None:  # the server's raw pixels
            try:
                pixels = serve_client.read_rgba(self._image.image, w, h)
            except (OSError, runner.CubistError) as e:
                raise runner.CubistError(f"cannot read the renderer's picture: {e}") from None
            prepared = self._claim.prepare if self._claim is not None else None
            if prepared is not None and prepared.rect is not None and np.array_equal(prepared.pixels, pixels):
                # Rendered ahead, and converted then: the same picture needs no converting.
                rect = prepared.rect[y0:y0 + rh, x0:x0 + rw].reshape(rw * rh, 4)
                last_run["ahead_picture"] = True
        result, self._result = self._result, None
        if result is None:
            result = self.begin_result(0, 0, rw, rh, layer=view_layer.name)
        try:
            layer = result.layers[0]
            if rect is not None:
                _set_rect(_combined(layer), rect)
            elif pixels is not None:
                self._put_picture(layer, pixels, (x0, y0, rw, rh))
            else:
                layer.load_from_file(str(out), x=x0, y=y0)
            for bname, rect in passes.items():
                p = layer.passes.find_by_name(bname, "") if hasattr(layer.passes, "find_by_name") else None
                p = p or layer.passes.get(bname)
                if p is not None:
                    _set_rect(p, rect)
        except Exception:
            self.end_result(result, cancel=True)
            raise
        self.end_result(result)
        self._mark("delivered")


def _combined(layer):
    p = layer.passes.find_by_name("Combined", "") if hasattr(layer.passes, "find_by_name") else None
    return p or layer.passes["Combined"]


def _set_rect(render_pass, rect) -> None:
    """A pass's pixels, (w * h, channels) float32, copied at once: `foreach_set` takes the
    array flat in 4.x and as (w * h) rows in 3.x (a row count that does not match is a
    TypeError). Setting `rect` itself converts every value through Python: seconds at 1080p."""
    rect = np.ascontiguousarray(rect, dtype=np.float32)
    if hasattr(render_pass.rect, "foreach_set"):
        for shaped in (rect.reshape(-1), rect):
            try:
                render_pass.rect.foreach_set(shaped)
                return
            except TypeError:
                continue
    render_pass.rect = rect


def region(render, w: int, h: int) -> tuple:
    """(x, y, width, height) of the Render Region in pixels, y from the bottom; the whole
    frame without one. Blender's own rounding and its 'too small' rule: it multiplies the
    border (a float) by the size in single precision, then truncates (render_init_from_main), so
    0.7 x 120 is 84 there where Python's double precision gives 83.99999857 and so 83: a region
    one pixel short, its last row left empty."""
    if not render.use_border:
        return 0, 0, w, h

    def px(fraction: float, size: int) -> int:
        return int(np.float32(fraction) * np.float32(size))

    x0, x1 = px(render.border_min_x, w), px(render.border_max_x, w)
    y0, y1 = px(render.border_min_y, h), px(render.border_max_y, h)
    if x1 - x0 < 2 or y1 - y0 < 2:
        return 0, 0, w, h
    return x0, y0, x1 - x0, y1 - y0


def _read_pass(path: Path, w: int, h: int, channels: int, integer: bool):
    """A pass PNG as a (w*h, channels) float array, rows bottom-up as Blender stores them.
    Data, not colour: the stored values, 0-1 (8-bit) or, for facet ids (16-bit), integers.
    Read with pngio: the render thread must not add images to bpy.data."""
    try:
        px = pngio.read(path)
    except (OSError, ValueError) as e:
        raise runner.CubistError(f"cannot read the renderer's pass {path.name}: {e}") from None
    if px.shape[:2] != (h, w):
        raise runner.CubistError(f"pass {path.name} is {px.shape[1]}x{px.shape[0]}, expected {w}x{h}")
    if px.shape[2] < channels:  # a grey PNG for a colour pass
        px = np.repeat(px[..., :1], channels, axis=2)
    scale = 65535.0 if px.dtype == np.uint16 else 255.0
    px = px[::-1, :, :channels].reshape(w * h, channels).astype(np.float32)
    if not integer:
        px /= scale
    return np.ascontiguousarray(px, dtype=np.float32)


# EEVEE's panels that edit what the renderer reads: camera focus, materials' base colour,
# the world's background colour.
INCLUDE_PANELS = {"DATA_PT_camera_dof", "EEVEE_MATERIAL_PT_context_material", "EEVEE_MATERIAL_PT_surface",
                  "EEVEE_WORLD_PT_surface", "DATA_PT_EEVEE_light"}
EXCLUDE_PANELS = {"RENDER_PT_simplify", "DATA_PT_lightprobe", "DATA_PT_lightprobe_display",
                  "DATA_PT_lightprobe_visibility", "DATA_PT_lightprobe_parallax", "DATA_PT_context_lightprobe",
                  "EEVEE_MATERIAL_PT_viewport_settings"}


def get_panels():
    """Blender's own panels that apply to any engine (output, format, camera, lights...)
    (the pattern of Blender's custom render engine template)."""
    for panel in bpy.types.Panel.__subclasses__():
        compat = getattr(panel, "COMPAT_ENGINES", None)
        if compat is None or panel.__name__ in EXCLUDE_PANELS:
            continue
        if "BLENDER_RENDER" in compat or panel.__name__ in INCLUDE_PANELS:
            yield panel


def _end() -> None:
    """Blender quits or the add-on is disabled: the session's renderer ends first (it may be
    writing a saliency cache into the unsaved file's folder), then that folder goes. Render
    ahead stops before the renderer ends."""
    ahead.shutdown()
    server.shutdown()
    remove_unsaved_folder()


@bpy.app.handlers.persistent
def _render_job_starts(*_args):
    _job_sources.clear()


@bpy.app.handlers.persistent
def _file_closing(*_args):
    # load_pre: the unsaved file (if it was one) is being replaced; a saved file's layouts
    # stay beside its .blend.
    remove_unsaved_folder()


def register():
    preferences.remember(bpy.context.preferences)
    bpy.utils.register_class(CubistRenderEngine)
    bpy.app.handlers.render_init.append(_render_job_starts)
    bpy.app.handlers.load_pre.append(_file_closing)
    atexit.register(_end)
    remove_orphaned_folders()
    for panel in get_panels():
        panel.COMPAT_ENGINES.add(ENGINE_ID)


def unregister():
    if _render_job_starts in bpy.app.handlers.render_init:
        bpy.app.handlers.render_init.remove(_render_job_starts)
    if _file_closing in bpy.app.handlers.load_pre:
        bpy.app.handlers.load_pre.remove(_file_closing)
    atexit.unregister(_end)
    # Blender's Ctrl+Q disables every add-on (`addon_utils.disable_all`) before Python's exit
    # handlers run: the folder goes here. Disabling the add-on drops the layouts of an unsaved
    # file too; they are computed again when needed.
    _end()
    for panel in get_panels():
        panel.COMPAT_ENGINES.discard(ENGINE_ID)
    bpy.utils.unregister_class(CubistRenderEngine)
