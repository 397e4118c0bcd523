"""The renderer's stderr protocol (`--progress lines`): `PROGRESS <fraction> <stage>`,
`warning: ...` and `error: ...` lines, and one forward-only progress bar over its stages."""

from __future__ import annotations

from dataclasses import dataclass

from .. import schema

# The add-on's guess of each stage's share of a frame's time, for one progress bar that only
# moves forward. The stages and their order are the renderer's (`cubist settings --schema`);
# a stage without a guess here gets a small share, "done" ends the bar.
_GUESS = {"loading": 0.05, "pre-render": 0.30, "saliency": 0.15, "faceting": 0.20, "imprecision": 0.05,
          "re-trace": 0.15, "paint": 0.05, "writing": 0.05}
STAGE_WEIGHTS = tuple((name, _GUESS.get(name, 0.05)) for name in schema.STAGES if name != "done")
# A frame whose facets follow the layout frame's is rendered by the renderer's frames pipeline,
# which traces every pixel once in its "frames" stage: on the bar, that is the re-trace's part.
STAGE_ALIASES = {"frames": "re-trace"}


@dataclass
class Line:
    kind: str  # "progress", "error", "warning" or "other"
    text: str = ""
    fraction: float = 0.0


def parse_line(line: str) -> Line:
    line = line.rstrip("\r\n")
    if line.startswith("PROGRESS "):
        parts = line.split(" ", 2)
        try:
            f = float(parts[1])
        except (IndexError, ValueError):
            return Line("other", line)
        return Line("progress", parts[2] if len(parts) > 2 else "", min(max(f, 0.0), 1.0))
    if line.startswith("error: "):
        return Line("error", line[len("error: "):])
    if line.startswith("warning: "):
        return Line("warning", line[len("warning: "):])
    return Line("other", line)


class ProgressTracker:
    """Maps (stage, fraction of stage) onto one forward-only fraction in [lo, hi], the part
    of the frame's progress bar this run owns (a layout pre-pass takes the first part)."""

    def __init__(self, lo: float = 0.0, hi: float = 1.0):
        self.lo, self.hi = lo, hi
        self.total = sum(w for _, w in STAGE_WEIGHTS)
        self.value = 0.0
        self.stage = ""

    def update(self, stage: str, fraction: float) -> float:
        self.stage = stage
        stage = STAGE_ALIASES.get(stage, stage)
        done = 0.0
        for name, w in STAGE_WEIGHTS:
            if name == stage:
                self.value = max(self.value, (done + w * fraction) / self.total)
                break
            done += w
        else:
            if stage == "done":
                self.value = 1.0
        return self.lo + (self.hi - self.lo) * self.value
