"""Make ``pytest.approx``'s stated relative bar the enforced one.

``pytest.approx(x, rel=r)`` keeps a default ``abs=1e-12``: the check passes when
``|actual - x| <= max(r |x|, 1e-12)``. For SI magnitudes (K in m^2 ~ 1e-11, lengths in m,
viscosities 1.8e-5 Pa s) that silently widens the stated bar, e.g. ``approx(7.17e-12,
rel=1e-9)`` accepted 6.5e-12 (session 17, approx17: ~100 such asserts fixed; four of them could
not fail at their stated bar). Installed from ``conftest.py``: a check that passes only by that
default absolute tolerance fails instead, naming the values; give ``abs=`` explicitly where an
absolute bar is meant (e.g. an expected zero). ``benchmarks/approx_scan.py`` finds the widened
ones that still pass.
"""

from __future__ import annotations

from _pytest.python_api import ApproxScalar

_plain_eq = ApproxScalar.__eq__


def _stated_bar_eq(self: ApproxScalar, actual) -> bool:
    passed = _plain_eq(self, actual)
    if not passed or self.abs is not None:
        return passed
    try:
        expected, value = float(self.expected), float(actual)
    except (TypeError, ValueError):  # complex, Decimal, non-numeric: pytest's own rules
        return passed
    rel = self.DEFAULT_RELATIVE_TOLERANCE if self.rel is None else self.rel
    if abs(value - expected) > rel * abs(expected):
        raise AssertionError(
            f"pytest.approx({expected!r}, rel={rel!r}) passed {value!r} only by its default "
            "abs=1e-12 (tests/approx_guard.py); state abs= explicitly"
        )
    return passed


def install() -> None:
    """Replace ``ApproxScalar.__eq__`` (every scalar, sequence, mapping and array compare)."""
    ApproxScalar.__eq__ = _stated_bar_eq
