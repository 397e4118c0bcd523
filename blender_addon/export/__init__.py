"""Exports what the renderer needs from the depsgraph `RenderEngine.render()` receives: a binary
glTF (GLB) written here with numpy, and the plain facts (size, camera, world colour) mapping.py
turns into settings.

Why not Blender's glTF exporter: it is an operator (`bpy.ops`), and in the interactive UI F12
runs `render()` on Blender's render-job thread, where operators and `bpy.context` are unusable
and forcing a window context crashes Blender (docs/blender.md). The depsgraph given to `render()`
is already evaluated at the frame being rendered, with modifiers at their render levels and
instancing (particles, geometry nodes, collections) expanded in `object_instances`. Reading
it, the mesh data as whole arrays (`foreach_get`), never a Python loop per vertex, is safe on
that thread and fast (BENCHMARKS.md: the 1M-triangle scene).

Nothing in this package touches `bpy.context`, `bpy.ops`, `bpy.data` collections or the
scene's frame.

What the GLB holds (read by src/scene/gltf.rs): one glTF mesh per evaluated mesh data (shared
by all its instances), one primitive per material with POSITION, NORMAL, TEXCOORD_0 (when the
material has a texture), COLOR_0 (when the material uses a colour attribute, or the object has
no material), uint32/uint16 indices; materials with base colour factor and texture (the image
file's own PNG/JPEG bytes, else the pixels encoded as PNG), sampler wrap and filter, the Mapping
node as KHR_texture_transform, metallic, roughness, Emission as KHR_materials_unlit; one node
per instance; the camera; lights as KHR_lights_punctual (the units of Blender's glTF exporter).
Coordinates: mesh data stays in Blender's local axes and each node's matrix carries the Z-up
to Y-up turn, so (x, y, z) in Blender is (x, z, -y) in the file (mapping.to_gltf).

The package, one concept a file: `exporter` walks the depsgraph; `meshes` (with `arrays`,
`triangles`, `weld`) makes a mesh's primitives; `materials` (with `images`) its materials;
`scene` the camera, lights and the facts for the settings; `glb` the container.
"""

from __future__ import annotations

from pathlib import Path
from typing import Callable, Optional

from .exporter import Exporter, ExportStats
from .glb import ExportCancelled
from .scene import camera_facts, has_geometry, scene_camera, scene_facts, world_background
from .triangles import triangulate

__all__ = ["ExportCancelled", "ExportStats", "Exporter", "camera_facts", "export_glb", "has_geometry",
           "read_scene", "scene_camera", "scene_facts", "triangulate", "world_background"]


def export_glb(depsgraph, path: Path, should_cancel: Callable[[], bool] = lambda: False,
               camera_override=None) -> ExportStats:
    """Writes the depsgraph's evaluated scene (at the frame it was evaluated for) to `path`."""
    exporter = Exporter(depsgraph, should_cancel, camera_override)
    stats = exporter.run()
    exporter.write(path)
    return stats


def read_scene(depsgraph, should_cancel: Callable[[], bool] = lambda: False, camera_override=None,
               mesh_cache: Optional[dict] = None) -> Exporter:
    """The first half of `export_glb` (main thread: Blender's data is read, nothing built);
    `.write(path)` (any thread) writes the same file `export_glb` would have written.
    `mesh_cache`: an earlier export's `meshes_read`, when no mesh's data changed since (the
    evaluated meshes are then the same, at the same addresses): their arrays are not read again."""
    exporter = Exporter(depsgraph, should_cancel, camera_override, later=True)
    exporter.mesh_cache = {} if mesh_cache is None else mesh_cache  # keys kept for the next read
    exporter.run()
    return exporter
