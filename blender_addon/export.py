"""Exports what the renderer needs from the depsgraph `RenderEngine.render()` receives: a binary
glTF (GLB) written here with numpy, and the plain facts (size, camera, world colour) mapping.py
turns into settings.

Why not Blender's glTF exporter: it is an operator (`bpy.ops`), and in the interactive UI F12
runs `render()` on Blender's render-job thread, where operators and `bpy.context` are unusable
and forcing a window context crashes Blender (TOOLCHAIN.md). The depsgraph given to `render()`
is already evaluated at the frame being rendered, with modifiers at their render levels and
instancing (particles, geometry nodes, collections) expanded in `object_instances`. Reading
it, the mesh data as whole arrays (`foreach_get`), never a Python loop per vertex, is safe on
that thread and fast (BENCHMARKS.md: the 1M-triangle scene).

Nothing here touches `bpy.context`, `bpy.ops`, `bpy.data` collections or the scene's frame.

What the GLB holds (read by src/scene/gltf.rs): one glTF mesh per evaluated mesh data (shared
by all its instances), one primitive per material with POSITION, NORMAL, TEXCOORD_0 (when the
material has a texture), COLOR_0 (when the material uses a colour attribute, or the object has
no material), uint32/uint16 indices; materials with base colour factor and texture (the image
file's own PNG/JPEG bytes, else the pixels encoded as PNG), sampler wrap and filter, the Mapping
node as KHR_texture_transform, metallic, roughness, Emission as KHR_materials_unlit; one node
per instance; the camera; lights as KHR_lights_punctual (the units of Blender's glTF exporter).
Coordinates: mesh data stays in Blender's local axes and each node's matrix carries the Z-up
to Y-up turn, so (x, y, z) in Blender is (x, z, -y) in the file (mapping.to_gltf).
"""

from __future__ import annotations

import json
import math
import struct
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Optional

import numpy as np

import bpy

from . import pngio
from .mapping import CameraFacts, SceneFacts, render_size

# Blender Z-up -> glTF Y-up: (x, y, z) -> (x, z, -y).
Y_UP = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, -1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 1.0]])

GEOMETRY_TYPES = {"MESH", "CURVE", "SURFACE", "FONT", "META"}

# Blender's glTF exporter's photometric conversion (lighting mode "Standard"): W -> lm.
WATTS_TO_LUMENS = 683.0

# glTF constants.
FLOAT, UNSIGNED_SHORT, UNSIGNED_INT = 5126, 5123, 5125
ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963
REPEAT, CLAMP_TO_EDGE, MIRRORED_REPEAT = 10497, 33071, 33648
NEAREST, LINEAR = 9728, 9729
WRAP = {"REPEAT": REPEAT, "EXTEND": CLAMP_TO_EDGE, "CLIP": CLAMP_TO_EDGE, "MIRROR": MIRRORED_REPEAT}

# A mesh whose n-gons make more triangles than this reads all its triangles from Blender's
# `loop_triangles` (one slow call) instead of one Python call per n-gon triangle.
NGON_TRIANGLES_ONE_BY_ONE = 20000
# Welding rounds before the general (sorting) fallback; see `weld`.
WELD_ROUNDS = 12


class ExportCancelled(Exception):
    """The user cancelled while the scene was being exported."""


@dataclass
class ExportStats:
    triangles: int = 0  # placed triangles (instances counted each time)
    meshes: int = 0  # glTF meshes written (shared by instances)
    meshes_reused: int = 0  # of which the arrays came from an earlier export (read_scene's mesh_cache)
    instances: int = 0  # nodes with a mesh
    lights: int = 0
    seconds: float = 0.0
    warnings: list = field(default_factory=list)


# ---------------------------------------------------------------------------------------------
# Facts for the settings (mapping.py)


def world_background(world):
    """The world's background colour in linear RGB (the Background node feeding the World
    Output, times its strength; else the world's viewport colour), or None without a world."""
    if world is None:
        return None
    # Blender 5 always renders the world's nodes (`use_nodes` is deprecated); 4.x only when on.
    uses_nodes = bpy.app.version >= (5, 0, 0) or world.use_nodes
    tree = world.node_tree if uses_nodes else None
    if tree is not None:
        out = next((n for n in tree.nodes if n.type == "OUTPUT_WORLD" and n.is_active_output), None)
        if out is None:
            out = next((n for n in tree.nodes if n.type == "OUTPUT_WORLD"), None)
        surface = out.inputs.get("Surface") if out is not None else None
        if surface is not None and surface.is_linked:
            node = surface.links[0].from_node
            if node.type == "BACKGROUND":
                color, strength = node.inputs["Color"], node.inputs["Strength"]
                if not color.is_linked:
                    k = strength.default_value if not strength.is_linked else 1.0
                    return [c * k for c in color.default_value[:3]]
    return list(world.color[:3])


def camera_facts(cam_obj) -> CameraFacts:
    """The evaluated camera object's frame, lens and focus (at the depsgraph's frame)."""
    data = cam_obj.data
    focus_loc = None
    dof = data.dof
    if dof.focus_object is not None:
        focus_loc = list(dof.focus_object.matrix_world.translation)
    return CameraFacts(
        matrix_world=[list(r) for r in cam_obj.matrix_world],
        type=data.type,
        lens=data.lens,
        sensor_width=data.sensor_width,
        sensor_height=data.sensor_height,
        sensor_fit=data.sensor_fit,
        ortho_scale=data.ortho_scale,
        use_dof=dof.use_dof,
        focus_distance=dof.focus_distance,
        focus_object_location=focus_loc,
    )


def scene_camera(depsgraph, camera_override=None):
    """The evaluated camera the frame is rendered through (camera markers already applied)."""
    cam = camera_override if camera_override is not None else depsgraph.scene_eval.camera
    if cam is None:
        return None
    return cam.evaluated_get(depsgraph)


