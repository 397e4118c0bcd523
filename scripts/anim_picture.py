#!/usr/bin/env python3
"""An animated WebP or GIF from frames rendered by `cubist render --frames` (docs/animation.md).

Usage: anim_picture.py PATTERN FIRST LAST OUT.(webp|gif) [--fps N] [--width W] [--loops N]

PATTERN is the frame path with a run of # (as given to `-o`). Frames are scaled down to at most
W pixels wide (default 480) and written looping (0 = forever) at N frames per second (default
12). WebP is lossy at quality 80 (a few hundred KB for a dozen frames); GIF uses one adaptive
palette of 256 colours for the whole sequence, so the still parts keep the same colours from
frame to frame instead of each frame's own dithering. Needs Pillow.
"""

import argparse
import re
import sys

from PIL import Image


def frame_path(pattern, f):
    m = list(re.finditer(r"#+", pattern))[-1]
    return pattern[: m.start()] + str(f).zfill(m.end() - m.start()) + pattern[m.end() :]


def main(argv):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("pattern")
    ap.add_argument("first", type=int)
    ap.add_argument("last", type=int)
    ap.add_argument("out")
    ap.add_argument("--fps", type=float, default=12.0)
    ap.add_argument("--width", type=int, default=480)
    ap.add_argument("--loops", type=int, default=0)
    a = ap.parse_args(argv[1:])
    if a.last < a.first or a.fps <= 0 or a.width <= 0:
        print("anim_picture: need FIRST <= LAST, --fps > 0 and --width > 0", file=sys.stderr)
        return 2
    frames = []
    for f in range(a.first, a.last + 1):
        try:
            img = Image.open(frame_path(a.pattern, f)).convert("RGB")
        except OSError as e:
            print(f"anim_picture: frame {f}: {e}", file=sys.stderr)
            return 1
        if img.width > a.width:
            img = img.resize((a.width, round(img.height * a.width / img.width)), Image.LANCZOS)
        frames.append(img)
    duration = round(1000.0 / a.fps)
    if a.out.lower().endswith(".gif"):
        # One palette for every frame (from a strip of all of them), no dithering: a still
        # pixel keeps its colour index from frame to frame.
        strip = Image.new("RGB", (frames[0].width, frames[0].height * len(frames)))
        for k, img in enumerate(frames):
            strip.paste(img, (0, k * frames[0].height))
        palette = strip.quantize(colors=256, method=Image.MEDIANCUT)
        frames = [img.quantize(palette=palette, dither=Image.Dither.NONE) for img in frames]
        frames[0].save(a.out, save_all=True, append_images=frames[1:], duration=duration, loop=a.loops,
                       optimize=False, disposal=1)
    elif a.out.lower().endswith(".webp"):
        frames[0].save(a.out, save_all=True, append_images=frames[1:], duration=duration, loop=a.loops,
                       quality=80, method=4)
    else:
        print("anim_picture: OUT must end in .webp or .gif", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
