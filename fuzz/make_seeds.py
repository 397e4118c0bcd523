#!/usr/bin/env python3
"""Writes the fuzzers' own seed corpus into fuzz/seeds/ (standard library only):
small, valid glTF/GLB files written here (no third-party content, so they can be committed)
that exercise what the loader reads: index types, strides, sparse accessors, node hierarchies,
matrices and TRS, cameras, lights, textures (an embedded PNG), texture transforms, unlit,
vertex colours, morph targets, skins, strips and fans, quantised attributes, data: URIs;
and settings JSON files covering every kind of key. scripts/fuzz.sh adds ../shared's sample
and invalid files at run time when present.

    python3 fuzz/make_seeds.py
"""

import base64
import json
import pathlib
import struct
import zlib

HERE = pathlib.Path(__file__).resolve().parent


def png(w, h, rgba):
    """A tiny RGBA PNG."""
    raw = b"".join(b"\x00" + bytes(rgba[y * w * 4:(y + 1) * w * 4]) for y in range(h))

    def chunk(t, d):
        return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xFFFFFFFF)

    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 6, 0, 0, 0))
            + chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


class Doc:
    """Builds a glTF document and its single binary buffer."""

    def __init__(self):
        self.bin = bytearray()
        self.j = {"asset": {"version": "2.0", "generator": "cubist fuzz seeds"}, "buffers": [], "bufferViews": [],
                  "accessors": [], "meshes": [], "nodes": [], "scenes": [{"nodes": []}], "scene": 0}

    def view(self, data, target=None, stride=None):
        while len(self.bin) % 4:
            self.bin.append(0)
        v = {"buffer": 0, "byteOffset": len(self.bin), "byteLength": len(data)}
        if target:
            v["target"] = target
        if stride:
            v["byteStride"] = stride
        self.bin += data
        self.j["bufferViews"].append(v)
        return len(self.j["bufferViews"]) - 1

    def accessor(self, values, ctype, typ, target=None, normalized=False, minmax=False):
        fmt = {5126: "f", 5125: "I", 5123: "H", 5121: "B", 5122: "h", 5120: "b"}[ctype]
        n = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}[typ]
        flat = [x for v in values for x in (v if isinstance(v, (list, tuple)) else [v])]
        data = struct.pack("<" + fmt * len(flat), *flat)
        a = {"bufferView": self.view(data, target), "componentType": ctype, "count": len(values), "type": typ}
        if normalized:
            a["normalized"] = True
        if minmax:
            cols = [flat[i::n] for i in range(n)]
            a["min"] = [min(c) for c in cols]
            a["max"] = [max(c) for c in cols]
        self.j["accessors"].append(a)
        return len(self.j["accessors"]) - 1

    def mesh(self, prims):
        self.j["meshes"].append({"primitives": prims})
        return len(self.j["meshes"]) - 1

    def node(self, root=True, **kw):
        self.j["nodes"].append(kw)
        i = len(self.j["nodes"]) - 1
        if root:
            self.j["scenes"][0]["nodes"].append(i)
        return i

    def glb(self):
        while len(self.bin) % 4:
            self.bin.append(0)
        j = dict(self.j)
        j["buffers"] = [{"byteLength": len(self.bin)}]
        text = json.dumps(j, separators=(",", ":")).encode()
        text += b" " * (-len(text) % 4)
        out = struct.pack("<III", 0x46546C67, 2, 12 + 8 + len(text) + 8 + len(self.bin))
        out += struct.pack("<II", len(text), 0x4E4F534A) + text
        out += struct.pack("<II", len(self.bin), 0x004E4942) + bytes(self.bin)
        return out

    def gltf(self):
        j = dict(self.j)
        uri = "data:application/octet-stream;base64," + base64.b64encode(bytes(self.bin)).decode()
        j["buffers"] = [{"byteLength": len(self.bin), "uri": uri}]
        return json.dumps(j, indent=1).encode()


BOX_P = [(-1, -1, -1), (1, -1, -1), (1, 1, -1), (-1, 1, -1), (-1, -1, 1), (1, -1, 1), (1, 1, 1), (-1, 1, 1)]
BOX_I = [0, 2, 1, 0, 3, 2, 4, 5, 6, 4, 6, 7, 0, 1, 5, 0, 5, 4, 2, 3, 7, 2, 7, 6, 1, 2, 6, 1, 6, 5, 0, 4, 7, 0, 7, 3]


def triangle():
    d = Doc()
    pos = d.accessor([(0, 0, 0), (1, 0, 0), (0, 1, 0)], 5126, "VEC3", 34962, minmax=True)
    d.node(mesh=d.mesh([{"attributes": {"POSITION": pos}}]))
    return d


def box(index_type):
    d = Doc()
    pos = d.accessor(BOX_P, 5126, "VEC3", 34962, minmax=True)
    idx = d.accessor(BOX_I, index_type, "SCALAR", 34963)
    d.node(mesh=d.mesh([{"attributes": {"POSITION": pos}, "indices": idx}]), translation=[0.5, 0, 0])
    return d


