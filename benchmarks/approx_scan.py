"""pytest plugin: find tolerance checks whose absolute tolerance decides or widens the stated bar.

``pytest.approx(x, rel=r)`` keeps its default ``abs=1e-12`` (and ``np.isclose`` / ``np.allclose``
their ``atol=1e-8``): on quantities of 1e-13 to 1e-6 (K in m^2, volumes, lengths in m) the stated
relative bar is silently widened. This plugin records, per call made from a file under ``tests/``:

- ``approx-widened`` / ``np.isclose-widened`` ...: the absolute part is larger than the relative
  part (the stated ``rel`` is not the bar), once per (line, test);
- ``approx`` / ``np.isclose`` ...: the check passed only because of the absolute part
  (``rel |expected| < |actual - expected| <= abs``): it fails at the stated bar.

Covered: pytest.approx (scalars, sequences, mappings, arrays: all via ``ApproxScalar.__eq__``),
``np.isclose``, ``np.allclose``, ``math.isclose`` with ``abs_tol``, and
``np.testing.assert_allclose`` with an explicit ``atol``. Outcomes are unchanged.

Usage (approx17, 2026-12-03)::

    APPROX_SCAN_OUT=/tmp/scan.jsonl PYTHONPATH=$PWD:$PWD/benchmarks NUMBA_NUM_THREADS=1 \
        python -m pytest -p approx_scan -q -n 2 tests
"""

from __future__ import annotations

import json
import math
import os
import sys

import numpy as np
import pytest
from _pytest import python_api as _pa

OUT = os.environ.get("APPROX_SCAN_OUT", "approx_scan.jsonl")
_state = {"test": None}
_guard = {"on": False}
_seen = set()


def _caller(depth_max: int = 12):
    """file:line of the first frame outside this plugin, pytest and numpy, if it is a test file."""
    f = sys._getframe(1)
    for _ in range(depth_max):
        if f is None:
            return None
        fn = f.f_code.co_filename
        if "approx_scan" in fn or "/_pytest/" in fn or "/numpy/" in fn:
            f = f.f_back
            continue
        if "/tests/" in fn:
            return f"{fn.split('/tests/', 1)[1]}:{f.f_lineno}"
        return None
    return None


def _write(rec):
    rec["test"] = _state["test"]
    with open(OUT, "a") as fh:
        fh.write(json.dumps(rec) + "\n")


_orig_eq = _pa.ApproxScalar.__eq__


def _eq(self, actual):
    res = _orig_eq(self, actual)
    try:
        if res and _as_scalar(actual) is not None and not _guard["on"]:
            a = _as_scalar(actual)
            e = (
                complex(self.expected)
                if isinstance(self.expected, complex)
                else float(self.expected)
            )
            d = abs(e - a)
            if d == 0:
                d = 0.0
            rel = self.rel if self.rel is not None else self.DEFAULT_RELATIVE_TOLERANCE
            absd = self.abs if self.abs is not None else self.DEFAULT_ABSOLUTE_TOLERANCE
            if self.rel is None and self.abs is not None:
                return res  # abs-only check: abs is the stated bar
            if absd > rel * abs(e) and self.abs is None:
                where = _caller()
                key = ("w", where, _state["test"])
                if where and key not in _seen:
                    _seen.add(key)
                    _write(
                        {
                            "kind": "approx-widened",
                            "where": where,
                            "expected": repr(self.expected),
                            "actual": repr(a),
                            "dev": float(d),
                            "rel": self.rel,
                            "rel_dev": float(d / abs(e)) if e != 0 else None,
                        }
                    )
            if d > rel * abs(e) and d <= absd:
                where = _caller()
                if where:
                    _write(
                        {
                            "kind": "approx",
                            "where": where,
                            "expected": repr(self.expected),
                            "actual": repr(a),
                            "dev": float(d),
                            "rel": self.rel,
                            "abs": self.abs,
                            "rel_dev": float(d / abs(e)) if e != 0 else None,
                        }
                    )
    except Exception as exc:  # never break a test
        _write({"kind": "scan_error", "err": repr(exc)})
    return res


