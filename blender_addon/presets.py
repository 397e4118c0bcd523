"""Panel defaults and the built-in presets (no bpy).

`DEFAULTS` are the renderer's own defaults (src/settings.rs, the `analytic` preset) so that F12
with an untouched panel renders what `cubist render` renders. Presets are panel values to
apply on top of the defaults; the recommended values come from the thesis (Chapter 5):
ambiguity 120-150 degrees, discontinuity 50-200 pixels at 1000 px, segment faceting.
"""

DEFAULTS = {
    "preset": "ANALYTIC",
    "spp": 4,
    "seed": 0,
    "animate_seed": False,
    "camera": "AUTO",
    "ambiguity": 140.0,
    "use_camera_lens": True,
    "framing": "FIT",
    "use_camera_focus": True,
    "camera_size": 0.0,
    "shadows": True,
    "exposure": 1.0,
    "use_world_background": True,
    "background": (0.62, 0.56, 0.46),
    "faceting": "NONE",
    "facet_map": "",
    "facet_count": 150,
    "grid_cells": 15,
    "patch_count": 80,
    "occlusion": 3.0,
    "segments": "5, 30, 120",
    "thresholds": "0, 0.05, 0.08",
    "static_facets": True,
    "layout_folder": "",
    "layout_frame": 1,
    "imprecision": "SALIENCY",
    "discontinuity": 0.0,
    "neighborhood": 0.0,
    "facet_projection": "CONVERGING",
    "facet_fov": 0.0,
    "border_width": 0.0,
    "border_strength": 1.0,
    "silhouette_width": 0.0,
    "silhouette_strength": 1.0,
    "palette": "NONE",
    "palette_image": "",
    "colors": 0,
    "gradients": 0.0,
    "chiaroscuro": 0.0,
    "pass_saliency": False,
    "pass_facet_ids": False,
    "pass_facets": False,
    "pass_segments": False,
    "pass_objects": False,
    "pass_normals": False,
    "pass_depth": False,
}

# The panel values each preset sets (the rest return to DEFAULTS). Order = menu order.
BUILTIN = {
    "Default": {},
    "Paper (recommended)": {
        "ambiguity": 140.0, "faceting": "SEGMENT", "imprecision": "SALIENCY", "discontinuity": 100.0,
        "border_width": 6.0, "silhouette_width": 4.0, "palette": "OCHRE", "colors": 24, "gradients": 0.3,
    },
    "Plain cubist camera": {"preset": "PLAIN", "faceting": "NONE", "discontinuity": 0.0},
    "Voronoi facets": {"faceting": "VORONOI", "facet_count": 150, "grid_cells": 15, "discontinuity": 100.0,
                       "border_width": 4.0},
    "Patch facets": {"faceting": "PATCH", "patch_count": 80, "occlusion": 3.0, "discontinuity": 100.0,
                     "border_width": 4.0},
    "Random imprecision (study baseline)": {"faceting": "SEGMENT", "imprecision": "RANDOM",
                                            "discontinuity": 100.0},
    "Linear facets": {"faceting": "SEGMENT", "discontinuity": 100.0, "facet_projection": "LINEAR",
                      "facet_fov": 0.0},
}

# Settings that a preset does not touch: where files go, what passes are written, the
# Blender-camera mapping choices (they are about the scene, not the look).
NOT_IN_PRESETS = {"layout_folder", "layout_frame", "static_facets", "use_world_background", "use_camera_focus",
                  "use_camera_lens", "facet_map", "palette_image"} | {k for k in DEFAULTS if k.startswith("pass_")}


def preset_values(name: str) -> dict:
    """The panel values of a built-in preset: DEFAULTS overridden by the preset."""
    if name not in BUILTIN:
        raise KeyError(f"unknown preset {name!r}")
    values = {k: v for k, v in DEFAULTS.items() if k not in NOT_IN_PRESETS}
    values.update(BUILTIN[name])
    return values