def interleaved():
    d = Doc()
    data = b"".join(struct.pack("<6f", *p, 0, 0, 1) for p in BOX_P)
    v = d.view(data, 34962, stride=24)
    d.j["accessors"].append({"bufferView": v, "componentType": 5126, "count": 8, "type": "VEC3",
                             "min": [-1, -1, -1], "max": [1, 1, 1]})
    d.j["accessors"].append({"bufferView": v, "byteOffset": 12, "componentType": 5126, "count": 8, "type": "VEC3"})
    idx = d.accessor(BOX_I, 5123, "SCALAR", 34963)
    d.node(mesh=d.mesh([{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": idx}]))
    return d


def sparse():
    d = Doc()
    base = d.accessor([(x, y, 0) for y in range(3) for x in range(3)], 5126, "VEC3", 34962, minmax=True)
    idx = d.view(struct.pack("<2H", 4, 8))
    val = d.view(struct.pack("<6f", 1, 1, 1, 2, 2, 0.5))
    acc = dict(d.j["accessors"][base])
    acc["sparse"] = {"count": 2, "indices": {"bufferView": idx, "componentType": 5123},
                     "values": {"bufferView": val}}
    acc["min"], acc["max"] = [0, 0, 0], [2, 2, 1]
    d.j["accessors"].append(acc)
    tris = d.accessor([0, 1, 4, 0, 4, 3, 1, 2, 5, 1, 5, 4, 3, 4, 7, 3, 7, 6, 4, 5, 8, 4, 8, 7], 5121, "SCALAR", 34963)
    d.node(mesh=d.mesh([{"attributes": {"POSITION": len(d.j["accessors"]) - 2}, "indices": tris}]))
    return d


def hierarchy_camera_lights():
    d = box(5125)
    d.j["nodes"][0]["children"] = [1, 2]
    d.node(root=False, mesh=0, matrix=[0.5, 0, 0, 0, 0, 0.5, 0, 0, 0, 0, 0.5, 0, 2, 0, 0, 1])
    d.node(root=False, mesh=0, rotation=[0, 0.7071068, 0, 0.7071068], scale=[1, 2, 1], translation=[0, 3, 0])
    d.j["cameras"] = [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1, "aspectRatio": 1.5}},
                      {"type": "orthographic", "orthographic": {"xmag": 2, "ymag": 1.5, "znear": 0.1, "zfar": 50}}]
    d.node(camera=0, translation=[0, 1, 6])
    d.node(camera=1, translation=[0, 0, 9], rotation=[0, 0, 0, 1])
    d.j["extensionsUsed"] = ["KHR_lights_punctual"]
    d.j["extensions"] = {"KHR_lights_punctual": {"lights": [
        {"type": "directional", "color": [1, 0.9, 0.8], "intensity": 3},
        {"type": "point", "intensity": 40, "range": 10},
        {"type": "spot", "intensity": 20, "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.6}}]}}
    for i in range(3):
        d.node(extensions={"KHR_lights_punctual": {"light": i}}, translation=[i, 4, 2])
    return d


def textured():
    d = Doc()
    pos = d.accessor([(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)], 5126, "VEC3", 34962, minmax=True)
    uv = d.accessor([(0, 1), (1, 1), (1, 0), (0, 0)], 5126, "VEC2", 34962)
    uv1 = d.accessor([(0, 65535), (65535, 65535), (65535, 0), (0, 0)], 5123, "VEC2", 34962, normalized=True)
    col = d.accessor([(255, 0, 0, 255), (0, 255, 0, 255), (0, 0, 255, 255), (255, 255, 255, 128)], 5121, "VEC4",
                     34962, normalized=True)
    idx = d.accessor([0, 1, 2, 0, 2, 3], 5123, "SCALAR", 34963)
    img = d.view(png(2, 2, [255, 0, 0, 255, 0, 255, 0, 255, 0, 0, 255, 255, 255, 255, 255, 255]))
    d.j["images"] = [{"bufferView": img, "mimeType": "image/png"}]
    d.j["samplers"] = [{"magFilter": 9728, "minFilter": 9986, "wrapS": 33648, "wrapT": 33071}]
    d.j["textures"] = [{"source": 0, "sampler": 0}]
    d.j["extensionsUsed"] = ["KHR_texture_transform", "KHR_materials_unlit"]
    d.j["materials"] = [
        {"pbrMetallicRoughness": {"baseColorFactor": [1, 0.8, 0.6, 1], "metallicFactor": 0.2, "roughnessFactor": 0.7,
                                  "baseColorTexture": {"index": 0, "texCoord": 1, "extensions": {
                                      "KHR_texture_transform": {"offset": [0.1, 0.2], "rotation": 0.3,
                                                                "scale": [2, 2]}}}}, "doubleSided": True},
        {"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}, "extensions": {"KHR_materials_unlit": {}}}]
    attrs = {"POSITION": pos, "TEXCOORD_0": uv, "TEXCOORD_1": uv1, "COLOR_0": col}
    m = d.mesh([{"attributes": attrs, "indices": idx, "material": 0},
                {"attributes": {"POSITION": pos, "TEXCOORD_0": uv}, "indices": idx, "material": 1}])
    d.node(mesh=m)
    return d


def morph_and_skin():
    d = triangle()
    delta = d.accessor([(0, 0, 1), (0, 0, 0), (0, 0, -1)], 5126, "VEC3", 34962, minmax=True)
    d.j["meshes"][0]["primitives"][0]["targets"] = [{"POSITION": delta}]
    d.j["meshes"][0]["weights"] = [0.5]
    joints = d.accessor([(0, 0, 0, 0)] * 3, 5121, "VEC4", 34962)
    weights = d.accessor([(1.0, 0, 0, 0)] * 3, 5126, "VEC4", 34962)
    d.j["meshes"][0]["primitives"][0]["attributes"].update({"JOINTS_0": joints, "WEIGHTS_0": weights})
    ibm = d.accessor([[1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1]], 5126, "MAT4")
    joint = d.node(root=False, translation=[0, 0.5, 0])
    d.j["nodes"][0]["children"] = [joint]
    d.j["nodes"][0]["skin"] = 0
    d.j["skins"] = [{"joints": [joint], "inverseBindMatrices": ibm}]
    d.j["nodes"][0]["weights"] = [1.0]
    return d


def modes():
    d = Doc()
    pos = d.accessor([(0, 0, 0), (1, 0, 0), (0, 1, 0), (1, 1, 0), (2, 0, 0)], 5126, "VEC3", 34962, minmax=True)
    prims = [{"attributes": {"POSITION": pos}, "mode": m} for m in range(7)]
    d.node(mesh=d.mesh(prims))
    return d


def quantized():
    d = Doc()
    pos = d.accessor([(-32767, -32767, 0), (32767, -32767, 0), (0, 32767, 0)], 5122, "VEC3", 34962, normalized=True,
                     minmax=True)
    nrm = d.accessor([(0, 0, 127)] * 3, 5120, "VEC3", 34962, normalized=True)
    d.j["extensionsUsed"] = d.j["extensionsRequired"] = ["KHR_mesh_quantization"]
    d.node(mesh=d.mesh([{"attributes": {"POSITION": pos, "NORMAL": nrm}}]), scale=[2, 2, 2])
    return d


SETTINGS = {
    "empty": {},
    "plain": {"preset": "plain", "width": 64, "height": 48, "spp": 1},
    "camera": {"camera": "planar", "ambiguity": 120, "framing": "centre", "focus_distance": 3.5,
               "camera_position": [0, 1, 5], "camera_target": [0, 0.5, 0], "camera_up": [0, 1, 0],
               "camera_size": 2.0, "fill": 0.7, "width": 8, "height": 8, "spp": 2},
    "spherical": {"camera": "spherical", "ambiguity": 360, "width": 12, "height": 4, "seed": 7},
    "pinhole": {"camera": "perspective", "ambiguity": 60, "shadows": False, "background": [0.1, 0.2, 0.3],
                "transparent": True, "exposure": 1.5, "width": 4, "height": 4},
    "ortho": {"camera": "orthographic", "camera_size": 3, "width": 5, "height": 5},
    "facets": {"faceting": "voronoi", "facet_count": 40, "grid_cells": 4, "patch_count": 10, "occlusion": 2.5,
               "segments": [5, 30, 120], "thresholds": [0, 0.05, 0.08], "imprecision": "random",
               "discontinuity": 100, "neighborhood": 3, "facet_projection": "linear", "facet_fov": 20},
    "paint": {"border_width": 4, "border_strength": 0.8, "silhouette_width": 2, "silhouette_strength": 0.5,
              "palette": "ochre", "colors": 8, "gradients": 0.3, "chiaroscuro": 0.2,
              "passes": ["saliency", "facets", "facet-ids", "segments", "objects", "normals", "depth"]},
    "paths": {"faceting": "constant", "facet_map": "map.png", "facets": "layout.json", "save_facets": "out.json",
              "palette_image": "painting.jpg"},
    "bad_values": {"width": 0, "ambiguity": 720, "camera": "planar"},
    "unknown_key": {"widht": 10},
}


def main():
    out = HERE / "seeds" / "gltf_loader"
    out.mkdir(parents=True, exist_ok=True)
    docs = {"triangle": triangle(), "box_u8": box(5121), "box_u16": box(5123), "box_u32": box(5125),
            "interleaved": interleaved(), "sparse": sparse(), "hierarchy_camera_lights": hierarchy_camera_lights(),
            "textured": textured(), "morph_skin": morph_and_skin(), "modes": modes(), "quantized": quantized()}
    for name, d in docs.items():
        (out / f"{name}.glb").write_bytes(d.glb())
        (out / f"{name}.gltf").write_bytes(d.gltf())
    sout = HERE / "seeds" / "settings_json"
    sout.mkdir(parents=True, exist_ok=True)
    for name, s in SETTINGS.items():
        (sout / f"{name}.json").write_text(json.dumps(s, indent=1) + "\n")
    print(f"wrote {len(docs) * 2} glTF seeds to {out} and {len(SETTINGS)} settings seeds to {sout}")


if __name__ == "__main__":
    main()
