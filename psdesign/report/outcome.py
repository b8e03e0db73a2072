"""The report's decision section of a ``study optimize`` folder: did a design meet the targets,
which one, each target's measured value with its error bar and status, and the search's rounds
(from ``OUT/optimize.json``, the outcome the command keeps).

Until session 43 the report of an optimize folder showed the cases alone: a reader could not
tell from it what the targets were, whether they were met, or which design point won.
"""

from __future__ import annotations

import html
import math
from pathlib import Path

from psdesign.analysis.columns import case_warnings, is_design_parameter
from psdesign.analysis.optimize import OPTIMIZE_FILE, miss_words
from psdesign.analysis.targets import REPORT_KEYS, measured_text, no_closest_case
from psdesign.report.units import parameter_unit


def _esc(x) -> str:
    return html.escape("" if x is None else str(x))


def read_outcome(out: Path) -> dict | None:
    """The ``study optimize`` outcome of a study folder, or ``None``: no ``optimize.json``, or
    one psdesign did not write (the folder's marker does not list it: a user's own file of
    that name is not read as the search's verdict)."""
    from psdesign.io.outputs import read_marker
    from psdesign.study.readback import read_json_object

    path = Path(out) / OPTIMIZE_FILE
    marker = read_marker(Path(out)) or {}
    if not path.is_file() or OPTIMIZE_FILE not in marker.get("files", []):
        return None
    doc = read_json_object(path)  # not JSON, or not an object: one line naming the file
    rows = doc.get("targets")
    if (
        not {"met", "message", "targets", "best"} <= set(doc)
        or not isinstance(rows, list)
        or not all(isinstance(r, dict) and REPORT_KEYS <= set(r) for r in rows)
    ):  # cut short, edited, or another version's: said in one line, not a KeyError
        raise ValueError(f"{OPTIMIZE_FILE} is not the outcome `study optimize` writes")
    return doc


def stale_reason(out: Path, doc: dict) -> str:
    """Why ``doc`` (the folder's ``optimize.json``) is not the outcome of the design the
    folder now holds, or ``""``. ``optimize.json`` is written when a search ends; a later
    ``study optimize`` (other targets, another ``--seed``) that was interrupted or failed, or
    a ``study run`` of another design into the folder, rewrites ``study.json`` and the tables
    but not it, so its verdict (e.g. MET) would stand over cases it never saw: the search's
    last design had ``n_points`` x seeds cases and held its chosen case (session 43 review).
    """
    from psdesign.study.readback import design_cases, read_json_object

    path = Path(out) / "study.json"
    if not path.is_file():
        return ""
    design = read_json_object(path)
    cases = design_cases(design, path)
    seeds = (design.get("study") or {}).get("seeds") or [None]
    n, best = doc.get("n_points"), (doc.get("best") or {}).get("case_id")
    if best and best not in {c.get("case_id") for c in cases}:
        return f"its chosen case {best} is not in the folder's design"
    if isinstance(n, int) and len(cases) != n * len(seeds):
        seen = f"{n} design point(s) x {len(seeds)} seed(s)"
        return f"it saw {seen}, the design now has {len(cases)} case(s)"
    return ""


def _design_point(best: dict) -> str:
    """The chosen case's design parameters (with their units), seed and id, as table rows."""
    rows = []
    for k, v in best.items():
        if not is_design_parameter(k):
            continue
        unit = parameter_unit(k)
        text = f"{v:.4g}" if isinstance(v, int | float) else str(v)
        text += f" {unit}" if unit and unit != "-" else ""
        rows.append(f"<tr><th>{_esc(k)}</th><td>{_esc(text)}</td></tr>")
    seed, n = best.get("seed"), best.get("replicates")
    if seed is not None:
        which = f"its worst of {n} seeds" if isinstance(n, int) and n > 1 else "its only seed"
        rows.append(f"<tr><th>seed</th><td>{_esc(seed)} ({which})</td></tr>")
    if best.get("case_id"):
        rows.append(f"<tr><th>case</th><td>{_esc(best['case_id'])}</td></tr>")
    # what the solve said about this K (a periodic bc on a non-periodic RVE, ...)
    for k, v in case_warnings(best).items():
        wrap = ' style="white-space:normal;max-width:60em"'  # a sentence, not a number
        rows.append(f"<tr><th>{_esc(k)}</th><td{wrap}>{_esc(v)}</td></tr>")
    return "".join(rows)


