"""The exporter: walks the depsgraph's object instances once and writes each evaluated mesh
(shared by its instances), material, light and the camera into a GLB. `run` reads Blender's
data; `write` builds what was left for later and writes the file (on any thread)."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Optional

from .glb import ELEMENT_ARRAY_BUFFER, ExportCancelled, GlbBuilder, gltf_matrix, without_scale
from .materials import MaterialWriter
from .meshes import BuiltMesh, read_mesh
from .scene import GEOMETRY_TYPES, camera_item, light_item, scene_camera


@dataclass
class ExportStats:
    triangles: int = 0  # placed triangles (instances counted each time)
    meshes: int = 0  # glTF meshes written (shared by instances)
    meshes_reused: int = 0  # of which the arrays came from an earlier export (read_scene's mesh_cache)
    instances: int = 0  # nodes with a mesh
    lights: int = 0
    seconds: float = 0.0
    warnings: list = field(default_factory=list)


class Exporter:
    """One export of a depsgraph to a GLB (see the module doc)."""

    def __init__(self, depsgraph, should_cancel: Callable[[], bool] = lambda: False, camera_override=None,
                 later: bool = False):
        """`later`: `run` only reads Blender's data (the meshes' arrays); `write` makes the
        glTF arrays from them and writes the file, on any thread (the viewport's worker)."""
        self.depsgraph = depsgraph
        self.later = later
        # Meshes' arrays read by an earlier export whose data did not change since (the viewport
        # knows from the depsgraph's updates), by mesh key; None: every mesh is read.
        self.mesh_cache: Optional[dict] = None
        self.meshes_read: dict = {}  # the arrays of this export, for the next one's mesh_cache
        self.mesh_triangles: dict = {}  # glTF mesh index -> its triangles
        self.should_cancel = should_cancel
        self.camera_override = camera_override
        self.glb = GlbBuilder()
        self.stats = ExportStats()
        self.mesh_index: dict = {}  # (mesh data, materials) -> glTF mesh index or None
        self.warned: set = set()
        self.materials = MaterialWriter(self.glb, self.warn)

    def warn(self, message: str) -> None:
        if message not in self.warned:
            self.warned.add(message)
            self.stats.warnings.append(message)

    # ----------------------------------------------------------------------- meshes

    def slot_materials(self, ob, me) -> list:
        """Materials per material index: the object's slot when linked to the object, else
        the mesh's (geometry nodes can add materials to the evaluated mesh)."""
        slots = ob.material_slots
        out = []
        for i, mat in enumerate(me.materials):
            if i < len(slots) and slots[i].link == "OBJECT":
                mat = slots[i].material
            out.append(mat)
        if not out:
            out = [s.material for s in slots]
        return out

    def mesh(self, ob) -> Optional[int]:
        """The glTF mesh of an evaluated object's geometry: written once per evaluated mesh
        data and materials, shared by every instance of it."""
        if ob.type == "MESH":
            me = ob.data
            mats = self.slot_materials(ob, me)
            key = (me.as_pointer(), tuple(m.as_pointer() if m else 0 for m in mats))
            if key in self.mesh_index:
                return self.mesh_index[key]
            index = self.write_mesh(ob, me, mats)
        else:
            # Curves, surfaces, text, metaballs: their evaluated geometry as a temporary mesh.
            key = ("object", ob.original.as_pointer())
            if key in self.mesh_index:
                return self.mesh_index[key]
            me = ob.to_mesh()
            try:
                index = None if me is None else self.write_mesh(ob, me, self.slot_materials(ob, me), temporary=True)
            finally:
                ob.to_mesh_clear()
        self.mesh_index[key] = index
        return index

    def write_mesh(self, ob, me, mats: list, temporary: bool = False) -> Optional[int]:
        infos = [self.materials.info(m) for m in mats]
        arrays = key = None
        if self.mesh_cache is not None and not temporary:
            # What the arrays read depend on besides the mesh's data: the materials' UV map
            # and colour attribute names (the data itself: the caller's to know unchanged).
            nv, nl = len(me.vertices), len(me.loops)
            # A few of its values too: a mesh made again at a freed one's address differs there.
            sample = (tuple(tuple(me.vertices[k].co) for k in sorted({0, nv // 2, nv - 1}) if k >= 0),
                      me.loops[nl - 1].vertex_index if nl else -1)
            key = (me.as_pointer(), nv, len(me.polygons), nl, sample,
                   tuple((i.texture.uv_map if i.texture is not None else None, i.vertex_color) if i is not None
                         else None for i in infos))
            arrays = self.mesh_cache.get(key)
            self.stats.meshes_reused += arrays is not None
        if arrays is None:
            arrays = read_mesh(ob, me, infos, temporary)
        if arrays is None:
            return None
        if key is not None:
            self.meshes_read[key] = arrays
        built = BuiltMesh(arrays)
        glb = self.glb

        def accessor(i: int, what: str, kind: str, **kw) -> int:
            if self.later:
                return glb.accessor_later(lambda: built.array(i, what), kind, **kw)
            return glb.accessor(built.array(i, what), kind, **kw)

        out = []
        for i, (m, (uvs, colors, _per_vertex)) in enumerate(zip(arrays.used, arrays.per_slot)):
            attrs = {"POSITION": accessor(i, "positions", "VEC3", bounds=True),
                     "NORMAL": accessor(i, "normals", "VEC3")}
            if uvs is not None:
                attrs["TEXCOORD_0"] = accessor(i, "uvs", "VEC2")
            if colors is not None:
                attrs["COLOR_0"] = accessor(i, "colors", "VEC4")
            item = {"attributes": attrs, "mode": 4,
                    "indices": accessor(i, "indices", "SCALAR", target=ELEMENT_ARRAY_BUFFER)}
            material = m if arrays.has_infos else None
            mat = mats[material] if material is not None and material < len(mats) else None
            index = self.materials.material(mat)
            if index is not None:
                item["material"] = index
            out.append(item)
        self.stats.meshes += 1
        mesh = self.glb.add("meshes", {"name": me.name or ob.name, "primitives": out})
        self.mesh_triangles[mesh] = arrays.triangles
        return mesh

    # ----------------------------------------------------------------------- scene

    def run(self) -> ExportStats:
        t0 = time.perf_counter()
        glb = self.glb
        roots = glb.json["scenes"][0]["nodes"]
        # Curves, text, surfaces and metaballs evaluate to a mesh that the depsgraph lists as an
        # instance of their own (Blender 3.0+): that mesh is exported, the object itself only
        # (converted with to_mesh) when no such mesh came.
        mesh_parents: set = set()
        converted: list = []
        for inst in self.depsgraph.object_instances:
            if self.should_cancel():
                raise ExportCancelled()
            ob = inst.object
            kind = ob.type
            if kind == "MESH":
                if not inst.show_self:
                    continue  # an emitter or instancer whose own geometry is not rendered
                parent = inst.parent if inst.is_instance else None
                if parent is not None:
                    mesh_parents.add(parent.original.as_pointer())
                name = ob.name if parent is None or parent.name == ob.name else f"{parent.name}/{ob.name}"
                self.place(self.mesh(ob), name, inst.matrix_world)
            elif kind in GEOMETRY_TYPES:
                if inst.show_self and not inst.is_instance:
                    converted.append(ob)
            elif kind == "LIGHT":
                light = self.light(ob.data, inst.matrix_world)
                if light is not None:
                    roots.append(glb.add("nodes", {
                        "name": ob.name, "matrix": gltf_matrix(without_scale(inst.matrix_world)),
                        "extensions": {"KHR_lights_punctual": {"light": light}}}))
                    self.stats.lights += 1
        for ob in converted:
            if ob.original.as_pointer() not in mesh_parents:
                self.place(self.mesh(ob), ob.name, ob.matrix_world)
        cam = scene_camera(self.depsgraph, self.camera_override)
        if cam is not None:
            camera = glb.add("cameras", camera_item(cam, self.depsgraph.scene_eval))
            # First in the scene: the loader takes the first camera node.
            roots.insert(0, glb.add("nodes", {"name": cam.name, "camera": camera,
                                              "matrix": gltf_matrix(without_scale(cam.matrix_world))}))
        self.stats.seconds = time.perf_counter() - t0
        return self.stats

    def place(self, mesh: Optional[int], name: str, matrix) -> None:
        if mesh is None:
            return
        self.glb.json["scenes"][0]["nodes"].append(
            self.glb.add("nodes", {"name": name, "mesh": mesh, "matrix": gltf_matrix(matrix)}))
        self.stats.instances += 1
        self.stats.triangles += self.triangles_of(mesh)

    def triangles_of(self, mesh: int) -> int:
        return self.mesh_triangles[mesh]

    def write(self, path: Path, should_cancel: Callable[[], bool] = lambda: False) -> None:
        """Makes what was left for later (`later`: no Blender data is read) and writes the file."""
        t0 = time.perf_counter()
        self.glb.finish(should_cancel)
        self.glb.write(Path(path))
        self.stats.seconds += time.perf_counter() - t0

    def light(self, data, matrix) -> Optional[int]:
        """The index of a Blender light among the file's KHR_lights_punctual lights (None: a
        kind glTF cannot carry)."""
        item = light_item(data, matrix)
        if item is None:
            return None
        self.glb.use_extension("KHR_lights_punctual")
        lights = self.glb.json.setdefault("extensions", {}).setdefault("KHR_lights_punctual", {"lights": []})
        lights["lights"].append(item)
        return len(lights["lights"]) - 1
