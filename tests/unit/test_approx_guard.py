"""The approx guard (tests/approx_guard.py): a stated relative bar is the one enforced."""

from __future__ import annotations

import numpy as np
import pytest


def test_default_abs_cannot_pass_a_value_outside_the_stated_rel() -> None:
    # |6.5e-12 - 7.17e-12| = 6.7e-13 <= 1e-12: plain pytest.approx would accept it
    with pytest.raises(AssertionError, match="only by its default abs"):
        assert 6.5e-12 == pytest.approx(7.17e-12, rel=1e-9)
    with pytest.raises(AssertionError, match="only by its default abs"):
        assert [1.0, 6.5e-12] == pytest.approx([1.0, 7.17e-12], rel=1e-3)
    with pytest.raises(AssertionError, match="only by its default abs"):
        assert np.array([3e-13]) == pytest.approx(np.array([0.0]))  # an expected zero needs abs


def test_stated_bars_still_decide() -> None:
    assert 7.17e-12 * (1 + 5e-10) == pytest.approx(7.17e-12, rel=1e-9)
    assert 6.5e-12 == pytest.approx(7.17e-12, rel=0.1)
    assert 3e-13 == pytest.approx(0.0, abs=1e-12)  # an explicit abs is the stated bar
    assert 1.0 != pytest.approx(2.0, rel=1e-3)
    assert 7.0e-12 != pytest.approx(7.17e-12, rel=1e-3, abs=0)