def scene_facts(depsgraph, camera_override=None) -> SceneFacts:
    """Size, frame, camera and world of the depsgraph's evaluated scene."""
    scene = depsgraph.scene_eval
    r = scene.render
    w, h = render_size(r.resolution_x, r.resolution_y, r.resolution_percentage)
    cam = scene_camera(depsgraph, camera_override)
    return SceneFacts(
        width=w,
        height=h,
        frame=scene.frame_current,
        camera=camera_facts(cam) if cam is not None else None,
        background=world_background(scene.world),
        transparent=r.film_transparent,
    )


def has_geometry(depsgraph) -> bool:
    """Whether anything visible renders as triangles (meshes, curves, text, metaballs...)."""
    for inst in depsgraph.object_instances:
        if inst.object.type in GEOMETRY_TYPES:
            return True
    return False


# ---------------------------------------------------------------------------------------------
# The GLB container


class GlbBuilder:
    """Binary chunk and JSON of a GLB: buffer views are appended 4-byte aligned.

    An accessor's array may be given later (`accessor_later`: a function making it): its
    place in the JSON and the buffer is taken at once, its contents are made by `finish`, which
    may run on another thread (the viewport's worker: the arrays read from Blender on the main
    thread are turned into glTF there). The file is the same either way."""

    def __init__(self):
        self.parts: list = []  # per buffer view: its bytes (None while pending)
        self.pending: list = []  # (accessor, view, make, bounds) in order
        self.size = 0
        self.json: dict = {"asset": {"version": "2.0", "generator": "cubist Blender add-on"}, "scene": 0,
                           "scenes": [{"nodes": []}], "nodes": [], "bufferViews": [], "accessors": []}

    def view(self, data: Optional[bytes], target: Optional[int] = None) -> int:
        view = {"buffer": 0, "byteOffset": 0, "byteLength": 0 if data is None else len(data)}
        if target is not None:
            view["target"] = target
        self.parts.append(data)
        self.json["bufferViews"].append(view)
        return len(self.json["bufferViews"]) - 1

    def _fill(self, acc: dict, array: np.ndarray, bounds: bool) -> bytes:
        array = np.ascontiguousarray(array)
        acc["componentType"] = {np.dtype(np.float32): FLOAT, np.dtype(np.uint32): UNSIGNED_INT,
                                np.dtype(np.uint16): UNSIGNED_SHORT}[array.dtype]
        acc["count"] = int(array.shape[0])
        if bounds and len(array):
            acc["min"] = [float(v) for v in array.min(axis=0)]
            acc["max"] = [float(v) for v in array.max(axis=0)]
        return array.tobytes()

    def accessor(self, array: np.ndarray, kind: str, bounds: bool = False, target: int = ARRAY_BUFFER) -> int:
        acc = {"bufferView": 0, "componentType": 0, "count": 0, "type": kind}
        data = self._fill(acc, array, bounds)
        acc["bufferView"] = self.view(data, target)
        self.json["accessors"].append(acc)
        return len(self.json["accessors"]) - 1

    def accessor_later(self, make: Callable[[], np.ndarray], kind: str, bounds: bool = False,
                       target: int = ARRAY_BUFFER) -> int:
        """An accessor whose array `make()` gives when `finish` runs."""
        acc = {"bufferView": self.view(None, target), "componentType": 0, "count": 0, "type": kind}
        self.json["accessors"].append(acc)
        self.pending.append((acc, acc["bufferView"], make, bounds))
        return len(self.json["accessors"]) - 1

    def finish(self, should_cancel: Callable[[], bool] = lambda: False) -> None:
        """Makes the pending arrays (no Blender data is read here) and lays out the buffer."""
        for acc, view, make, bounds in self.pending:
            if should_cancel():
                raise ExportCancelled()
            data = self._fill(acc, make(), bounds)
            self.parts[view] = data
            self.json["bufferViews"][view]["byteLength"] = len(data)
        self.pending = []
        size = 0
        for view, data in zip(self.json["bufferViews"], self.parts):
            size += (-size) % 4
            view["byteOffset"] = size
            size += len(data)
        self.size = size

    def add(self, key: str, item: dict) -> int:
        self.json.setdefault(key, []).append(item)
        return len(self.json[key]) - 1

    def write(self, path: Path) -> None:
        self.finish()
        size = self.size + (-self.size) % 4
        if size:
            self.json["buffers"] = [{"byteLength": size}]
        else:
            del self.json["bufferViews"], self.json["accessors"]
        text = json.dumps(self.json, separators=(",", ":")).encode("utf-8")
        text += b" " * ((-len(text)) % 4)
        total = 12 + 8 + len(text) + (8 + size if size else 0)
        with open(path, "wb") as f:
            f.write(struct.pack("<4sII", b"glTF", 2, total))
            f.write(struct.pack("<I4s", len(text), b"JSON"))
            f.write(text)
            if size:
                f.write(struct.pack("<I4s", size, b"BIN\0"))
                offset = 0
                for data in self.parts:
                    pad = (-offset) % 4
                    if pad:
                        f.write(b"\0" * pad)
                    f.write(data)
                    offset += pad + len(data)
                if size > offset:
                    f.write(b"\0" * (size - offset))


def gltf_matrix(m) -> list:
    """A Blender world matrix (4x4, rows) as a glTF node matrix: turned Y-up, column-major."""
    return (Y_UP @ np.asarray(m, dtype=np.float64)).T.reshape(-1).tolist()


def without_scale(m) -> np.ndarray:
    """Rotation and translation of a matrix (cameras and lights: their axes matter, not scale)."""
    m = np.array(m, dtype=np.float64)
    for c in range(3):
        n = np.linalg.norm(m[:3, c])
        if n > 0:
            m[:3, c] /= n
    return m


# ---------------------------------------------------------------------------------------------
# Materials


@dataclass
class TextureInfo:
    image: object  # bpy.types.Image (original)
    uv_map: str = ""  # "" = the mesh's active render UV map
    wrap: int = REPEAT
    nearest: bool = False
    transform: Optional[dict] = None  # KHR_texture_transform


