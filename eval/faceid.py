"""Independent reference for visible-face counts: pyrender (OpenGL rasterisation) renders a
mesh's face ids through exactly the camera `cubist faces --json` reports, and we count the
distinct ids.

Why the details matter:
- each face i is coloured with i + 1 packed in 24 bits, flat (unlit) shading, black
  background, no back-face culling (a ray tracer sees back faces through holes too);
- pyrender renders into a 4x multisampled buffer and enables GL_MULTISAMPLE before every
  forward pass, which blends ids along edges (582 "visible" faces where 428 are). We make
  its `glEnable(GL_MULTISAMPLE)` a `glDisable`, so each pixel is one sample at its centre,
  the same point `cubist faces --spp 1` traces.
Runs offscreen on the CPU through EGL (Mesa llvmpipe) unless PYOPENGL_PLATFORM says otherwise.
"""

import os

os.environ.setdefault("PYOPENGL_PLATFORM", "egl")

import numpy as np  # noqa: E402
import pyrender  # noqa: E402
import pyrender.renderer  # noqa: E402
import trimesh  # noqa: E402
from OpenGL import GL  # noqa: E402

_gl_enable = GL.glEnable


def _enable_without_multisampling(cap):
    if cap == GL.GL_MULTISAMPLE:
        GL.glDisable(cap)
    else:
        _gl_enable(cap)


# pyrender.renderer did `from OpenGL.GL import *`: patch the name it calls.
pyrender.renderer.glEnable = _enable_without_multisampling


def load_mesh(path):
    """The scene's triangles in file order (process=False keeps faces and their order, so
    face i here is triangle i of `cubist faces --ids` for a one-mesh file)."""
    m = trimesh.load(str(path), force="mesh", process=False)
    return trimesh.Trimesh(vertices=np.asarray(m.vertices), faces=np.asarray(m.faces), process=False)


def id_mesh(mesh):
    """A pyrender mesh whose face i is coloured with i + 1 (24 bits)."""
    n = len(mesh.faces)
    if n >= 1 << 24:
        raise ValueError(f"{n} faces do not fit in 24-bit ids")
    ids = np.arange(1, n + 1, dtype=np.uint32)
    cols = np.stack([(ids >> 16) & 255, (ids >> 8) & 255, ids & 255, np.full(n, 255)], axis=1).astype(np.uint8)
    m = mesh.copy()
    m.visual = trimesh.visual.ColorVisuals(m, face_colors=cols)
    return pyrender.Mesh.from_trimesh(m, smooth=False)


def camera_pose(view):
    """4x4 camera-to-world matrix: pyrender cameras look down their -Z with +Y up."""
    pose = np.eye(4)
    pose[:3, 0] = view["right"]
    pose[:3, 1] = view["up"]
    pose[:3, 2] = -np.asarray(view["forward"], dtype=float)
    pose[:3, 3] = view["position"]
    return pose


_OFFSCREEN = None


def _offscreen(w, h):
    """One OpenGL context for the whole process, resized as needed: pyrender's EGL
    renderers share one display, and deleting any of them terminates it for all."""
    global _OFFSCREEN
    if _OFFSCREEN is None:
        _OFFSCREEN = pyrender.OffscreenRenderer(w, h)
    _OFFSCREEN.viewport_width, _OFFSCREEN.viewport_height = w, h
    return _OFFSCREEN


class FaceIdRenderer:
    """Renders face-id images of one mesh through cameras described as by `cubist faces --json`."""

    def __init__(self, mesh):
        self.mesh = mesh
        self.pmesh = id_mesh(mesh)
        lo, hi = mesh.bounds
        self.centre = (lo + hi) / 2
        self.radius = float(np.max(np.linalg.norm(mesh.vertices - self.centre, axis=1)))

    def camera(self, view):
        w, h = view["width"], view["height"]
        d = float(np.linalg.norm(np.asarray(view["position"]) - self.centre))
        r = self.radius
        znear = max(d - 1.05 * r, 1e-4 * r)
        zfar = d + 1.05 * r
        if view["kind"] == "perspective":
            return pyrender.PerspectiveCamera(
                yfov=np.radians(view["angle_deg"]), aspectRatio=w / h, znear=znear, zfar=zfar
            )
        if view["kind"] == "orthographic":
            hh = view["view_height"] / 2
            return pyrender.OrthographicCamera(xmag=hh * w / h, ymag=hh, znear=znear, zfar=zfar)
        raise ValueError(f"pyrender has no {view['kind']} camera")

    def ids_image(self, view):
        """Per-pixel face id (-1 for background), row 0 at the top."""
        scene = pyrender.Scene(bg_color=[0, 0, 0, 0], ambient_light=[1, 1, 1])
        scene.add(self.pmesh)
        scene.add(self.camera(view), pose=camera_pose(view))
        flags = pyrender.RenderFlags.FLAT | pyrender.RenderFlags.SKIP_CULL_FACES
        color, _ = _offscreen(view["width"], view["height"]).render(scene, flags=flags)
        c = color[..., :3].astype(np.int64)
        return ((c[..., 0] << 16) | (c[..., 1] << 8) | c[..., 2]) - 1

    def visible(self, view):
        """The set of face ids visible through `view`."""
        img = self.ids_image(view)
        ids = np.unique(img[img >= 0])
        if len(ids) and ids.max() >= len(self.mesh.faces):
            raise RuntimeError(f"decoded id {ids.max()} out of range: colours were not written exactly")
        return set(int(i) for i in ids)

    def close(self):
        """Frees nothing today (the context is shared); kept so callers can scope a renderer."""


def icosphere_glb(path):
    """Writes the Table 4.1 sphere: a unit icosphere of 3 subdivisions, 1280 faces (the same
    as ../shared/models/sphere_1280.glb, generated the same way)."""
    m = trimesh.creation.icosphere(subdivisions=3, radius=1.0)
    m.export(str(path), file_type="glb")
    return path
