"""What the renderer says about itself (no bpy): every setting's type, default, range or
choices, unit, help and group, the stages its progress reports, and its presets.

`renderer_schema.json` is what `cubist settings --schema` prints for the bundled binary
(written by `scripts/sync_addon_presets.py`; a test and the extension build refuse a copy that
differs from the binary's). The panel's properties, the settings keys, the enum values, the
stage names and the preset names all come from it: adding a setting to the renderer and
running the script is all the add-on needs (README, "The settings schema").
"""

from __future__ import annotations

import json
from pathlib import Path

SCHEMA_FILE = Path(__file__).resolve().parent / "renderer_schema.json"
# The shape of the schema this add-on reads (`version` in the file).
SCHEMA_VERSION = 1


class SchemaError(Exception):
    """The schema file is missing or not what this add-on reads."""


def load(path: Path = SCHEMA_FILE) -> dict:
    try:
        with open(path, encoding="utf-8") as f:
            data = json.load(f)
    except (OSError, ValueError) as e:
        raise SchemaError(f"{path.name}: {e}") from None
    if not isinstance(data, dict) or data.get("version") != SCHEMA_VERSION:
        raise SchemaError(f"{path.name}: not a version {SCHEMA_VERSION} schema of `cubist settings --schema`")
    return data


SCHEMA = load()

# Every settings key, in the renderer's order -> its description (see README).
SETTINGS: dict = {f["key"]: f for f in SCHEMA["settings"]}
SETTINGS_KEYS = frozenset(SETTINGS)
# Keys whose value is one name of a list of choices.
ENUM_KEYS = tuple(k for k, f in SETTINGS.items() if f["type"] == "enum")
# The stages a render reports (`PROGRESS <fraction> <stage>`), in the order it runs them.
STAGES = tuple(s["name"] for s in SCHEMA["stages"])
STAGE_HELP = {s["name"]: s["help"] for s in SCHEMA["stages"]}
# Preset name -> what it is, in the renderer's order.
PRESETS = {p["name"]: p["help"] for p in SCHEMA["presets"]}


def default(key: str):
    """The renderer's default of `key` (the analytic preset's; None = chosen per scene)."""
    return SETTINGS[key]["default"]


def choices(key: str) -> list[tuple[str, str]]:
    """(value, help) of every choice of an enum key (or of an array of enums), in order."""
    return [(c["value"], c["help"]) for c in SETTINGS[key].get("choices", [])]


def label(value: str) -> str:
    """A choice's name for people: 'blue-period' -> 'Blue Period'."""
    return " ".join(w.capitalize() for w in value.replace("_", "-").split("-"))


def automatic(key: str, case: str):
    """The value the renderer uses for a null `key` in `case` (e.g. the camera kind), when the
    schema states one (`automatic`); None otherwise."""
    auto = SETTINGS[key].get("automatic") or {}
    return auto.get(case, auto.get("other"))


def pass_format(name: str) -> str:
    """How the renderer writes pass `name`: 'grey', 'grey16', 'rgba16' or 'rgb'."""
    return SETTINGS["passes"]["formats"][name]