@dataclass
class MaterialInfo:
    name: str
    base_color: list
    metallic: float = 0.0
    roughness: float = 0.5
    unlit: bool = False
    texture: Optional[TextureInfo] = None
    # Colour attribute multiplying the base colour: None, or its name ("" = the render colour).
    vertex_color: Optional[str] = None
    warnings: list = field(default_factory=list)


def _source(socket):
    """(node, output socket) feeding an input socket, through reroutes; None when unlinked."""
    seen = 0
    while socket is not None and socket.is_linked and seen < 64:
        link = socket.links[0]
        if getattr(link, "is_muted", False) or not link.is_valid:
            return None
        node = link.from_node
        if node.type == "REROUTE":
            socket = node.inputs[0]
            seen += 1
            continue
        return node, link.from_socket
    return None


def _input(node, *names):
    for name in names:
        for sock in node.inputs:
            if sock.identifier == name or (sock.name == name and sock.enabled):
                return sock
    return None


@dataclass
class _Colour:
    factor: list  # linear RGBA
    texture: Optional[TextureInfo] = None
    vertex_color: Optional[str] = None
    supported: bool = True
    what: str = ""


def _colour_source(socket, depth: int = 0) -> _Colour:
    """What feeds a colour input: a constant, an Image Texture, a colour attribute, or a
    Multiply mix of those (the cases Blender's glTF exporter also recognises)."""
    if socket is None:
        return _Colour([1.0, 1.0, 1.0, 1.0])
    src = _source(socket)
    if src is None:
        v = list(socket.default_value)
        return _Colour((v + [1.0])[:4] if len(v) == 3 else v[:4])
    node, _out = src
    if node.type == "TEX_IMAGE":
        if node.image is None:
            return _Colour([1.0, 1.0, 1.0, 1.0], supported=False, what="an Image Texture without an image")
        return _Colour([1.0, 1.0, 1.0, 1.0], texture=_texture_info(node))
    if node.type == "VERTEX_COLOR":
        return _Colour([1.0, 1.0, 1.0, 1.0], vertex_color=node.layer_name)
    if node.type == "ATTRIBUTE" and getattr(node, "attribute_type", "GEOMETRY") == "GEOMETRY":
        return _Colour([1.0, 1.0, 1.0, 1.0], vertex_color=node.attribute_name)
    if node.type in {"MIX", "MIX_RGB"} and depth < 4:
        if node.type == "MIX":
            if getattr(node, "data_type", "RGBA") != "RGBA":
                return _Colour([1.0] * 4, supported=False, what=f"a {node.bl_label} node")
            fac, a, b = _input(node, "Factor_Float", "Factor"), _input(node, "A_Color"), _input(node, "B_Color")
        else:
            fac, a, b = _input(node, "Fac"), _input(node, "Color1"), _input(node, "Color2")
        if (node.blend_type == "MULTIPLY" and fac is not None and not fac.is_linked
                and abs(fac.default_value - 1.0) < 1e-6 and a is not None and b is not None):
            ca, cb = _colour_source(a, depth + 1), _colour_source(b, depth + 1)
            if ca.supported and cb.supported and not (ca.texture and cb.texture) and not (
                    ca.vertex_color is not None and cb.vertex_color is not None):
                return _Colour([x * y for x, y in zip(ca.factor, cb.factor)], ca.texture or cb.texture,
                               ca.vertex_color if ca.vertex_color is not None else cb.vertex_color)
    return _Colour([1.0, 1.0, 1.0, 1.0], supported=False, what=f"a {node.bl_label} node")


def _texture_info(node) -> TextureInfo:
    info = TextureInfo(image=getattr(node.image, "original", node.image) or node.image,
                       wrap=WRAP.get(node.extension, REPEAT), nearest=node.interpolation == "Closest")
    src = _source(node.inputs.get("Vector"))
    if src is not None and src[0].type == "MAPPING":
        info.transform = _texture_transform(src[0])
        src = _source(src[0].inputs.get("Vector"))
    if src is not None and src[0].type == "UVMAP":
        info.uv_map = src[0].uv_map
    return info


def _texture_transform(mapping) -> Optional[dict]:
    """A Point-type Mapping node (its z rotation and x/y scale and location) as
    KHR_texture_transform. glTF's v runs down the image (v = 1 - v_Blender): conjugating the
    node's affine map by that flip keeps rotation and scale and moves the offset."""
    if mapping.vector_type != "POINT":
        return None
    loc, rot, scale = (mapping.inputs.get(k) for k in ("Location", "Rotation", "Scale"))
    if any(s is None or s.is_linked for s in (loc, rot, scale)):
        return None
    tx, ty = loc.default_value[0], loc.default_value[1]
    r = rot.default_value[2]
    sx, sy = scale.default_value[0], scale.default_value[1]
    c, s = math.cos(r), math.sin(r)
    b, e = -s * sy, c * sy  # the node's map: u' = c sx u - s sy v + tx, v' = s sx u + c sy v + ty
    return {"offset": [tx + b, 1.0 - e - ty], "rotation": r, "scale": [sx, sy]}


# Shaders that give a surface its colour, in order of preference when Mix/Add Shader nodes
# combine several (Blender's glTF importer makes unlit materials as Transparent + Emission).
COLOUR_SHADERS = ("BSDF_PRINCIPLED", "BSDF_DIFFUSE", "EMISSION", "BACKGROUND")
NO_COLOUR_SHADERS = {"BSDF_TRANSPARENT", "HOLDOUT", "MIX_SHADER", "ADD_SHADER"}


def _surface_shader(tree):
    """The shader node that colours the surface: the one feeding the active Material Output,
    or through Mix/Add Shader nodes the preferred of the shaders they combine."""
    out = None
    get_output = getattr(tree, "get_output_node", None)
    if get_output is not None:
        for target in ("ALL", "CYCLES", "EEVEE"):
            try:
                out = get_output(target)
            except TypeError:
                out = None
            if out is not None:
                break
    if out is None:
        out = next((n for n in tree.nodes if n.type == "OUTPUT_MATERIAL"), None)
    if out is None:
        return None
    leaves, stack, visited = [], [out.inputs.get("Surface")], 0
    while stack and visited < 64:
        visited += 1
        src = _source(stack.pop())
        if src is None:
            continue
        node = src[0]
        if node.type in {"MIX_SHADER", "ADD_SHADER"}:
            stack.extend(reversed([s for s in node.inputs if s.type == "SHADER"]))
        else:
            leaves.append(node)
    for kind in COLOUR_SHADERS:
        found = next((n for n in leaves if n.type == kind), None)
        if found is not None:
            return found
    return next((n for n in leaves if n.type not in NO_COLOUR_SHADERS), None)


