"""Design targets: ``"k_z_m2=8e-12"`` (within a tolerance), ``"diffusivity_z>=0.5"``, ``"x<=3"``."""

from __future__ import annotations

import math
import numbers
import re
from dataclasses import dataclass

from psdesign.analysis.ranges import RANGES
from psdesign.errors import StudyError, short

#: Most design points of one optimization, and per round (``--budget``, ``--batch``; here, in
#: the light module of ``study optimize``, so the command line checks them without importing
#: the optimizer).
MAX_BUDGET = 10_000
MAX_BATCH = 1000
#: Largest seed of a search (``--seed``): numpy / scipy take 32-bit seeds, and Sobol's
#: bootstrap uses ``seed + 1``.
MAX_SEED = 2**32 - 2
#: The comparisons a target may make.
TARGET_OPS = ("=", ">=", "<=")

_TARGET = re.compile(
    r"^\s*([A-Za-z0-9_.\-]+)\s*(>=|<=|=)\s*([^\s]+?)\s*(?:\+-\s*(\S*?)\s*(%?))?\s*$"
)
_PERCENT = "tolerance must be a percentage like +-5%"


def target_columns(outputs: list[str]) -> list[str]:
    """The result columns a study with these ``[study] outputs`` writes that a target may name
    (:func:`psdesign.study.case.run_case`; porosity is always written).

    >>> target_columns(["porosity", "k_z", "tortuosity_x"])
    ['porosity', 'k_z_m2', 'diffusivity_x', 'tortuosity_x']
    """
    cols = ["porosity"]
    for o in outputs:
        if o in ("k_x", "k_y", "k_z"):
            cols.append(f"{o}_m2")
        elif o == "k_tensor":
            cols += [f"k_{d}_m2" for d in "xyz"] + [f"k_{a}{b}_m2" for a in "xyz" for b in "xyz"]
        elif o[:-1] in ("diffusivity_", "tortuosity_"):  # the case writes both
            cols += [f"diffusivity_{o[-1]}", f"tortuosity_{o[-1]}"]
        elif o.startswith("pore_d"):  # the case writes the three
            cols += ["pore_d10_m", "pore_d50_m", "pore_d90_m"]
        elif o != "fields":
            cols.append(o)
    return list(dict.fromkeys(cols))


def check_targets(targets: list[Target], outputs: list[str], what: str = "targets") -> None:
    """Refuse (one :class:`~psdesign.errors.StudyError` line, a ``ValueError``, naming
    ``what``) no target, something that is not a :class:`Target`, a target on a column this
    study does not write, or one that can never be met (:meth:`Target.check`): before any
    case.

    ``what`` names the targets: the Python keyword (``"targets"`` of
    :func:`psdesign.analysis.optimize.optimize_study`, the default), or the command line's
    ``"--target"``.
    """
    from psdesign.schema.errors import did_you_mean

    if isinstance(targets, Target | str) or not isinstance(targets, list | tuple) or not targets:
        # a str was read one character at a time (AttributeError); [] ran a search for nothing
        raise StudyError(f"{what}: must be a non-empty list of Target, got {short(targets)}")
    cols = target_columns(outputs)
    for t in targets:
        if not isinstance(t, Target):
            raise StudyError(
                f"{what}: each must be a psdesign.analysis.targets.Target (Target.parse("
                f"'k_z_m2=8e-12+-5%')), got {type(t).__name__} {short(t)}"
            )
        if t.output not in cols:
            raise StudyError(
                f"{what}: {t.output!r} is not an output of this study"
                f"{did_you_mean(t.output, cols)} (outputs: {', '.join(cols)})"
            )
        t.check(what)
    for i, a in enumerate(targets):  # targets on one output that no value meets together
        for b in targets[i + 1 :]:
            if a.output == b.output:
                (lo_a, hi_a), (lo_b, hi_b) = a.bounds(), b.bounds()
                if max(lo_a, lo_b) > min(hi_a, hi_b):
                    raise StudyError(
                        f"{what}: {a} and {b} can never both be met (no value of "
                        f"{a.output} meets both); give targets on one output that overlap"
                    )


#: Relative tolerance of an equality target when none is given.
DEFAULT_TOLERANCE = 0.05


