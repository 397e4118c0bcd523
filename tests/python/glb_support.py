"""Reading the add-on's GLB files in tests (numpy only), and Blender scenes they export."""

import json
import struct
from pathlib import Path

import numpy as np

DTYPES = {5126: np.float32, 5125: np.uint32, 5123: np.uint16, 5121: np.uint8}
WIDTHS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT4": 16}


class Glb:
    def __init__(self, path):
        data = Path(path).read_bytes()
        magic, version, total = struct.unpack_from("<4sII", data, 0)
        assert (magic, version, total) == (b"glTF", 2, len(data)), (magic, version, total, len(data))
        jlen, jkind = struct.unpack_from("<I4s", data, 12)
        assert jkind == b"JSON" and jlen % 4 == 0
        self.json = json.loads(data[20:20 + jlen])
        pos = 20 + jlen
        self.bin = b""
        if pos < len(data):
            blen, bkind = struct.unpack_from("<I4s", data, pos)
            assert bkind == b"BIN\0" and pos + 8 + blen == len(data)
            self.bin = data[pos + 8:pos + 8 + blen]

    def accessor(self, i: int) -> np.ndarray:
        a = self.json["accessors"][i]
        v = self.json["bufferViews"][a["bufferView"]]
        n = WIDTHS[a["type"]]
        arr = np.frombuffer(self.bin, DTYPES[a["componentType"]], a["count"] * n,
                            v["byteOffset"] + a.get("byteOffset", 0))
        return arr.reshape(a["count"], n) if n > 1 else arr

    def view_bytes(self, i: int) -> bytes:
        v = self.json["bufferViews"][i]
        return self.bin[v["byteOffset"]:v["byteOffset"] + v["byteLength"]]

    def nodes_with_mesh(self):
        return [n for n in self.json["nodes"] if "mesh" in n]

    def primitive(self, p: dict) -> dict:
        """A primitive's attributes and triangles as arrays."""
        out = {k: self.accessor(i) for k, i in p["attributes"].items()}
        out["indices"] = self.accessor(p["indices"]).astype(np.int64).reshape(-1, 3)
        return out

    def triangles(self) -> int:
        total = 0
        for node in self.nodes_with_mesh():
            for p in self.json["meshes"][node["mesh"]]["primitives"]:
                total += self.json["accessors"][p["indices"]]["count"] // 3
        return total

    def node_matrix(self, node: dict) -> np.ndarray:
        """A node's matrix (4x4, rows) in Blender's Z-up axes."""
        m = np.array(node["matrix"], dtype=np.float64).reshape(4, 4).T
        y_up = np.array([[1, 0, 0, 0], [0, 0, 1, 0], [0, -1, 0, 0], [0, 0, 0, 1]], dtype=np.float64)
        return y_up.T @ m
