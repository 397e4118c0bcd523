"""What a change in Blender does to a viewport (main thread, `view_update` and `view_draw`):
the scene read again when its content changed, the settings made from the panel and the view,
and a job handed to the session unless it is the one it has."""

from __future__ import annotations

import json
from typing import Optional

import bpy

from .. import export, runner
from .session import SceneExport, ViewportSession
from .view import View, settings_for


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
