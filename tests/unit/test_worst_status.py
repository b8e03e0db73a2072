"""The worst of several statuses is total over every status word (session 45 review).

``permeability --direction all`` combined the three directions' statuses with a lookup that
knew only ok / untrustworthy / not_converged: a ``blocked`` direction (a fibre bundle that
closes one axis) made ``max(..., key=dict.get)`` compare None with an int and raise TypeError,
a traceback instead of the exit-3 line. The truth here is the ordering itself
(:data:`psdesign.transport.effective.STATUS_ORDER`) and the exit rule of
:mod:`psdesign.cli.exit_status` (any status that is not ok is not trusted).
"""

import itertools
from types import SimpleNamespace

import pytest

from psdesign.cli.exit_status import NOT_TRUSTED, OK, status_code
from psdesign.cli.permeability import _combine
from psdesign.status import TRUSTED
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


def test_the_worst_status_is_trusted_exactly_when_the_exit_is_0():
    """The order and the exit rule are one definition (session 46): a force-field search's
    trusted ``converged`` and ``at_bound`` (:data:`psdesign.status.TRUSTED`) ranked
    below ``blocked``, as unknown words, so ``worst_status(["converged", "untrustworthy"])``
    was ``converged``, a trusted word for a list the exit rule calls not trusted (3). Over
    every pair of words, in either order, the worst is trusted exactly when the exit is 0.
    Fails on main's effective.py."""
    assert STATUS_ORDER[0] in TRUSTED and not set(STATUS_ORDER[1:]) & set(TRUSTED)
    words = [*TRUSTED, *STATUS_ORDER, "extrapolated", None]
    for pair in itertools.product(words, repeat=2):
        assert (worst_status(list(pair)) in TRUSTED) == (status_code(*pair) == OK), pair
    assert worst_status(["converged", "untrustworthy"]) == "untrustworthy"
    assert worst_status(["at_bound", "blocked", "converged"]) == "blocked"


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


@pytest.mark.parametrize(
    "word", ["ok", "converged", "at_bound", "not_applicable", "untrustworthy", "extrapolated"]
)
def test_a_predictions_flag_is_shouted_exactly_when_the_exit_is_3(
    word, tmp_path, monkeypatch, capsys
):
    """Session 52: ``study predict`` printed ``[ok]`` for ``ok`` and ``(WORD)``, the form of a
    value not to trust, for every other word, while its exit follows the one rule
    (:func:`psdesign.cli.exit_status.status_code`: ``converged``, ``at_bound`` and
    ``not_applicable`` exit 0). Truth: the exit rule; the word itself is printed either way.
    The surrogate is stubbed (the statuses a fit gives are ok / untrustworthy / extrapolated;
    the rule must hold for every word a row can carry)."""
    import psdesign.analysis.columns as columns
    import psdesign.analysis.surrogate as surrogate
    from psdesign.cli import study_analysis
    from psdesign.cli.main import main

    row = {"mean": 1.5e-11, "std": 1e-12, "gp_std": 1e-12, "error_from": "GP std",
           "holdout_rel_error": None, "cv_rel_error": 0.05, "cv_level_rel_error": None,
           "cv_between_rel_error": None, "status": word, "outside": []}  # fmt: skip
    monkeypatch.setattr(surrogate, "load_study_surrogates", lambda out: {"k_z_m2": None})
    monkeypatch.setattr(columns, "study_table", lambda out: {"parameters": {}})
    monkeypatch.setattr(study_analysis, "_predict_one", lambda *a: (dict(row), ""))
    code = main(["study", "predict", str(tmp_path), "--at", "generator.porosity=0.8"])
    line = capsys.readouterr().out.strip()
    assert code == status_code(word) == (OK if word in (*TRUSTED, "not_applicable") else 3)
    shouted = f"({word.upper()})" in line
    assert shouted == (code == NOT_TRUSTED), line
    assert shouted or line.endswith(f"[{word}]"), line