def _as_scalar(x):
    try:
        if isinstance(x, (bool, np.bool_)):
            return None
        if isinstance(x, complex):
            return x
        return float(x)
    except Exception:
        return None


_pa.ApproxScalar.__eq__ = _eq

_orig_isclose = np.isclose
_orig_allclose = np.allclose


def _np_check(kind, a, b, rtol, atol, equal_nan, res_any):
    where = _caller()
    if not where:
        return
    try:
        a_ = np.asarray(a, dtype=complex if np.iscomplexobj(a) or np.iscomplexobj(b) else float)
        b_ = np.asarray(b, dtype=a_.dtype)
        d = np.abs(a_ - b_)
        relpart = rtol * np.abs(b_)
        decided = (d > relpart) & (d <= atol)
        widened = atol > relpart
        key = ("w", kind, where, _state["test"])
        if np.any(widened) and key not in _seen:
            _seen.add(key)
            _write(
                {
                    "kind": kind + "-widened",
                    "where": where,
                    "n_widened": int(np.sum(widened)),
                    "rtol": rtol,
                    "atol": atol,
                    "min_abs_expected": float(np.min(np.abs(b_))),
                }
            )
        if np.any(decided):
            idx = np.flatnonzero(
                np.broadcast_to(decided, np.broadcast_shapes(d.shape, decided.shape))
            )[:3]
            bb = np.broadcast_to(b_, d.shape).ravel()
            aa = np.broadcast_to(a_, d.shape).ravel()
            _write(
                {
                    "kind": kind,
                    "where": where,
                    "n_decided": int(decided.sum()),
                    "n": int(d.size),
                    "rtol": rtol,
                    "atol": atol,
                    "examples": [[repr(aa[i]), repr(bb[i])] for i in idx],
                    "max_dev_decided": float(np.max(d[decided])),
                }
            )
    except Exception as exc:
        _write({"kind": "scan_error", "err": repr(exc), "where": where})


def isclose(a, b, rtol=1e-05, atol=1e-08, equal_nan=False):
    res = _orig_isclose(a, b, rtol=rtol, atol=atol, equal_nan=equal_nan)
    if not _guard["on"]:
        _np_check("np.isclose", a, b, rtol, atol, equal_nan, res)
    return res


def allclose(a, b, rtol=1e-05, atol=1e-08, equal_nan=False):
    _guard["on"] = True
    try:
        res = _orig_allclose(a, b, rtol=rtol, atol=atol, equal_nan=equal_nan)
    finally:
        _guard["on"] = False
    _np_check("np.allclose", a, b, rtol, atol, equal_nan, res)
    return res


np.isclose = isclose
np.allclose = allclose

_orig_misclose = math.isclose


def misclose(a, b, *, rel_tol=1e-09, abs_tol=0.0):
    res = _orig_misclose(a, b, rel_tol=rel_tol, abs_tol=abs_tol)
    if res and abs_tol > 0:
        d = abs(a - b)
        if d > rel_tol * max(abs(a), abs(b)) and d <= abs_tol:
            where = _caller()
            if where:
                _write(
                    {
                        "kind": "math.isclose",
                        "where": where,
                        "a": repr(a),
                        "b": repr(b),
                        "rel_tol": rel_tol,
                        "abs_tol": abs_tol,
                        "dev": d,
                    }
                )
    return res


math.isclose = misclose


@pytest.hookimpl(wrapper=True)
def pytest_runtest_call(item):
    _state["test"] = item.nodeid
    try:
        return (yield)
    finally:
        _state["test"] = None


_orig_aac = np.testing.assert_allclose


def assert_allclose(
    actual, desired, rtol=1e-07, atol=0, equal_nan=True, err_msg="", verbose=True, **kw
):
    _orig_aac(
        actual,
        desired,
        rtol=rtol,
        atol=atol,
        equal_nan=equal_nan,
        err_msg=err_msg,
        verbose=verbose,
        **kw,
    )
    if atol and atol > 0:
        _np_check("assert_allclose(atol)", actual, desired, rtol, atol, equal_nan, True)


np.testing.assert_allclose = assert_allclose