@dataclass(frozen=True)
class Target:
    """One target on a study output.

    Attributes
    ----------
    output : str
        A results column, e.g. ``k_z_m2``.
    op : {"=", ">=", "<="}
    value : float
    tolerance : float
        Relative half-width for ``=`` (``|y - value| <= tolerance * |value|``).
    """

    output: str
    op: str
    value: float
    tolerance: float = DEFAULT_TOLERANCE

    @classmethod
    def parse(cls, text: str, what: str = "targets") -> Target:
        """Parse ``OUTPUT=VALUE[+-P%]``, ``OUTPUT>=VALUE`` or ``OUTPUT<=VALUE``; refusals are
        one :class:`~psdesign.errors.StudyError` line naming ``what``: the keyword ``targets``
        of :func:`psdesign.analysis.optimize.optimize_study` (the default), or the command
        line's ``"--target"`` (named from Python too until session 47; ``text=3`` was a
        ``TypeError``).

        >>> Target.parse("k_z_m2=8e-12+-3%")
        Target(output='k_z_m2', op='=', value=8e-12, tolerance=0.03)
        >>> Target.parse("k_z_m2=-1e-12", "--target")  # doctest: +ELLIPSIS
        Traceback (most recent call last):
        ...
        psdesign.errors.StudyError: --target: k_z_m2=-1e-12 can never be met: ...
        """
        m = _TARGET.match(text) if isinstance(text, str) else None
        if not m:
            raise StudyError(
                f"{what}: expected OUTPUT=VALUE[+-P%], OUTPUT>=VALUE or OUTPUT<=VALUE, "
                f"got {short(text)}"
            )
        name, op, val, tol, pct = m.groups()
        try:
            value = float(val)
        except ValueError:
            raise StudyError(f"{what}: {name} value must be a number, got {val!r}") from None
        if tol is None:
            tolerance = DEFAULT_TOLERANCE
        else:
            try:
                tolerance = float(tol) / 100.0
            except ValueError:
                tolerance = math.nan
            if not pct or not math.isfinite(tolerance):
                raise StudyError(f"{what}: {name} {_PERCENT}, got '+-{tol}{pct}'")
        target = cls(name, op, value, tolerance)
        target.check(what)
        return target

    def check(self, what: str = "targets") -> None:
        """Refuse (one :class:`~psdesign.errors.StudyError` line naming ``what``) a target that
        can never be met or has no meaning: an op other than ``=``, ``>=``, ``<=``, a value
        that is not a finite number, an ``=`` target's tolerance outside (0, 1) or of the
        value 0 (no relative band), a value outside the output's physical range
        (:data:`RANGES`).

        A :class:`Target` built directly (not by :meth:`parse`) was used unchecked: ``op="~"``
        was met by no value, a NaN value or a negative tolerance ran the whole budget
        (session 47).

        >>> Target("porosity", "=", 0.8, tolerance=-1.0).check("targets")
        Traceback (most recent call last):
        ...
        psdesign.errors.StudyError: targets: porosity tolerance must be in (0, 100) %, got -100%
        """
        name, op, value, tol = self.output, self.op, self.value, self.tolerance
        if op not in TARGET_OPS:
            raise StudyError(
                f"{what}: {name} op must be one of {', '.join(TARGET_OPS)}, got {op!r}"
            )
        for key, v in (("value", value), ("tolerance", tol)):
            if isinstance(v, bool) or not isinstance(v, numbers.Real) or not math.isfinite(v):
                raise StudyError(f"{what}: {name} {key} must be a finite number, got {short(v)}")
        if op == "=" and not 0 < tol < 1:
            raise StudyError(f"{what}: {name} tolerance must be in (0, 100) %, got {100 * tol:g}%")
        if op == "=" and value == 0:
            raise StudyError(f"{what}: {name}=0 has no relative tolerance; use <= or >=")
        if self.output in RANGES:
            lo, lo_open, hi, hi_open, why = RANGES[self.output]
            below = value <= lo if lo_open else value < lo
            above = value >= hi if hi_open else value > hi
            if below or above:
                raise StudyError(f"{what}: {name}{op}{value:g} can never be met: {why}")

    def bounds(self) -> tuple[float, float]:
        """The values that meet the target, as ``(low, high)``."""
        if self.op == ">=":
            return self.value, math.inf
        if self.op == "<=":
            return -math.inf, self.value
        half = self.tolerance * abs(self.value)
        return self.value - half, self.value + half

    def within_bar(
        self, y: float, rel_error: float | None, one_sided: bool = False, rel_below: float = 0.0
    ) -> bool:
        """Whether the error bar of ``y`` (:func:`bar_range`) overlaps the values that meet
        the target (the measurement cannot tell met from missed)."""
        bar = bar_range(y, rel_error, one_sided, rel_below)
        if bar is None:
            return False
        lo, hi = self.bounds()
        return bar[0] <= hi and lo <= bar[1]

    def bar_inside(
        self, y: float, rel_error: float | None, one_sided: bool = False, rel_below: float = 0.0
    ) -> bool:
        """Whether the whole error bar of ``y`` (:func:`bar_range`) meets the target."""
        bar = bar_range(y, rel_error, one_sided, rel_below)
        if bar is None:
            return False
        lo, hi = self.bounds()
        return lo <= bar[0] and bar[1] <= hi

    def met(self, y: float) -> bool:
        """Whether a measured value meets the target."""
        if not math.isfinite(y):
            return False
        if self.op == ">=":
            return y >= self.value
        if self.op == "<=":
            return y <= self.value
        return abs(y - self.value) <= self.tolerance * abs(self.value)

    def miss(self, y: float) -> float:
        """Relative distance from meeting the target (0 when met): :meth:`margin` clipped."""
        return max(0.0, self.margin(y))

    def margin(self, y: float) -> float:
        """The unclipped :meth:`miss`: relative distance past the edge of the met values,
        negative inside (how far from missing), so that the margins of targets of different
        kinds and bands compare (the nearest a miss is the largest): a tie-break between
        values that :meth:`miss` scores alike (every met one 0). ``=``: ``|y - value| /
        |value| - tolerance``; ``<=``: ``(y - value) / |value|``; ``>=``: the reverse.

        >>> Target("k", "=", 2.0, tolerance=0.1).margin(2.5), Target("k", ">=", 2.0).margin(3.0)
        (0.15, -0.5)
        """
        if not math.isfinite(y):
            return math.inf
        scale = abs(self.value) or 1.0
        if self.op == ">=":
            return (self.value - y) / scale
        if self.op == "<=":
            return (y - self.value) / scale
        return abs(y - self.value) / scale - self.tolerance

    def __str__(self) -> str:
        if self.op == "=":
            return f"{self.output}={self.value:g}+-{100 * self.tolerance:g}%"
        return f"{self.output}{self.op}{self.value:g}"


