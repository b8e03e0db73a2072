"""The RVE preview (psdesign.report.preview.render_preview) shows the whole box.

Truth: the picture's own pixels. An empty box (no fiber) renders as its black outline; every
outline pixel must lie inside the picture with a margin, for the two picture sizes psdesign
writes (`generate`'s preview.png, 900 x 700; a study case's, 480 x 400) and for a cube, a flat
sheet (a GDL) and a tall column. Session 42: the camera's zoom of 1.1 after the isometric reset
cut the box's lowest corner (and the fibers there) off every preview: the outline reached the
last row of the picture.
"""

from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from psdesign.report.preview import box_label, render_preview

#: Pixels between the outline and the picture's edge, at least.
MARGIN_PX = 5


def _in_label(rows: np.ndarray, cols: np.ndarray, window: tuple[int, int]) -> np.ndarray:
    """Pixels of the box-size label's corner (lower right, :func:`box_label`)."""
    width, height = window
    return (cols > 0.55 * width) & (rows > 0.9 * height)


@pytest.mark.parametrize("window", [(900, 700), (480, 400)])
@pytest.mark.parametrize("shape", [(16, 16, 16), (32, 32, 8), (8, 8, 32)])
def test_preview_shows_the_whole_box(tmp_path, window, shape) -> None:
    distance = np.full(shape, 1e-6)  # all pore: only the box outline is drawn
    path = render_preview(distance, np.full(3, 1e-6), tmp_path / "p.png", window_size=window)
    gray = np.asarray(Image.open(path).convert("L"))
    assert gray.shape == (window[1], window[0])
    rows, cols = np.nonzero(gray < 128)
    width, height = window
    axes_widget = (cols < 0.2 * width) & (rows > 0.75 * height)  # the x-y-z triad, lower left
    keep = ~axes_widget & ~_in_label(rows, cols, window)
    rows, cols = rows[keep], cols[keep]
    assert len(rows) > 100  # the outline was drawn
    assert rows.min() >= MARGIN_PX and rows.max() < height - MARGIN_PX, (rows.min(), rows.max())
    assert cols.min() >= MARGIN_PX and cols.max() < width - MARGIN_PX, (cols.min(), cols.max())


@pytest.mark.parametrize("window", [(900, 700), (480, 400)])
def test_preview_carries_its_scale(tmp_path, window) -> None:
    """The picture says how big its box is (session 45: no preview had a scale; an engineer
    could not tell a 50 um box of 7 um fibers from a 1 mm one). Truth: the box's edges,
    n * voxel, in micrometres, and dark text pixels in the label's corner, where the empty
    box draws none (main's preview: 0 dark pixels there)."""
    shape, h = (60, 60, 30), 0.8333333333333333e-6
    assert box_label(shape, np.full(3, h)) == "box 50 x 50 x 25 µm"
    distance = np.full(shape, 1e-6)
    path = render_preview(distance, np.full(3, h), tmp_path / "p.png", window_size=window)
    gray = np.asarray(Image.open(path).convert("L"))
    rows, cols = np.nonzero(gray < 128)
    assert _in_label(rows, cols, window).sum() > 50


def test_box_label_writes_every_edge_out_without_an_exponent() -> None:
    """review s45: a 1.5 mm x 1.5 mm x 200 um box was labelled "box 1.5e+03 x 1.5e+03 x 200
    µm" (``.3g``; rve.size allows up to 1 m). Truth: the edges n * voxel in micrometres, 3
    significant digits, written out, for cubic and non-cubic boxes and voxels."""
    assert box_label((1500, 1500, 200), np.full(3, 1e-6)) == "box 1500 x 1500 x 200 µm"
    assert box_label((100, 100, 50), np.array([1e-6, 1e-6, 0.5e-6])) == "box 100 x 100 x 25 µm"
    assert box_label((1234, 1, 3), np.full(3, 1e-6)) == "box 1230 x 1 x 3 µm"
    assert box_label((1000, 10, 10), np.full(3, 1e-3)) == "box 1000000 x 10000 x 10000 µm"
    assert box_label((3, 3, 3), np.full(3, 1e-7)) == "box 0.3 x 0.3 x 0.3 µm"
