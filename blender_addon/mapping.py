"""Blender facts and panel values -> the renderer's settings JSON (no bpy, unit-tested alone).

The engine reads plain values out of Blender (`CameraFacts`, the panel's properties as a dict)
and this module decides every settings key, so "which panel value becomes which key" and
"how a Blender camera becomes a cubist camera" are tested without Blender.

Coordinates: Blender is Z-up, glTF (what the renderer reads, exported with +Y up) is Y-up:
(x, y, z) in Blender is (x, z, -y) in the exported scene.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping, Optional, Sequence

from . import presets, runner, schema

# Panel enum properties: identifier (BLUE_PERIOD) -> settings value (blue-period).
ENUM_KEYS = presets.ENUM_KEYS

# Panel properties copied to the settings key of the same name (floats as typed, see
# runner.f32_decimal): every plain value the renderer takes (booleans and numbers that are
# never null) but those Blender decides and the seed (animated below).
PLAIN_KEYS = tuple(
    k for k, f in schema.SETTINGS.items()
    if f["type"] in ("boolean", "integer", "number") and not f["nullable"] and k not in presets.BLENDER_KEYS
    and k != "seed"
)

# The render passes' names in Blender (the compositor's sockets); the renderer's names, and
# whether a pass is grey (one channel) or colour, come from the schema.
BLENDER_PASS_NAMES = {"saliency": "Saliency", "facet-ids": "Facet Index", "facets": "Facets",
                      "segments": "Segments", "objects": "Object Colors", "normals": "Cubist Normal",
                      "depth": "Cubist Depth"}


def _pass(toggle: str, name: str) -> tuple:
    grey = schema.pass_format(name).startswith("grey")
    return (toggle, name, BLENDER_PASS_NAMES[name], 1 if grey else 3, "X" if grey else "RGB",
            "VALUE" if grey else "COLOR")


# Render passes: panel toggle -> (renderer pass name, Blender pass name, channels, chan_id, type).
PASSES = tuple(_pass(toggle, name) for toggle, name in presets.PASS_TOGGLES.items())


def to_gltf(v: Sequence[float]) -> list[float]:
    """A Blender (Z-up) point or direction in the exported glTF's Y-up coordinates."""
    return [float(v[0]), float(v[2]), -float(v[1])]


def _norm(v: Sequence[float]) -> list[float]:
    n = math.sqrt(sum(c * c for c in v))
    return [c / n for c in v] if n > 0 else list(v)


@dataclass
class CameraFacts:
    """What the engine reads off the scene's active camera (Blender units and conventions)."""

    matrix_world: Sequence[Sequence[float]]  # 4x4, rows
    type: str = "PERSP"  # PERSP, ORTHO or PANO
    lens: float = 50.0  # mm
    sensor_width: float = 36.0
    sensor_height: float = 24.0
    sensor_fit: str = "AUTO"
    ortho_scale: float = 6.0
    use_dof: bool = False
    focus_distance: float = 10.0
    focus_object_location: Optional[Sequence[float]] = None  # world space

    def position(self) -> list[float]:
        m = self.matrix_world
        return [m[0][3], m[1][3], m[2][3]]

    def forward(self) -> list[float]:
        """The view direction: the camera looks down its local -Z."""
        m = self.matrix_world
        return _norm([-m[0][2], -m[1][2], -m[2][2]])

    def up(self) -> list[float]:
        m = self.matrix_world
        return _norm([m[0][1], m[1][1], m[2][1]])

    def vertical_fov_deg(self, width: int, height: int) -> float:
        """The vertical field of view Blender renders with, from lens, sensor and its fit."""
        fit = self.sensor_fit
        if fit == "AUTO":
            fit = "HORIZONTAL" if width >= height else "VERTICAL"
            sensor = self.sensor_width
        else:
            sensor = self.sensor_width if fit == "HORIZONTAL" else self.sensor_height
        half = sensor / (2.0 * self.lens)
        if fit == "HORIZONTAL":
            half *= height / width
        return math.degrees(2.0 * math.atan(half))

    def ortho_height(self, width: int, height: int) -> float:
        """Blender's ortho_scale spans the larger side (AUTO fit)."""
        fit = self.sensor_fit
        if fit == "AUTO":
            fit = "HORIZONTAL" if width >= height else "VERTICAL"
        return self.ortho_scale * (height / width if fit == "HORIZONTAL" else 1.0)

    def focus(self) -> tuple[Optional[float], Optional[str]]:
        """Distance along the view to the focal centre: the depth-of-field focus object if set,
        else the focus distance when depth of field is on. (None, reason) when neither applies."""
        if self.focus_object_location is not None:
            p, f = self.position(), self.forward()
            d = sum((o - c) * k for o, c, k in zip(self.focus_object_location, p, f))
            if d > 1e-6:
                return d, None
            return None, "the camera's focus object is behind the camera: ignored"
        if self.use_dof and self.focus_distance > 0:
            return float(self.focus_distance), None
        return None, None


