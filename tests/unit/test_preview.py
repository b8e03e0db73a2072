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

from psdesign.report.preview import render_preview

#: Pixels between the outline and the picture's edge, at least.
MARGIN_PX = 5


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
    rows, cols = rows[~axes_widget], cols[~axes_widget]
    assert len(rows) > 100  # the outline was drawn
    assert rows.min() >= MARGIN_PX and rows.max() < height - MARGIN_PX, (rows.min(), rows.max())
    assert cols.min() >= MARGIN_PX and cols.max() < width - MARGIN_PX, (cols.min(), cols.max())