def _history(history: list, n_targets: int) -> str:
    """The rounds as a table; a round whose cases hold no trusted value of a target's output
    has no closest miss (``optimize.json`` keeps it as ``"inf"``): "no trusted value". The
    miss's header says what the NOT MET line says of it
    (:func:`psdesign.analysis.optimize.miss_words`: to the band's edge, over the target value,
    summed over the ``n_targets``)."""
    before, after = miss_words(n_targets)
    rows = []
    for h in history or []:
        miss = h.get("best_miss")
        finite = isinstance(miss, int | float) and math.isfinite(miss)
        miss = f"{miss:.3g}" if finite else "no trusted value"
        rows.append(
            f"<tr><td>{_esc(h.get('round'))}</td><td>{_esc(h.get('n_points'))}</td>"
            f"<td>{_esc(miss)}</td></tr>"
        )
    miss = _esc(f"closest case {before} ... {after}")
    head = f"<tr><th>round</th><th>design points run</th><th>{miss}</th></tr>"
    return f'<table class="meta">{head}{"".join(rows)}</table>'


def missed_target_alert(out: Path) -> str:
    """The red box's line when the folder's ``study optimize`` outcome (for the design it now
    holds: not :func:`stale_reason`) is NOT MET, or ``""``; a file :func:`read_outcome` cannot
    read is its section's own note. Review s52: the report's headline was the red NOT MET box
    while ``study report`` exited 0 (``study optimize`` exited 3)."""
    try:
        doc = read_outcome(out)
    except ValueError:
        return ""
    if doc is None or doc["met"] or stale_reason(out, doc):
        return ""
    targets = ", ".join(str(t.get("target")) for t in doc["targets"])
    return f"the design decision (study optimize) is NOT MET for {targets}"


def optimize_section(out: Path) -> str:
    """The ``<h2>`` section of the search's outcome, or ``""`` when the folder has none."""
    doc = read_outcome(out)
    if doc is None:
        return ""
    stale = stale_reason(out, doc)
    if stale:
        was = "MET" if doc["met"] else "NOT MET"
        targets = ", ".join(str(t.get("target")) for t in doc["targets"])
        return (
            "<h2>Design decision (study optimize)</h2>"
            # a note, not a red box: the folder's own results are not in question, so
            # study report exits 0 on it (review F, session 52: red box beside exit 0)
            f'<p class="note" id="psd-optimize"><b>NO DECISION:</b> {OPTIMIZE_FILE} holds '
            f"the outcome of an earlier search ({_esc(was)} for {_esc(targets)}), not of this "
            f"folder's design: {_esc(stale)} (a later <code>study optimize</code> did not "
            "finish, or another design ran here). Run <code>study optimize</code> again to "
            "finish the search.</p>"
        )
    met = bool(doc["met"])
    verdict = "MET" if met else "NOT MET"
    box = "note" if met else "alert"
    rows = "".join(
        f"<tr><th>{_esc(t.get('target'))}</th><td>{_esc(measured_text(t))}</td></tr>"
        for t in doc["targets"]
    )
    point_note = no_closest_case(doc["targets"])
    point_note = f" ({point_note})" if point_note else ""
    return (
        "<h2>Design decision (study optimize)</h2>"
        f'<p class="{box}" id="psd-optimize"><b>{verdict}:</b> {_esc(doc["message"])}</p>'
        '<p class="note">Each target against the chosen case, with the case\'s own error bar '
        "and status (from optimize.json, the last finished <code>study optimize</code> in this "
        "folder; a design point is met only when every seed's case meets every target, and "
        "the case shown is its worst seed).</p>"
        f'<table class="meta">{rows}</table>'
        f"<h3>Design point{_esc(point_note)}</h3>"
        f'<table class="meta">{_design_point(doc["best"])}</table>'
        f"<h3>Search rounds</h3>{_history(doc.get('history', []), len(doc['targets']))}"
    )