@dataclass
class SceneFacts:
    """Render-level facts the engine reads off Blender."""

    width: int
    height: int
    frame: int
    camera: Optional[CameraFacts] = None
    background: Optional[Sequence[float]] = None  # linear RGB of the world, None: no world
    transparent: bool = False
    warnings: list = field(default_factory=list)


def render_size(resolution_x: int, resolution_y: int, percentage: int) -> tuple[int, int]:
    """Blender's own rounding of the render size (truncation, at least 1 pixel)."""
    return max(1, int(resolution_x * percentage / 100)), max(1, int(resolution_y * percentage / 100))


def settings_from_panel(panel: Mapping[str, object], facts: SceneFacts) -> dict:
    """Every settings key from the panel's values (property name -> value) and Blender's
    facts. Raises runner.SettingError for text fields that do not parse."""
    p = panel
    f32 = runner.f32_decimal
    s: dict = {"width": facts.width, "height": facts.height}
    seed = int(p["seed"])
    if p.get("animate_seed"):
        seed += int(facts.frame)
    s["seed"] = max(seed, 0)
    for key in PLAIN_KEYS:
        v = p[key]
        s[key] = f32(v) if isinstance(v, float) else v
    for key in ENUM_KEYS:
        s[key] = presets.enum_value(str(p[key]))

    # Camera: the active camera's frame, its focus, its lens for the perspective kind.
    cam = facts.camera
    kind = s["camera"]
    # 0 = automatic (null): the renderer chooses the cubist angle per scene (`compose`).
    ambiguity = f32(p["ambiguity"])
    s["ambiguity"] = ambiguity if ambiguity > 0 else None
    camera_size = f32(p["camera_size"])
    if cam is not None:
        pos, fwd, up = cam.position(), cam.forward(), cam.up()
        focus, why = cam.focus() if p["use_camera_focus"] else (None, None)
        if why:
            facts.warnings.append(why)
        s["camera_position"] = to_gltf(pos)
        dist = focus if focus is not None else 1.0
        s["camera_target"] = to_gltf([c + k * dist for c, k in zip(pos, fwd)])
        s["camera_up"] = to_gltf(up)
        s["focus_distance"] = focus
        if kind == "perspective" and p["use_camera_lens"]:
            s["ambiguity"] = cam.vertical_fov_deg(facts.width, facts.height)
        if kind == "orthographic" and p["use_camera_lens"] and camera_size <= 0:
            s["camera_size"] = cam.ortho_height(facts.width, facts.height)
    if kind == "orthographic":
        s.pop("ambiguity")  # no angle: parallel rays
    if camera_size > 0:
        s["camera_size"] = camera_size
    fill = f32(p["fill"])
    s["fill"] = fill if fill > 0 else None  # 0 = the renderer's automatic fill

    # Background: the world colour (linear), else the panel's colour; Film > Transparent.
    if p["use_world_background"] and facts.background is not None:
        s["background"] = [max(float(c), 0.0) for c in facts.background[:3]]
    else:
        s["background"] = [f32(c) for c in p["background"][:3]]
    s["transparent"] = bool(facts.transparent)
    # The add-on's exported GLB is self-contained (buffers and images inside): it never needs
    # files outside the scene's folder (the URI confinement stays on).
    s["allow_external_files"] = False

    # Facets. A layout file of the user's replaces the computed (or static) layout.
    if p["faceting"] == "CONSTANT" or p.get("facet_map"):
        s["facet_map"] = p.get("facet_map") or None
    s["facets"] = p.get("layout_file") or None
    s["segments"] = runner.parse_number_list(str(p["segments"]), "Segments", int)
    s["thresholds"] = [f32(t) for t in runner.parse_number_list(str(p["thresholds"]), "Thresholds", float)]

    # Painterly.
    s["palette_image"] = p.get("palette_image") or None
    s["passes"] = [name for toggle, name, *_ in PASSES if p.get(toggle)]
    return runner.clean_settings(s)


def absolute(path: str, blend_dir: Optional[Path]) -> Optional[str]:
    """Blender's `//` (relative to the .blend) made absolute; '' -> None."""
    if not path:
        return None
    if path.startswith("//"):
        base = blend_dir if blend_dir is not None else Path.cwd()
        return str((base / path[2:]).resolve())
    return str(Path(path).expanduser())
