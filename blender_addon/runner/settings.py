"""The settings JSON the binary reads (`cubist render --config SETTINGS.json`): its keys and how
panel values become its values."""

from __future__ import annotations

import json
import math
import struct
from pathlib import Path
from typing import Iterable, Mapping

from .. import schema
from .errors import SettingError

# Every key the renderer accepts (`cubist settings --schema`, kept in renderer_schema.json;
# unknown keys are an error there).
SETTINGS_KEYS = schema.SETTINGS_KEYS
# Keys that only save time (the picture is the same without them): left out, rather than
# refused, for a binary that does not know them (`binary.settings_for_binary`).
OPTIONAL_KEYS = frozenset({"saliency_cache"})


def f32_decimal(v: float) -> float:
    """The shortest decimal that is the same 32-bit float as `v`. Blender keeps float
    properties in 32 bits, so a typed 0.85 reads back as 0.8500000238418579; the renderer
    reads 64-bit numbers, and gets what was typed (as from `--border-strength 0.85`)."""
    v = float(v)
    if not math.isfinite(v):
        return v
    try:
        bits = struct.pack("<f", v)
    except OverflowError:
        return v
    x = struct.unpack("<f", bits)[0]
    for digits in range(1, 10):
        d = float(f"{x:.{digits}g}")
        if struct.pack("<f", d) == bits:
            return d
    return x


def parse_number_list(text: str, key: str, kind: type = float) -> list:
    """'5, 30, 120' -> [5, 30, 120]; the error names the field."""
    parts = [p for p in text.replace(";", ",").replace(" ", ",").split(",") if p]
    if not parts:
        raise SettingError(f"{key}: give one or more numbers separated by commas")
    out = []
    for p in parts:
        try:
            v = kind(p)
        except ValueError:
            noun = "a whole number" if kind is int else "a number"
            raise SettingError(f"{key}: `{p}` is not {noun}") from None
        out.append(v)
    return out


def clean_settings(values: Mapping[str, object], extra_keys: Iterable[str] = ()) -> dict:
    """The settings JSON object: None values dropped (the renderer's default applies), keys
    checked against the contract so a typo fails here, in a test, not in a user's render."""
    allowed = SETTINGS_KEYS | set(extra_keys)
    unknown = sorted(k for k in values if k not in allowed)
    if unknown:
        raise SettingError(f"unknown setting(s) {', '.join(unknown)}")
    out = {}
    for k, v in values.items():
        if v is None:
            continue
        if isinstance(v, Path):
            v = str(v)
        elif isinstance(v, tuple):
            v = list(v)
        out[k] = v
    return out


def write_settings(path: Path, settings: Mapping[str, object]) -> None:
    path.write_text(json.dumps(settings, indent=2, sort_keys=True), encoding="utf-8")

