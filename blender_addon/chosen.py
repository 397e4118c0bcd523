"""What the renderer chose for the settings the panel leaves to it (its "Auto" values), read
from the report `cubist render --verbose` prints (no bpy): the camera line, e.g.
`camera: spherical camera, 159.6 deg, focal centre (...)`, gives the angle, which is Ambiguity
(the cubist camera's angle, a perspective camera's field of view). The renderer does not report
the fill it chose."""

from __future__ import annotations

import re

CAMERA_LINE = re.compile(r"(?m)^camera: ([a-z][a-z -]*?) camera, (\d+(?:\.\d+)?) deg\b")


def from_report(text: str) -> dict:
    """{settings key: the value the renderer chose} found in a render's report (stderr)."""
    m = CAMERA_LINE.search(text)
    if m is None:
        return {}
    return {"ambiguity": float(m.group(2))}
