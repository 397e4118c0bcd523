"""Runs the `cubist` binary for the add-on, one concept per module:

- `binary`: finding the binary (preferences, PATH, bundled, project build), what it knows;
- `settings`: the settings JSON the binary reads;
- `layouts`: the facet layout shared by every frame (static facets) and its reuse;
- `progress`: the renderer's stderr lines and one forward-only progress bar;
- `process`: argv, running it with progress and cancel, the temporary workspace;
- `errors`: the one-line failures shown to the user.

No bpy here, on purpose: everything that can go wrong between Blender and the renderer is
decided in this package, and its tests run in plain Python (tests/python/test_addon_runner.py).
The names below are the package's interface: callers write `runner.find_binary(...)`,
`runner.run(...)`, and need not know which module holds what.
"""

from .binary import (
    ADDON_DIR,
    BINARY_NAME,
    PREFERENCE,
    RELEASE_PLATFORMS,
    binary_candidates,
    binary_keys,
    binary_supports,
    binary_version,
    bundled_platforms,
    executable_name,
    find_binary,
    locate_binary,
    manifest_field,
    missing_platform_binary,
    platform_tag,
    settings_for_binary,
)
from .errors import BinaryNotFound, Cancelled, CubistError, RendererError, SettingError
from .layouts import (
    LAYOUT_KEYS,
    PICTURE_FACETINGS,
    PRERENDER_KEYS,
    LayoutPlan,
    follow_path,
    follows_picture,
    follows_scene,
    forget_source,
    layout_is_current,
    layout_key,
    layout_path,
    layout_prepass,
    layout_source,
    layout_unreadable,
    plan_layout,
    record_source,
    source_path,
    uses_layout,
)
from .process import RunResult, Workspace, build_argv, pass_path, run
from .progress import STAGE_WEIGHTS, Line, ProgressTracker, parse_line
from .settings import (
    OPTIONAL_KEYS,
    SETTINGS_KEYS,
    clean_settings,
    f32_decimal,
    parse_number_list,
    write_settings,
)

__all__ = [
    "ADDON_DIR", "BINARY_NAME", "PREFERENCE", "RELEASE_PLATFORMS", "binary_candidates", "binary_keys",
    "binary_supports", "binary_version", "bundled_platforms", "executable_name", "find_binary", "locate_binary",
    "manifest_field", "missing_platform_binary", "platform_tag", "settings_for_binary",
    "BinaryNotFound", "Cancelled", "CubistError", "RendererError", "SettingError",
    "LAYOUT_KEYS", "PICTURE_FACETINGS", "PRERENDER_KEYS", "LayoutPlan", "follow_path", "follows_picture",
    "follows_scene", "forget_source", "layout_is_current", "layout_key", "layout_path",
    "layout_prepass", "layout_source", "layout_unreadable", "plan_layout", "record_source", "source_path", "uses_layout",
    "RunResult", "Workspace", "build_argv", "pass_path", "run",
    "STAGE_WEIGHTS", "Line", "ProgressTracker", "parse_line",
    "OPTIONAL_KEYS", "SETTINGS_KEYS", "clean_settings", "f32_decimal", "parse_number_list",
    "write_settings",
]
