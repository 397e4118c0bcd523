"""Panel defaults and presets, taken from the renderer itself (no bpy).

`renderer_presets.json` is what `cubist settings --preset NAME` prints for every preset of
the bundled binary (written by `scripts/sync_addon_presets.py`; a test and the extension build
refuse a copy that differs from the binary's). The panel's defaults are the `analytic`
preset's values read from it, so an untouched panel sends exactly the settings `cubist render`
uses, and applying a preset in Blender gives exactly `cubist render --preset NAME`:
the defaults cannot drift from the renderer by hand.

`panel_from_settings` is the inverse of `mapping.settings_from_panel`: settings JSON -> the
panel's values. Values the settings leave to the scene (null) are the panel's "automatic" 0.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Mapping

from . import runner

PRESETS_FILE = Path(__file__).resolve().parent / "renderer_presets.json"

# Settings enum values <-> panel enum identifiers (Blender identifiers: upper case, `_`).
ENUM_KEYS = ("preset", "camera", "framing", "faceting", "imprecision", "facet_projection", "palette",
             "saliency_method")


def enum_id(value: str) -> str:
    return value.upper().replace("-", "_")


def enum_value(ident: str) -> str:
    return ident.lower().replace("_", "-")


def load_renderer_presets(path: Path = PRESETS_FILE) -> dict:
    """{preset name: the settings `cubist settings --preset NAME` prints}."""
    with open(path, encoding="utf-8") as f:
        data = json.load(f)
    if not isinstance(data, dict) or "analytic" not in data:
        raise runner.CubistError(f"{path.name}: not a table of the renderer's presets")
    return data


RENDERER_PRESETS = load_renderer_presets()

# Preset name -> (menu label, description). Order = menu order. A test checks these are the
# renderer's presets (src/settings.rs `Preset`).
PRESET_LABELS = {
    "analytic": ("Analytic", "The paper's recommended look (the renderer's default): convergence 140 deg, "
                 "Segment facets, discontinuity 200, bold borders, ochre palette, some gradients"),
    "braque": ("Braque", "Braque's earthy 1909-10 canvases: olive palette, 8 colours, heavy borders, many "
               "gradients, light manipulated facet by facet"),
    "blue-period": ("Blue Period", "Picasso's blue period: blue palette, softer borders, strong silhouettes, "
                    "gentler discontinuity"),
    "grisaille": ("Grisaille", "The grey canvases of 1911: grey palette quantised to 6 tones, relit facets"),
    "plain": ("Plain", "The bare cubist camera: no facets, no painterly effects"),
}

# Settings keys Blender decides, not the panel: the render size, Film > Transparent, the
# active camera and its focus, the per-frame layout files (static facets), the saliency
# cache folder (beside the layout).
BLENDER_KEYS = frozenset({"width", "height", "transparent", "camera_position", "camera_target", "camera_up",
                          "focus_distance", "facets", "save_facets", "saliency_cache"})

# Panel properties with no settings key of their own: how Blender's scene maps to settings,
# animation, and files. The renderer has no say in these.
ADDON_DEFAULTS = {
    "animate_seed": False,
    "use_camera_lens": True,
    "use_camera_focus": True,
    "use_world_background": True,
    "static_facets": True,
    "layout_frame": 1,
    "layout_folder": "",
    "layout_file": "",
    "use_saliency_cache": True,
    "saliency_cache": "",
}

# Render passes: panel toggle -> the renderer's pass name.
PASS_TOGGLES = {"pass_saliency": "saliency", "pass_facet_ids": "facet-ids", "pass_facets": "facets",
                "pass_segments": "segments", "pass_objects": "objects", "pass_normals": "normals",
                "pass_depth": "depth"}

# The convergence angle the renderer uses when `ambiguity` is null (Settings::angle_deg).
DEFAULT_ANGLE = {"perspective": 60.0}
DEFAULT_CUBIST_ANGLE = 140.0


def format_number_list(values) -> str:
    """[5, 30, 120] -> '5, 30, 120'; floats keep every digit ('0.05'), whole ones lose '.0'."""
    out = []
    for v in values:
        if isinstance(v, float) and v.is_integer():
            v = int(v)
        out.append(repr(v))
    return ", ".join(out)


def panel_from_settings(settings: Mapping[str, object]) -> dict:
    """The panel's values for a settings object (every key of `cubist settings`). Raises
    CubistError on a key the add-on does not know, so a new renderer setting cannot be
    silently missing from the panel."""
    s = dict(settings)
    unknown = sorted(set(s) - runner.SETTINGS_KEYS)
    if unknown:
        raise runner.CubistError(f"settings the add-on does not know: {', '.join(unknown)}")
    missing = sorted(runner.SETTINGS_KEYS - set(s))
    if missing:
        raise runner.CubistError(f"settings missing: {', '.join(missing)}")
    p: dict = {}
    for k in ENUM_KEYS:
        p[k] = enum_id(str(s[k]))
    for k in ("spp", "seed", "facet_count", "grid_cells", "patch_count", "superpixels", "colors"):
        p[k] = int(s[k])
    for k in ("occlusion", "weight_colour", "weight_normal", "weight_depth", "weight_object", "weight_saliency",
              "discontinuity", "neighborhood", "facet_fov", "border_width", "border_strength", "silhouette_width",
              "silhouette_strength", "gradients", "chiaroscuro", "exposure"):
        p[k] = float(s[k])
    p["shadows"] = bool(s["shadows"])
    a = s["ambiguity"]
    p["ambiguity"] = float(a) if a is not None else DEFAULT_ANGLE.get(str(s["camera"]), DEFAULT_CUBIST_ANGLE)
    # null = automatic, shown as 0 (out of the settings' valid range, so unambiguous).
    p["camera_size"] = float(s["camera_size"] or 0.0)
    p["fill"] = float(s["fill"] or 0.0)
    p["background"] = tuple(float(c) for c in s["background"])
    p["segments"] = format_number_list(s["segments"])
    p["thresholds"] = format_number_list([float(t) for t in s["thresholds"]])
    p["facet_map"] = str(s["facet_map"] or "")
    p["palette_image"] = str(s["palette_image"] or "")
    passes = list(s["passes"])
    for toggle, name in PASS_TOGGLES.items():
        p[toggle] = name in passes
    return p


def _ordered_defaults() -> dict:
    """Every panel property's default, in the panel's order (the preset files' order too)."""
    base = panel_from_settings(RENDERER_PRESETS["analytic"])
    order = ("preset", "spp", "seed", "animate_seed",
             "camera", "ambiguity", "use_camera_lens", "framing", "use_camera_focus", "camera_size", "fill",
             "shadows", "exposure", "use_world_background", "background",
             "faceting", "facet_map", "facet_count", "grid_cells", "patch_count", "occlusion", "segments",
             "thresholds", "superpixels", "weight_colour", "weight_normal", "weight_depth", "weight_object",
             "weight_saliency", "static_facets", "layout_folder", "layout_frame", "layout_file",
             "imprecision", "discontinuity", "neighborhood", "facet_projection", "facet_fov",
             "saliency_method", "use_saliency_cache", "saliency_cache",
             "border_width", "border_strength", "silhouette_width", "silhouette_strength", "palette",
             "palette_image", "colors", "gradients", "chiaroscuro") + tuple(PASS_TOGGLES)
    values = {**base, **ADDON_DEFAULTS}
    assert set(order) == set(values), sorted(set(order) ^ set(values))
    return {k: values[k] for k in order}


DEFAULTS = _ordered_defaults()

# Panel values a preset does not touch: sampling and seed (quality, not look), the scene's own
# choices (background, camera lens and focus), files, animation, passes, the saliency method
# (accuracy, not look).
NOT_IN_PRESETS = frozenset({"spp", "seed", "animate_seed", "use_camera_lens", "use_camera_focus",
                            "use_world_background", "background", "facet_map", "static_facets", "layout_folder",
                            "layout_frame", "layout_file", "saliency_method", "use_saliency_cache",
                            "saliency_cache"} | set(PASS_TOGGLES))
LOOK_KEYS = tuple(k for k in DEFAULTS if k not in NOT_IN_PRESETS)

# Variations on a renderer preset: the thesis's other methods. (base preset, panel values.)
VARIANTS = {
    "Voronoi Facets": ("analytic", {"faceting": "VORONOI", "facet_count": 150, "grid_cells": 15}),
    "Patch Facets": ("analytic", {"faceting": "PATCH", "patch_count": 80, "occlusion": 3.0}),
    "Random Imprecision (study baseline)": ("analytic", {"imprecision": "RANDOM"}),
    "Linear Facets": ("analytic", {"facet_projection": "LINEAR", "facet_fov": 0.0}),
}

# Built-in menu entries: label -> (renderer preset, panel overrides). Order = menu order.
BUILTIN = {label: (name, {}) for name, (label, _) in PRESET_LABELS.items()}
BUILTIN.update(VARIANTS)


def renderer_preset_values(name: str) -> dict:
    """The panel values (LOOK_KEYS) of the renderer's preset `name` ('braque')."""
    if name not in RENDERER_PRESETS:
        raise KeyError(f"unknown renderer preset {name!r}")
    values = panel_from_settings(RENDERER_PRESETS[name])
    return {k: values[k] for k in LOOK_KEYS}


def preset_values(label: str) -> dict:
    """The panel values a built-in menu entry sets (every look value, so nothing of the
    previous look is left)."""
    if label not in BUILTIN:
        raise KeyError(f"unknown preset {label!r}")
    name, overrides = BUILTIN[label]
    values = renderer_preset_values(name)
    values.update(overrides)
    return values
