"""The worst of several statuses is total over every status word (session 45 review).

``permeability --direction all`` combined the three directions' statuses with a lookup that
knew only ok / untrustworthy / not_converged: a ``blocked`` direction (a fibre bundle that
closes one axis) made ``max(..., key=dict.get)`` compare None with an int and raise TypeError,
a traceback instead of the exit-3 line. The truth here is the ordering itself
(:data:`psdesign.transport.effective.STATUS_ORDER`) and the exit rule of
:mod:`psdesign.cli.exit_status` (any status that is not ok is not trusted).
"""

from types import SimpleNamespace

import pytest

from psdesign.cli.exit_status import NOT_TRUSTED, status_code
from psdesign.cli.permeability import _combine
from psdesign.transport.effective import STATUS_ORDER, worst_status


@pytest.mark.parametrize(
    ("statuses", "worst"),
    [
        (["ok", "ok"], "ok"),
        (["ok", "untrustworthy"], "untrustworthy"),
        (["not_converged", "untrustworthy", "ok"], "not_converged"),
        (["ok", "blocked", "not_converged"], "blocked"),
        (["blocked", "extrapolated", "ok"], "extrapolated"),  # unknown word: worse than any known
        (["ok", None], None),  # a missing status is not ok either
        ([], "ok"),
    ],
)
def test_worst_status_is_total(statuses, worst):
    assert worst_status(statuses) == worst


def test_worst_status_follows_the_order():
    # every pair of known words: the later one in STATUS_ORDER wins, in either position
    for i, a in enumerate(STATUS_ORDER):
        for b in STATUS_ORDER[i:]:
            assert worst_status([a, b]) == b
            assert worst_status([b, a]) == b


def _result(direction: str, status: str) -> dict:
    return {
        "direction": direction,
        "status": status,
        "bc": "periodic",
        "converged": status != "not_converged",
        "flux_imbalance": 1e-9,
        "permeability_m2": 0.0 if status == "blocked" else 1e-11,
        "permeability_rel_error": None,
    }


@pytest.mark.parametrize("bad", ["blocked", "extrapolated"])
def test_combine_all_directions_with_a_blocked_one(bad):
    fields = SimpleNamespace(porosity=0.7, porosity_error=1e-3)
    results = [_result("x", "ok"), _result("y", "untrustworthy"), _result("z", bad)]
    out = _combine(results, "voxel", fields)
    assert out["status"] == bad
    assert out["permeability_m2"] == {
        "x": 1e-11,
        "y": 1e-11,
        "z": 1e-11 if bad != "blocked" else 0.0,
    }
    assert status_code(out["status"]) == NOT_TRUSTED