def material_info(mat) -> MaterialInfo:
    """What the renderer takes from a material: the Principled BSDF's (or a Diffuse / Emission
    shader's) base colour with its texture or colour attribute, metallic, roughness. A base
    colour made by other nodes falls back to the material's viewport colour, with a warning."""
    name = mat.name
    viewport = list(mat.diffuse_color)
    info = MaterialInfo(name=name, base_color=viewport, metallic=float(mat.metallic),
                        roughness=float(mat.roughness))
    tree = mat.node_tree if (bpy.app.version >= (5, 0, 0) or mat.use_nodes) else None
    if tree is None:
        return info
    shader = _surface_shader(tree)
    if shader is None:
        return info
    if shader.type == "EMISSION" or shader.type == "BACKGROUND":
        info.unlit = True
    colour_input = _input(shader, "Base Color", "Color")
    if colour_input is None:
        info.warnings.append(f"material '{name}': its {shader.bl_label} shader has no colour: viewport colour used")
        return info
    colour = _colour_source(colour_input)
    if not colour.supported:
        info.warnings.append(f"material '{name}': base colour from {colour.what}: its viewport colour is used")
        return info
    alpha = _input(shader, "Alpha")
    if alpha is not None and not alpha.is_linked:
        colour.factor[3] *= float(alpha.default_value)
    info.base_color = colour.factor
    info.texture = colour.texture
    info.vertex_color = colour.vertex_color
    for key in ("Metallic", "Roughness"):
        sock = _input(shader, key)
        if sock is not None:
            # Linked (a texture): glTF's factor 1, as Blender's exporter writes it beside the
            # texture the renderer does not read.
            setattr(info, key.lower(), 1.0 if sock.is_linked else float(sock.default_value))
    return info


# ---------------------------------------------------------------------------------------------
# Meshes


def _get(collection, prop: str, count: int, dtype, width: int = 1) -> np.ndarray:
    a = np.empty(count * width, dtype=dtype)
    if count:
        collection.foreach_get(prop, a)
    return a.reshape(count, width) if width > 1 else a


def _attribute(me, name: str, domain: str, width: int, prop: str, dtype=np.float32):
    """A generic attribute as an array (the fast path of Blender 3.5+), or None when absent."""
    attrs = getattr(me, "attributes", None)
    if attrs is None:
        return None
    a = attrs.get(name)
    if a is None or a.domain != domain:
        return None
    return _get(a.data, prop, len(a.data), dtype, width)


def loop_triangles_of_ngons(me, npoly: int, nloops: int, sizes: np.ndarray):
    """What `triangulate` needs of Blender's `loop_triangles` (read on the main thread): None
    without n-gons, else all of them (many n-gon triangles) or {triangle: corners} of the
    n-gons' triangles (few: read one by one)."""
    ngons = np.flatnonzero(sizes > 4)
    if not len(ngons):
        return None
    ntri = int(nloops - 2 * npoly)
    count = int((sizes[ngons] - 2).sum())
    if count > NGON_TRIANGLES_ONE_BY_ONE:
        return _get(me.loop_triangles, "loops", ntri, np.int32, 3)
    starts = (np.cumsum(sizes, dtype=np.int64) - sizes).astype(np.int32)
    tri_start = starts - 2 * np.arange(npoly, dtype=np.int32)
    lts = me.loop_triangles
    out = {}
    for p in ngons.tolist():
        for i in range(int(tri_start[p]), int(tri_start[p]) + int(sizes[p]) - 2):
            out[i] = tuple(lts[i].loops)
    return out


