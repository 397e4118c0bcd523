"""A mesh's glTF primitives: its arrays read from Blender on the main thread (`read_mesh`:
positions, corners, faces, normals as Blender renders them, UVs and colour attributes the
materials use), then the primitives built from those arrays alone, on any thread
(`build_primitives`: one per material slot used, triangulated and welded)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from .arrays import read_array, read_attribute
from .triangles import loop_triangles_of_ngons, triangulate_arrays
from .weld import weld


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
            return ("vertex", read_array(me.vertex_normals, "vector", nverts, np.float32, 3)), False
        if domain == "FACE":
            return ("face", read_array(me.polygon_normals, "vector", npoly, np.float32, 3)), True
        # Sharp faces or edges split the fans around a vertex: only Blender's corner normals
        # have the averages over each fan.
        return ("corner", read_array(me.corner_normals, "vector", nloops, np.float32, 3)), False
    # Blender 3.x / 4.0: split normals only with Auto Smooth or custom normals, and computing
    # them writes to the mesh: on a temporary copy.
    smooth = read_array(me.polygons, "use_smooth", npoly, bool)
    if getattr(me, "use_auto_smooth", False) or me.has_custom_normals:
        flat = not smooth.any()
        if temporary:
            me.calc_normals_split()
            return ("corner", read_array(me.loops, "normal", nloops, np.float32, 3)), flat
        tmp = ob.to_mesh()
        try:
            tmp.calc_normals_split()
            return ("corner", read_array(tmp.loops, "normal", nloops, np.float32, 3)), flat
        finally:
            ob.to_mesh_clear()
    if smooth.all():
        return ("vertex", read_array(me.vertices, "normal", nverts, np.float32, 3)), False
    fn = read_array(me.polygons, "normal", npoly, np.float32, 3)
    if not smooth.any():
        return ("face", fn), True
    return ("mixed", read_array(me.vertices, "normal", nverts, np.float32, 3), fn, smooth), False


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
    uv = read_attribute(me, layer.name, "CORNER", 2, "vector")
    if uv is None or len(uv) != nloops:
        uv = read_array(layer.data, "uv", nloops, np.float32, 2)
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
    return read_array(attr.data, "color", len(attr.data), np.float32, 4), attr.domain == "POINT"


@dataclass
class Primitive:
    material: Optional[int]  # index into the GLB's materials
    positions: np.ndarray
    normals: np.ndarray
    indices: np.ndarray
    uvs: Optional[np.ndarray] = None
    colors: Optional[np.ndarray] = None


class BuiltMesh:
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
    positions = read_attribute(me, "position", "POINT", 3, "vector")
    if positions is None:
        positions = read_array(me.vertices, "co", nverts, np.float32, 3)
    corner_vert = read_attribute(me, ".corner_vert", "CORNER", 1, "value", np.int32)
    if corner_vert is None:
        corner_vert = read_array(me.loops, "vertex_index", nloops, np.int32)
    sizes = read_array(me.polygons, "loop_total", npoly, np.int32)
    ngon_tris = loop_triangles_of_ngons(me, npoly, nloops, sizes)
    normals, flat = read_normals(ob, me, nverts, npoly, nloops, temporary)
    mat_index = read_attribute(me, "material_index", "FACE", 1, "value", np.int32)
    if mat_index is None and len(infos) > 1:
        mat_index = read_array(me.polygons, "material_index", npoly, np.int32)
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
