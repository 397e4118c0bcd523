"""Drawing a viewport's image (main thread, in `view_draw`: Blender's GPU context): the image
as a texture over the view's rect, errors and status as text."""

from __future__ import annotations

import numpy as np

from .. import picture

# Tests: every drawn frame's facts (image size and scale, rect, readback) when on.
record_draws = False


def gpu_pixels(pixels: np.ndarray) -> np.ndarray:
    """8-bit sRGB RGBA rows, top row first, as the GPU texture's data: scene-linear float,
    rows bottom-up, alpha premultiplied (the ALPHA_PREMULT blend). Blender shows a viewport
    engine's drawing through the scene's view transform, as it shows F12's result: sRGB values
    drawn as they are were encoded twice (a washed-out picture, each colour as light as
    linear-to-sRGB of itself), so they are decoded here, as F12's hand-back does."""
    return picture.result_rect(pixels, (0, 0, pixels.shape[1], pixels.shape[0])).reshape(-1)


def texture_of(session, image):
    """The image as a GPU texture, uploaded once per image."""
    import gpu

    key = (image.generation, image.scale, id(image.pixels))
    if session.texture is not None and session.texture[0] == key:
        return session.texture[1]
    flat = gpu_pixels(image.pixels)
    buf = gpu.types.Buffer("FLOAT", flat.size, flat)
    tex = gpu.types.GPUTexture((image.width, image.height), format="RGBA16F", data=buf)
    session.texture = (key, tex)
    session.counts["uploads"] += 1
    return tex


def draw_image(session, image, x: int, y: int, width: int, height: int) -> None:
    """Draws the image over (x, y, width, height) of the region. The picture's own sRGB colours
    are drawn as they are: the painting as F12 shows it with the Standard view transform (which
    the add-on sets, docs/blender.md "Colours")."""
    import gpu
    from gpu_extras.presets import draw_texture_2d

    tex = texture_of(session, image)
    gpu.state.blend_set("ALPHA_PREMULT")
    draw_texture_2d(tex, (x, y), width, height)
    gpu.state.blend_set("NONE")
    if record_draws:
        entry = {"generation": image.generation, "scale": image.scale, "image": [image.width, image.height],
                 "rect": [x, y, width, height]}
        try:
            fb = gpu.state.active_framebuffer_get()
            cx, cy = x + width // 2, y + height // 2
            entry["centre"] = [cx, cy]
            entry["readback"] = [float(v) for v in fb.read_color(cx, cy, 1, 1, 4, 0, "FLOAT").to_list()[0][0]]
        except Exception as e:  # readback is a test aid only
            entry["readback_error"] = f"{type(e).__name__}: {e}"
        session.draws.append(entry)
        del session.draws[:-100]


def draw_text(region, lines: list) -> None:
    import blf

    font = 0
    try:
        blf.size(font, 13)
    except TypeError:  # Blender 3.x: blf.size(fontid, size, dpi)
        blf.size(font, 13, 72)
    blf.color(font, 1.0, 1.0, 1.0, 1.0)
    y = 12
    for line in reversed(lines):
        for chunk in _wrap(line, max(20, region.width // 8)):
            blf.position(font, 12, y, 0)
            blf.draw(font, chunk)
            y += 18


def _wrap(text: str, width: int) -> list:
    words, out, cur = text.split(), [], ""
    for w in words:
        if cur and len(cur) + 1 + len(w) > width:
            out.append(cur)
            cur = w
        else:
            cur = f"{cur} {w}" if cur else w
    if cur:
        out.append(cur)
    return list(reversed(out))