def bar_range(y: float, rel_error: float | None, one_sided: bool = False, rel_below: float = 0.0):
    """The values the error bar of a measured ``y`` spans, ``(low, high)``: ``y +- rel_error
    |y|``, or for a one-sided bar (:data:`~psdesign.analysis.columns.UPPER_BARS`: a pore
    diameter, whose scan measures low) ``y - rel_below |y|`` to ``y + rel_error |y|``, its
    lower side ``rel_below`` 0 where every face of the box repeats and the walled scan's
    distance (:data:`~psdesign.analysis.columns.LOWER_BAR_COLUMN`) where one does not
    (session 54); None without a bar.

    >>> bar_range(2.0, 0.1), bar_range(2.0, 0.1, one_sided=True), bar_range(2.0, None)
    ((1.8, 2.2), (2.0, 2.2), None)
    >>> bar_range(2.0, 0.1, one_sided=True, rel_below=0.15)
    (1.7, 2.2)
    """
    if not math.isfinite(y) or rel_error is None or not math.isfinite(rel_error):
        return None
    half = abs(rel_error * y)
    below = abs(rel_below * y) if math.isfinite(rel_below) else 0.0
    return (y - below if one_sided else y - half), y + half


def target_report(t: Target, best: dict) -> dict:
    """One target against the chosen case ``best`` (a row of a results table): the row of the
    ``study optimize`` outcome's ``targets`` (``--json``, ``optimize.json``), with the
    measured value, its own error bar and status
    (:func:`psdesign.analysis.columns.error_bar`) and the verdicts :func:`measured_text` words.

    >>> r = target_report(Target.parse("k_z_m2>=1e-11"), {"k_z_m2": 1.05e-11,
    ...                   "k_z_rel_error": 0.1, "k_z_status": "ok"})
    >>> measured_text(r)
    'measured 1.05e-11 +- 10 % [ok] (met; the error bar reaches outside the target)'
    """
    # pandas: not on the CLI's start path
    from psdesign.analysis.columns import UPPER_BARS, error_bar, rel_error_below

    try:
        y = float(best.get(t.output, float("nan")))
    except (TypeError, ValueError):
        y = float("nan")
    rel, status = error_bar(best, t.output)
    # a pore diameter's bar reaches upward, and downward only where a face does not repeat
    one_sided = t.output in UPPER_BARS
    below = rel_error_below(best, t.output)
    return {
        "target": str(t),
        "output": t.output,
        # the target's numbers as given: its text rounds them to 6 digits (session 49); a
        # tolerance only where it counts, an = target
        "target_value": t.value,
        "target_tolerance": t.tolerance if t.op == "=" else None,
        "measured": y if y == y else None,
        "rel_error": rel,
        # a pore diameter's lower side (0 where every face repeats; session 54 review)
        "rel_error_below": below,
        "status": status,
        "met": t.met(y),
        # the bar overlaps the target; a pore diameter's reaches upward (session 48) and
        # down by its lower side
        "target_within_error_bar": t.within_bar(y, rel, one_sided, below),
        "error_bar_inside_target": t.bar_inside(y, rel, one_sided, below),
    }


