"""The renderer's stderr protocol (`--progress lines`): `PROGRESS <fraction> <stage>`,
`warning: ...` and `error: ...` lines, and one forward-only progress bar over its stages."""

from __future__ import annotations

from dataclasses import dataclass

# Renderer stages in pipeline order with their rough share of a frame's time, for one
# progress bar that only moves forward. Unknown stages keep the bar where it is.
# Names as src/pipeline.rs and src/main.rs report them (`--progress lines`).
STAGE_WEIGHTS = (
    ("loading", 0.05),
    ("pre-render", 0.30),
    ("saliency", 0.15),
    ("faceting", 0.20),
    ("imprecision", 0.05),
    ("re-trace", 0.15),
    ("paint", 0.05),
    ("writing", 0.05),
)


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
