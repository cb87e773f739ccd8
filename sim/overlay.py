"""Text drawn on a video's frames (pillow, extra ``[video]``): a panel of lines at the top left
(time, speeds, the entry's name) and, at the end of a run, a banner with the verdict, green for a
pass and red for a failure, wrapped to the frame's width."""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np

PANEL_RGBA = (0, 0, 0, 150)
PASS_RGBA = (25, 135, 60, 225)
FAIL_RGBA = (185, 35, 35, 225)


@dataclass(frozen=True)
class Caption:
    """What one frame says: ``lines`` at the top left; ``verdict`` ("" for none) in a banner at the
    bottom, green when ``passed``."""

    lines: tuple[str, ...]
    verdict: str = ""
    passed: bool = True


@lru_cache(maxsize=8)
def _font(size: int) -> Any:
    from PIL import ImageFont

    return ImageFont.load_default(size=size)


def text_px(height: int) -> int:
    """The text's size for a frame ``height`` pixels high (27 px at 720) [px]."""
    return max(10, round(height / 26.7))


def draw_caption(frame: np.ndarray, caption: Caption) -> np.ndarray:
    """``frame`` (H, W, 3) with ``caption`` drawn on it (a new array)."""
    from PIL import Image, ImageDraw

    image = Image.fromarray(frame).convert("RGBA")
    layer = Image.new("RGBA", image.size, (0, 0, 0, 0))
    pen = ImageDraw.Draw(layer)
    size = text_px(image.height)
    font, pad, step = _font(size), size // 2, round(size * 1.3)
    if caption.lines:
        width = max(pen.textlength(line, font=font) for line in caption.lines)
        pen.rounded_rectangle((pad, pad, pad + width + 2 * pad, pad + step * len(caption.lines) + pad),
                              radius=pad, fill=PANEL_RGBA)
        for i, line in enumerate(caption.lines):
            pen.text((2 * pad, 1.5 * pad + i * step), line, font=font, fill=(255, 255, 255, 255))
    if caption.verdict:
        rows = wrap(caption.verdict, lambda s: pen.textlength(s, font=font), image.width - 4 * pad)
        top = image.height - pad - step * len(rows) - pad
        pen.rounded_rectangle((pad, top, image.width - pad, image.height - pad), radius=pad,
                              fill=PASS_RGBA if caption.passed else FAIL_RGBA)
        for i, row in enumerate(rows):
            pen.text((2 * pad, top + 0.5 * pad + i * step), row, font=font, fill=(255, 255, 255, 255))
    return np.asarray(Image.alpha_composite(image, layer).convert("RGB"))


def wrap(text: str, length: Any, width: float) -> list[str]:
    """``text`` in rows no wider than ``width`` by ``length(row)`` (a word longer than that alone)."""
    rows: list[str] = []
    for word in text.split():
        if rows and length(f"{rows[-1]} {word}") <= width:
            rows[-1] = f"{rows[-1]} {word}"
        else:
            rows.append(word)
    return rows