def no_closest_case(rows: list[dict]) -> str:
    """Why the outcome's design point is no closest one, or ``""``: the chosen case lacks a
    measured value of some target (a :func:`target_report` row with ``measured`` None) only
    when every case does (its miss is infinite, so every case's is: the search picks the least
    miss), and the point shown is then the first one run (session 43 review).

    >>> no_closest_case([{"measured": None}, {"measured": 0.8}])
    "no case has a trusted value of every target's output: the first design point run"
    >>> no_closest_case([{"measured": 1e-11}])
    ''
    """
    if any(r.get("measured") is None for r in rows):
        return "no case has a trusted value of every target's output: the first design point run"
    return ""


#: The keys of a :func:`target_report` row that :func:`measured_text` reads (``output`` picks
#: the bar's sides, ``target`` re-reads a one-sided bar's verdicts: rows have held both since
#: session 43).
REPORT_KEYS = frozenset(
    (
        "target",
        "output",
        "measured",
        "rel_error",
        "status",
        "met",
        "target_within_error_bar",
        "error_bar_inside_target",
    )
)


def row_target(r: dict) -> Target:
    """The :class:`Target` of a :func:`target_report` row: its text's output and comparison
    with the numbers stored beside it (``target_value``, and ``target_tolerance`` of an ``=``
    target, None otherwise; since session 49); a row written before has only the text,
    whose numbers are rounded to 6 digits.

    >>> row_target({"target": "pore_d50_m<=2e-05", "target_value": 2.0000004e-05}).value
    2.0000004e-05
    >>> row_target({"target": "pore_d50_m<=2e-05"}).value
    2e-05
    """
    t = Target.parse(r["target"])
    value, tolerance = r.get("target_value"), r.get("target_tolerance")
    if value is None:
        return t
    tolerance = t.tolerance if tolerance is None else tolerance  # None: a >= or <= target
    exact = Target(t.output, t.op, float(value), float(tolerance))
    exact.check("target")
    return exact


def _bar_verdicts(r: dict, one_sided: bool) -> tuple[bool, bool]:
    """``(target_within_error_bar, error_bar_inside_target)`` of a :func:`target_report` row:
    for a one-sided bar recomputed from the row's target (:func:`row_target`: its stored
    numbers, not its 6-digit text, since session 49), value and bar, since an
    ``optimize.json`` written before session 48 stored the two-sided bar's verdicts (d50 =
    21 um +3 um "could not tell" ``<= 20 um``); the stored ones otherwise."""
    stored = bool(r["target_within_error_bar"]), bool(r["error_bar_inside_target"])
    if not one_sided or r["rel_error"] is None:
        return stored
    try:
        t = row_target(r)
        y, rel, below = float(r["measured"]), float(r["rel_error"]), _rel_below(r)
    except (StudyError, TypeError, ValueError):  # an edited row: its own words stand
        return stored
    return t.within_bar(y, rel, True, below), t.bar_inside(y, rel, True, below)