def triangulate(me, npoly: int, nloops: int, positions: np.ndarray, corner_vert: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(triangles as corner indices (n, 3), polygon of each triangle, corners per polygon),
    in the order of Blender's `loop_triangles`: triangles and quads here in numpy, split as
    Blender splits them (`quad_flipped`), n-gons read from `loop_triangles`."""
    sizes = _get(me.polygons, "loop_total", npoly, np.int32)
    return triangulate_arrays(sizes, npoly, nloops, positions, corner_vert,
                              loop_triangles_of_ngons(me, npoly, nloops, sizes))


def triangulate_arrays(sizes: np.ndarray, npoly: int, nloops: int, positions: np.ndarray, corner_vert: np.ndarray,
                       ngon_tris) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """`triangulate` from arrays (no Blender data): `ngon_tris` from `loop_triangles_of_ngons`."""
    ntri = int(nloops - 2 * npoly)
    poly_of = np.repeat(np.arange(npoly, dtype=np.int32), sizes - 2)
    if (sizes == 3).all():
        return np.arange(nloops, dtype=np.int32).reshape(-1, 3), poly_of, sizes
    starts = (np.cumsum(sizes, dtype=np.int64) - sizes).astype(np.int32)
    tri_start = starts - 2 * np.arange(npoly, dtype=np.int32)
    tris = np.empty((ntri, 3), dtype=np.int32)
    t = sizes == 3
    tris[tri_start[t]] = starts[t, None] + np.array([0, 1, 2], dtype=np.int32)
    quads = np.flatnonzero(sizes == 4)
    if len(quads):
        c = starts[quads, None] + np.arange(4, dtype=np.int32)
        corners_xyz = positions[corner_vert[c]]  # (quads, 4, 3)
        flip = quad_flipped(*(corners_xyz[:, k] for k in range(4)))
        first = np.where(flip[:, None], c[:, [0, 1, 3]], c[:, [0, 1, 2]])
        second = np.where(flip[:, None], c[:, [1, 2, 3]], c[:, [0, 2, 3]])
        if len(quads) == npoly:  # all quads (subdivision surfaces): no scattered writes
            tris = np.stack([first, second], axis=1).reshape(-1, 3)
        else:
            tris[tri_start[quads]] = first
            tris[tri_start[quads] + 1] = second
    if isinstance(ngon_tris, np.ndarray):
        tris[:] = ngon_tris
    elif ngon_tris:
        for i, corners in ngon_tris.items():
            tris[i] = corners
    return tris, poly_of, sizes


def quad_flipped(v1, v2, v3, v4) -> np.ndarray:
    """Whether Blender splits a quad along its 2-4 diagonal (triangles 1-2-4, 2-3-4) instead of
    1-3: when corners 2 and 4 lie on the same side of the 1-3 diagonal (a bent or concave quad),
    as Blender's `is_quad_flip_v3_first_third_fast` decides, in 32-bit floats like it."""
    a, b, c = (v2 - v1).T, (v3 - v1).T, (v4 - v1).T
    # cross(a, b) . cross(c, b), component by component (fewer temporaries than np.cross).
    x = (a[1] * b[2] - a[2] * b[1]) * (c[1] * b[2] - c[2] * b[1])
    x += (a[2] * b[0] - a[0] * b[2]) * (c[2] * b[0] - c[0] * b[2])
    x += (a[0] * b[1] - a[1] * b[0]) * (c[0] * b[1] - c[1] * b[0])
    return x > 0.0


def read_normals(ob, me, nverts: int, npoly: int, nloops: int, temporary: bool = False) -> tuple:
    """The shading normals as Blender renders them (smooth/flat faces, sharp edges, custom
    normals), as read (main thread; `shading_normals` makes the arrays the glTF gets from
    them): ("vertex", per vertex) when every face is smooth without sharp edges, ("face", per
    face) when every face is flat, ("mixed", per vertex, per face, smooth per face), ("corner",
    per corner); and whether the faces are flat (a vertex is then a glTF vertex per face).
    Per-vertex and per-face arrays (fast to read) when they say it all; Blender's per-corner
    array (slow to read: one value at a time) only when the mesh needs it. `temporary`: `me`
    is our own copy (`to_mesh`), which may be written to."""
    props = me.bl_rna.properties
    if "normals_domain" in props:  # Blender 4.1+
        domain = me.normals_domain
        if domain == "POINT":
            return ("vertex", _get(me.vertex_normals, "vector", nverts, np.float32, 3)), False
        if domain == "FACE":
            return ("face", _get(me.polygon_normals, "vector", npoly, np.float32, 3)), True
        # Sharp faces or edges split the fans around a vertex: only Blender's corner normals
        # have the averages over each fan.
        return ("corner", _get(me.corner_normals, "vector", nloops, np.float32, 3)), False
    # Blender 3.x / 4.0: split normals only with Auto Smooth or custom normals, and computing
    # them writes to the mesh: on a temporary copy.
    smooth = _get(me.polygons, "use_smooth", npoly, bool)
    if getattr(me, "use_auto_smooth", False) or me.has_custom_normals:
        flat = not smooth.any()
        if temporary:
            me.calc_normals_split()
            return ("corner", _get(me.loops, "normal", nloops, np.float32, 3)), flat
        tmp = ob.to_mesh()
        try:
            tmp.calc_normals_split()
            return ("corner", _get(tmp.loops, "normal", nloops, np.float32, 3)), flat
        finally:
            ob.to_mesh_clear()
    if smooth.all():
        return ("vertex", _get(me.vertices, "normal", nverts, np.float32, 3)), False
    fn = _get(me.polygons, "normal", npoly, np.float32, 3)
    if not smooth.any():
        return ("face", fn), True
    return ("mixed", _get(me.vertices, "normal", nverts, np.float32, 3), fn, smooth), False


def shading_normals(read: tuple, corner_vert: np.ndarray, poly_of_corner: np.ndarray
                    ) -> tuple[Optional[np.ndarray], Optional[np.ndarray]]:
    """(per vertex, None) or (None, per corner): the normals `read_normals` read, as the glTF
    vertices get them (no Blender data is read here)."""
    kind = read[0]
    if kind == "vertex":
        return read[1], None
    if kind == "face":
        return None, read[1][poly_of_corner]
    if kind == "corner":
        return None, read[1]
    _, vn, fn, smooth = read
    return None, np.where(smooth[poly_of_corner][:, None], vn[corner_vert], fn[poly_of_corner])


def corner_uvs(me, name: str, nloops: int) -> Optional[np.ndarray]:
    """The UV map `name` (else the active render one) per corner, v flipped for glTF."""
    layers = me.uv_layers
    layer = layers.get(name) if name else None
    if layer is None:
        layer = next((u for u in layers if u.active_render), None) or layers.active
    if layer is None:
        return None
    uv = _attribute(me, layer.name, "CORNER", 2, "vector")
    if uv is None or len(uv) != nloops:
        uv = _get(layer.data, "uv", nloops, np.float32, 2)
    uv = uv.copy()
    uv[:, 1] = 1.0 - uv[:, 1]
    return uv


def vertex_colors(me, name: Optional[str]) -> tuple[Optional[np.ndarray], bool]:
    """The colour attribute `name` ("" = the render colour) as linear RGBA: (values, whether
    they are per vertex (else per corner))."""
    attrs = getattr(me, "color_attributes", None)
    if attrs is None or name is None or not len(attrs):
        return None, False
    attr = attrs.get(name) if name else None
    if attr is None:
        index = getattr(attrs, "render_color_index", -1)
        if 0 <= index < len(attrs):
            attr = attrs[index]
        else:
            default = getattr(me, "default_color_name", "") or getattr(attrs, "default_color_name", "")
            attr = attrs.get(default) if default else attrs.active_color
    if attr is None or attr.domain not in {"POINT", "CORNER"}:
        return None, False
    return _get(attr.data, "color", len(attr.data), np.float32, 4), attr.domain == "POINT"


def weld(corner_vert: np.ndarray, attrs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """glTF vertices from Blender corners: corners of one vertex share a glTF vertex when all
    their attributes (normal, UV, colour) are bit-equal. Returns (the corner each glTF vertex is
    taken from, the glTF vertex of each corner).

    Why not one np.unique over all rows: sorting millions of rows costs seconds. Instead each
    round takes one corner per vertex as representative and settles every corner whose
    attributes hash equal to it; a smooth mesh's seams take a round or two. Hash matches are
    then checked bit by bit once, and whatever is left after WELD_ROUNDS (or failed the check)
    is sorted."""
    n = len(corner_vert)
    bits = np.ascontiguousarray(attrs, dtype=np.float32).view(np.uint32)
    # A 64-bit hash of each corner's attributes (odd multipliers, wrapping arithmetic).
    key = np.zeros(n, dtype=np.uint64)
    for j in range(bits.shape[1]):
        key = key * np.uint64(0x9E3779B97F4A7C15) + bits[:, j].astype(np.uint64)
    key ^= key >> np.uint64(29)
    index = np.full(n, -1, dtype=np.int32)
    new_id = np.empty(n, dtype=np.int32)
    rep_of = np.empty(n, dtype=np.int32)  # the representative each settled corner matched
    slot = np.empty(int(corner_vert.max()) + 1 if n else 0, dtype=np.int32)
    reps = []
    remaining = np.arange(n, dtype=np.int32)
    next_id = 0
    with np.errstate(over="ignore"):
        for _ in range(WELD_ROUNDS):
            if not len(remaining):
                break
            v = corner_vert[remaining]
            slot[v] = remaining  # one representative corner per vertex (numpy: the last written)
            rep = slot[v]
            same = key[remaining] == key[rep]
            rep_corners = remaining[rep == remaining]
            new_id[rep_corners] = np.arange(next_id, next_id + len(rep_corners), dtype=np.int32)
            next_id += len(rep_corners)
            reps.append(rep_corners)
            settled = remaining[same]
            index[settled] = new_id[rep[same]]
            rep_of[settled] = rep[same]
            remaining = remaining[~same]
    # Bit-exact check of the hash matches: a collision goes to the sorted remainder.
    matched = np.flatnonzero(index >= 0)
    wrong = matched[(bits[matched] != bits[rep_of[matched]]).any(axis=1)]
    if len(wrong):
        index[wrong] = -1
        remaining = np.union1d(remaining, wrong).astype(np.int32)
    if len(remaining):
        rows = np.concatenate([corner_vert[remaining, None].astype(np.uint32), bits[remaining]], axis=1)
        _, first, inverse = np.unique(rows, axis=0, return_index=True, return_inverse=True)
        order = np.argsort(first, kind="stable")  # keep corner order for a deterministic file
        rank = np.empty_like(order)
        rank[order] = np.arange(len(order))
        reps.append(remaining[first[order]])
        index[remaining] = next_id + rank[inverse.reshape(-1)]
    return (np.concatenate(reps) if reps else np.empty(0, np.int32)), index


@dataclass
class Primitive:
    material: Optional[int]  # index into the GLB's materials
    positions: np.ndarray
    normals: np.ndarray
    indices: np.ndarray
    uvs: Optional[np.ndarray] = None
    colors: Optional[np.ndarray] = None


# ---------------------------------------------------------------------------------------------
# The exporter


class Exporter:
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
        self.material_index: dict = {}  # material -> glTF material index
        self.materials: dict = {}  # material -> MaterialInfo
        self.image_index: dict = {}  # (image, wrap, nearest) -> glTF texture index
        self.image_source: dict = {}  # image -> glTF image index
        self.warned: set = set()

    def warn(self, message: str) -> None:
        if message not in self.warned:
            self.warned.add(message)
            self.stats.warnings.append(message)

    # ----------------------------------------------------------------------- materials

    def info(self, mat) -> Optional[MaterialInfo]:
        if mat is None:
            return None
        key = mat.as_pointer()
        if key not in self.materials:
            info = material_info(mat)
            for w in info.warnings:
                self.warn(w)
            self.materials[key] = info
        return self.materials[key]

    def material(self, mat) -> Optional[int]:
        if mat is None:
            return None
        key = mat.as_pointer()
        if key in self.material_index:
            return self.material_index[key]
        info = self.info(mat)
        pbr = {"baseColorFactor": [float(min(max(c, 0.0), 1.0)) for c in info.base_color],
               "metallicFactor": float(min(max(info.metallic, 0.0), 1.0)),
               "roughnessFactor": float(min(max(info.roughness, 0.0), 1.0))}
        if info.texture is not None:
            tex = self.texture(info.texture)
            if tex is not None:
                ref = {"index": tex}
                if info.texture.transform is not None:
                    ref["extensions"] = {"KHR_texture_transform": info.texture.transform}
                    self.use_extension("KHR_texture_transform")
                pbr["baseColorTexture"] = ref
        item = {"name": info.name, "pbrMetallicRoughness": pbr}
        if info.unlit:
            item["extensions"] = {"KHR_materials_unlit": {}}
            self.use_extension("KHR_materials_unlit")
        self.material_index[key] = self.glb.add("materials", item)
        return self.material_index[key]

    def use_extension(self, name: str) -> None:
        used = self.glb.json.setdefault("extensionsUsed", [])
        if name not in used:
            used.append(name)

    def texture(self, t: TextureInfo) -> Optional[int]:
        key = (t.image.as_pointer(), t.wrap, t.nearest)
        if key in self.image_index:
            return self.image_index[key]
        src = self.image(t.image)
        index = None
        if src is not None:
            sampler = self.glb.add("samplers", {"wrapS": t.wrap, "wrapT": t.wrap,
                                                "magFilter": NEAREST if t.nearest else LINEAR})
            index = self.glb.add("textures", {"source": src, "sampler": sampler})
        self.image_index[key] = index
        return index

    def image(self, img) -> Optional[int]:
        key = img.as_pointer()
        if key in self.image_source:
            return self.image_source[key]
        data, mime = image_bytes(img, self.warn)
        index = None
        if data is not None:
            index = self.glb.add("images", {"name": img.name, "mimeType": mime,
                                            "bufferView": self.glb.view(data)})
        self.image_source[key] = index
        return index

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
        infos = [self.info(m) for m in mats]
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
        built = _BuiltMesh(arrays)
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
            index = self.material(mat)
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
            camera = glb.add("cameras", self.camera(cam))
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
        """A Blender light as KHR_lights_punctual, in the units of Blender's glTF exporter (sun:
        W/m2 -> lux, x683; point and spot: W -> cd, /4pi x683). Area lights, which glTF lacks
        (the exporter drops them), become a spot lighting the half-space in front of them."""
        kind = data.type
        color = [float(c) for c in data.color]
        if getattr(data, "use_temperature", False):
            color = [c * t for c, t in zip(color, data.temperature_color)]
        energy = float(data.energy)
        if hasattr(data, "normalize") and not data.normalize and hasattr(data, "area"):
            energy *= data.area(world_matrix=matrix)
        energy *= 2.0 ** float(getattr(data, "exposure", 0.0))
        item: dict = {"name": data.name, "color": color}
        if kind == "SUN":
            item["type"] = "directional"
            item["intensity"] = energy * WATTS_TO_LUMENS
        elif kind in {"POINT", "SPOT", "AREA"}:
            item["intensity"] = energy / (4.0 * math.pi) * WATTS_TO_LUMENS
            if kind == "POINT":
                item["type"] = "point"
            else:
                if kind == "SPOT":
                    outer = min(float(data.spot_size) * 0.5, math.pi / 2)
                    inner = outer - outer * float(data.spot_blend)
                else:
                    outer, inner = math.pi / 2, 0.0
                inner = min(max(inner, 0.0), outer * (1.0 - 1e-6))
                item["type"] = "spot"
                item["spot"] = {"innerConeAngle": inner, "outerConeAngle": outer}
        else:
            return None
        self.use_extension("KHR_lights_punctual")
        lights = self.glb.json.setdefault("extensions", {}).setdefault("KHR_lights_punctual", {"lights": []})
        lights["lights"].append(item)
        return len(lights["lights"]) - 1

    def camera(self, cam) -> dict:
        scene = self.depsgraph.scene_eval
        r = scene.render
        w, h = render_size(r.resolution_x, r.resolution_y, r.resolution_percentage)
        facts = camera_facts(cam)
        data = cam.data
        znear = max(float(data.clip_start), 1e-6)
        zfar = max(float(data.clip_end), znear * 2.0)
        if data.type == "ORTHO":
            ymag = facts.ortho_height(w, h) / 2.0
            return {"name": data.name, "type": "orthographic",
                    "orthographic": {"xmag": ymag * w / h, "ymag": ymag, "znear": znear, "zfar": zfar}}
        yfov = math.radians(facts.vertical_fov_deg(w, h))
        return {"name": data.name, "type": "perspective",
                "perspective": {"yfov": min(max(yfov, 1e-4), math.pi - 1e-4), "aspectRatio": w / h,
                                "znear": znear, "zfar": zfar}}


class _BuiltMesh:
    """A mesh's primitives, built from its arrays when first asked for, let go of once its
    last array (the last primitive's indices) was taken."""

    def __init__(self, arrays: MeshArrays):
        self.arrays: Optional[MeshArrays] = arrays
        self.prims: Optional[list] = None

    def array(self, i: int, what: str) -> np.ndarray:
        if self.prims is None:
            self.prims = build_primitives(self.arrays)
            self.arrays = None
        p = self.prims[i]
        if what == "indices":
            out = p.indices.reshape(-1).astype(np.uint16 if len(p.positions) < 65535 else np.uint32)
            if i == len(self.prims) - 1:
                self.prims = []
            return out
        return getattr(p, what)


@dataclass
class MeshArrays:
    """Everything of an evaluated mesh its glTF primitives are made from, read from Blender
    (`read_mesh`, main thread); `build_primitives` makes the primitives from it alone (any
    thread)."""

    nverts: int
    npoly: int
    nloops: int
    positions: np.ndarray
    corner_vert: np.ndarray
    sizes: np.ndarray
    ngon_tris: object  # loop_triangles_of_ngons
    normals: tuple  # read_normals
    flat: bool
    poly_mat: Optional[np.ndarray]
    used: list  # the material slots used, ascending
    has_infos: bool
    # Per used slot: (UVs or None, colours or None, whether the colours are per vertex).
    per_slot: list

    @property
    def triangles(self) -> int:
        return int(self.nloops - 2 * self.npoly)


def read_mesh(ob, me, infos: list, temporary: bool = False) -> Optional[MeshArrays]:
    """An evaluated mesh's arrays (Blender's data is read here only); None when it has no
    triangles."""
    nverts, npoly, nloops = len(me.vertices), len(me.polygons), len(me.loops)
    if npoly == 0 or nloops < 3 or nloops - 2 * npoly <= 0:
        return None
    positions = _attribute(me, "position", "POINT", 3, "vector")
    if positions is None:
        positions = _get(me.vertices, "co", nverts, np.float32, 3)
    corner_vert = _attribute(me, ".corner_vert", "CORNER", 1, "value", np.int32)
    if corner_vert is None:
        corner_vert = _get(me.loops, "vertex_index", nloops, np.int32)
    sizes = _get(me.polygons, "loop_total", npoly, np.int32)
    ngon_tris = loop_triangles_of_ngons(me, npoly, nloops, sizes)
    normals, flat = read_normals(ob, me, nverts, npoly, nloops, temporary)
    mat_index = _attribute(me, "material_index", "FACE", 1, "value", np.int32)
    if mat_index is None and len(infos) > 1:
        mat_index = _get(me.polygons, "material_index", npoly, np.int32)
    poly_mat = None if mat_index is None else np.clip(mat_index, 0, max(len(infos), 1) - 1)
    # The slots used, ascending (as np.unique; a count is faster on large meshes).
    used = [0] if poly_mat is None else np.flatnonzero(np.bincount(poly_mat, minlength=1)).tolist()
    uv_cache: dict = {}
    color_cache: dict = {}
    per_slot = []
    for m in used:
        info = infos[m] if m < len(infos) else None
        uvs, colors, per_vertex = None, None, False
        if info is not None and info.texture is not None:
            key = info.texture.uv_map
            if key not in uv_cache:
                uv_cache[key] = corner_uvs(me, key, nloops)
            uvs = uv_cache[key]
        wanted = info.vertex_color if info is not None else ""
        if wanted is not None:
            if wanted not in color_cache:
                color_cache[wanted] = vertex_colors(me, wanted)
            colors, per_vertex = color_cache[wanted]
        per_slot.append((uvs, colors, per_vertex))
    return MeshArrays(nverts, npoly, nloops, positions, corner_vert, sizes, ngon_tris, normals, flat, poly_mat, used,
                      bool(infos), per_slot)


def mesh_primitives(ob, me, infos: list, temporary: bool = False) -> list:
    """An evaluated mesh as glTF primitives, one per material index used."""
    arrays = read_mesh(ob, me, infos, temporary)
    return [] if arrays is None else build_primitives(arrays)


def build_primitives(a: MeshArrays) -> list:
    """The glTF primitives of a mesh's arrays, one per material slot used (no Blender data is
    read here: the viewport runs this on its worker thread)."""
    nverts, nloops = a.nverts, a.nloops
    positions, corner_vert, poly_mat = a.positions, a.corner_vert, a.poly_mat
    poly_of_corner = np.repeat(np.arange(a.npoly, dtype=np.int32), a.sizes)
    vertex_normals, normals = shading_normals(a.normals, corner_vert, poly_of_corner)
    tris, tri_poly, _sizes = triangulate_arrays(a.sizes, a.npoly, nloops, positions, corner_vert, a.ngon_tris)
    single = len(a.used) == 1
    prims = []
    for m, (uvs, colors, per_vertex_colors) in zip(a.used, a.per_slot):
        if single:
            sel_tris, corners = tris, None
        else:
            sel_tris = tris[poly_mat[tri_poly] == m]
            corners = np.flatnonzero(poly_mat[poly_of_corner] == m).astype(np.int32)
        pick = (lambda a: a) if corners is None else (lambda a: a[corners])  # noqa: E731
        # Attributes that vary per corner decide which corners share a glTF vertex.
        columns = [c for c in (normals, uvs, None if per_vertex_colors else colors) if c is not None]
        cv = pick(corner_vert)
        if a.flat:
            rep = np.arange(len(cv), dtype=np.int32)
            local = rep
            src = rep if corners is None else corners
            verts = corner_vert[src]
        elif columns:
            rep, local = weld(cv, np.concatenate([pick(c) for c in columns], axis=1))
            src = rep if corners is None else corners[rep]
            verts = corner_vert[src]
        else:
            # Everything is per vertex: the glTF vertices are the Blender vertices used.
            used_v = np.zeros(nverts, dtype=bool)
            used_v[cv] = True
            verts = np.flatnonzero(used_v).astype(np.int32)
            if len(verts) == nverts:
                local = cv
            else:
                remap = np.empty(nverts, dtype=np.int32)
                remap[verts] = np.arange(len(verts), dtype=np.int32)
                local = remap[cv]
            src = None
        if corners is None:
            to_vertex = local
        else:
            to_vertex = np.empty(nloops, dtype=np.int32)
            to_vertex[corners] = local

        def out(per_corner, per_vertex):
            if per_vertex is not None:
                return per_vertex[verts]
            return None if per_corner is None else per_corner[src]

        prims.append(Primitive(
            material=m if a.has_infos else None,
            positions=positions[verts],
            normals=out(normals, vertex_normals),
            indices=to_vertex[sel_tris],
            uvs=out(uvs, None),
            colors=out(None if per_vertex_colors else colors, colors if per_vertex_colors else None)))
    return prims


# ---------------------------------------------------------------------------------------------
# Images


def _srgb(linear: np.ndarray) -> np.ndarray:
    c = np.clip(linear, 0.0, 1.0)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1.0 / 2.4) - 0.055)


