"""Captions on a video's frames: the lines change only the panel at the top left, the verdict only
a banner at the bottom in the verdict's colour; a long verdict wraps within the frame."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("PIL")

from skatelib.sim.overlay import FAIL_RGBA, PASS_RGBA, Caption, draw_caption, text_px, wrap

H, W = 720, 1280
LINES = ("v0.50_s2 on the MuJoCo twin, errors: none", "t =  1.00 s", "board 0.48 m/s   label 0.50 m/s")


def _frame() -> np.ndarray:
    return np.random.default_rng(0).integers(60, 200, (H, W, 3), dtype=np.uint8)


def _changed(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.abs(a.astype(int) - b.astype(int)).sum(axis=2) > 0


def test_the_time_changes_the_panel_only():
    """Two frames whose captions differ in the time differ inside the top-left panel (at most half
    the width, four text rows high) and nowhere else. Negative control: an empty caption changes
    nothing."""
    frame = _frame()
    one = draw_caption(frame, Caption(LINES))
    two = draw_caption(frame, Caption((LINES[0], "t =  2.00 s", LINES[2])))
    diff = _changed(one, two)
    panel = np.zeros_like(diff)
    panel[:5 * text_px(H), :W // 2] = True
    assert diff[panel].sum() > 50 and not diff[~panel].any()
    assert _changed(one, frame)[panel].mean() > 0.2
    assert not _changed(draw_caption(frame, Caption(())), frame).any()


@pytest.mark.parametrize("passed", [True, False])
def test_the_verdict_is_a_banner_in_its_colour(passed):
    """The verdict adds a banner in the bottom rows, green for a pass and red for a failure (the
    banner's median colour is nearer its own than the other's), leaving the middle of the frame."""
    frame = _frame()
    lines = draw_caption(frame, Caption(LINES))
    judged = draw_caption(frame, Caption(LINES, "FAIL: a stance slipped 1.2 cm " * 6, passed))
    diff = _changed(lines, judged)
    rows = np.nonzero(diff.any(axis=1))[0]
    assert rows.min() > H // 2 and rows.max() < H
    banner = np.median(judged[rows.min() + 5:rows.max() - 5, 10:W - 10].reshape(-1, 3), axis=0)
    own, other = (PASS_RGBA, FAIL_RGBA) if passed else (FAIL_RGBA, PASS_RGBA)
    assert np.linalg.norm(banner - own[:3]) < np.linalg.norm(banner - other[:3])


def test_wrap_keeps_the_words_within_the_width():
    """Rows at most ``width`` long (by the given length) and the words in order."""
    text = " ".join(f"word{i}" for i in range(40))
    rows = wrap(text, len, 30)
    assert all(len(r) <= 30 for r in rows) and " ".join(rows) == text
    assert wrap("a" * 50, len, 30) == ["a" * 50]  # a word longer than the width stands alone