def _rel_below(r: dict) -> float:
    """The lower side of a :func:`target_report` row's one-sided bar: ``rel_error_below``, 0
    in a row written before session 54 or where it is None/NaN."""
    try:  # an edited optimize.json ("n/a"): no lower side, not a traceback in study report
        v = float(r.get("rel_error_below") or 0.0)
    except (TypeError, ValueError):
        return 0.0
    return v if math.isfinite(v) else 0.0


def measured_text(r: dict) -> str:
    """One target's line of the ``study optimize`` outcome (a :func:`target_report` row):
    ``measured 1.077e-11 +- 11.8 % [ok] (missed; the target lies within ...)``."""
    from psdesign.analysis.columns import UPPER_BARS

    if r["measured"] is None:
        return f"no measured value [{r['status']}] (missed)"
    one_sided = r.get("output") in UPPER_BARS
    bar = " (no error estimate)"
    if r["rel_error"] is not None:  # a pore diameter's: +above/-below (sessions 48, 54)
        bar = " " + _bar_text(r["rel_error"], one_sided, _rel_below(r))
    within, inside = _bar_verdicts(r, one_sided)
    verdict = "met" if r["met"] else "missed"
    if within and not r["met"]:
        verdict += "; the target lies within the measurement's error bar"
    elif r["met"] and r["rel_error"] is not None and not inside:
        verdict += _wider_than_band(r, one_sided) or "; the error bar reaches outside the target"
    return f"measured {r['measured']:.4g}{bar} [{r['status']}] ({verdict})"


def _wider_than_band(r: dict, one_sided: bool = False) -> str:
    """Of a met ``=`` target's row: ``"; its error bar (+- 2 %) is wider than the target's
    band (+- 1 %)..."`` when the bar's span (:func:`bar_range`; a one-sided bar's is its
    half-width) exceeds the band's (no value, however close, is then confirmed inside it:
    session 53, a +-1 % K target MET on a +-2 % K), else ``""``. Until the review of session
    53 the half-widths were compared, so a pore diameter's +1.5 %/-0 bar (spanning 1.5 %)
    read wider than a +-1 % band (spanning 2 %).

    >>> _wider_than_band({"target": "k=3e-11+-1%", "target_value": 3e-11,
    ...                   "target_tolerance": 0.01, "measured": 2.995e-11, "rel_error": 0.02})[:65]
    "; its error bar (+- 2 %) is wider than the target's band (+- 1 %)"
    """
    try:
        t = row_target(r)
        below = _rel_below(r)
        bar = bar_range(float(r["measured"]), float(r["rel_error"]), one_sided, below)
    except (StudyError, TypeError, ValueError):  # an edited row: the general words
        return ""
    lo, hi = t.bounds()
    if t.op != "=" or bar is None or not bar[1] - bar[0] > hi - lo:
        return ""
    return (
        f"; its error bar ({_bar_text(float(r['rel_error']), one_sided, below)}) is wider than the "
        f"target's band (+- {100 * t.tolerance:.3g} %): it cannot tell met from missed"
    )


def _bar_text(rel_error: float, one_sided: bool, rel_below: float = 0.0) -> str:
    """A relative error bar as printed: ``+- 2 %``, one-sided ``+1.5 %/-0``, or with a lower
    side (a pore diameter where a face does not repeat) ``+10 %/-15 %``.

    >>> _bar_text(0.02, False), _bar_text(0.015, True), _bar_text(0.1, True, 0.15)
    ('+- 2 %', '+1.5 %/-0', '+10 %/-15 %')
    """
    pct = f"{100 * rel_error:.3g} %"
    if not one_sided:
        return f"+- {pct}"
    return f"+{pct}/-{100 * rel_below:.3g} %" if rel_below > 0 else f"+{pct}/-0"