def image_bytes(img, warn: Callable[[str], None]) -> tuple[Optional[bytes], str]:
    """The image as PNG or JPEG bytes: the file's own bytes when it is one (packed or on
    disk), else its pixels encoded as PNG (float images turned to sRGB)."""
    data = None
    packed = getattr(img, "packed_file", None)
    try:
        if packed is not None:
            data = bytes(packed.data)
        elif img.source == "FILE":
            path = Path(bpy.path.abspath(img.filepath_raw or img.filepath, library=img.library))
            if path.is_file():
                data = path.read_bytes()
    except (OSError, ValueError):
        data = None
    colourspace = img.colorspace_settings.name
    as_colour = colourspace not in {"Non-Color", "Raw", "Linear", "Linear Rec.709", "Linear CIE-XYZ E"}
    if data is not None and as_colour:
        if data[:8] == pngio.SIGNATURE:
            return data, "image/png"
        if data[:3] == b"\xff\xd8\xff":
            return data, "image/jpeg"
    w, h = int(img.size[0]), int(img.size[1])
    if w * h == 0:
        warn(f"image '{img.name}' cannot be read: its texture is left out")
        return None, ""
    px = np.empty(w * h * 4, dtype=np.float32)
    img.pixels.foreach_get(px)
    px = px.reshape(h, w, 4)[::-1]  # Blender's rows run bottom-up, PNG's top-down
    if img.is_float:
        px = np.concatenate([_srgb(px[..., :3]), np.clip(px[..., 3:], 0.0, 1.0)], axis=2)
    px8 = np.round(np.clip(px, 0.0, 1.0) * 255.0).astype(np.uint8)
    return pngio.encode(px8, level=1), "image/png"


# ---------------------------------------------------------------------------------------------


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
