"""Section of ``docs/validation.md``: the sub-voxel walls' alignment floor at every resolution of
the convergence table (``benchmarks/validation_tables.py --only alignment``).

K of a voxel solve depends on where the wall cuts the cells (``benchmarks/RESULTS.md``, "Issue 12
item 3, alignment scatter"): solving each case of ``voxel_convergence.CONVERGENCE`` with the
cylinders shifted by :data:`OFFSETS` (fractions of a voxel) samples that dependence. Per
resolution the section gives the error at the unshifted alignment, the mean over the offsets and
their standard deviation ``s(n)``, the resolution's own error floor. Two counts complement the
single-alignment 'monotone' of the convergence table:

* *offset mean monotone*: ``|mean error|`` falls at every refinement (the alignment-averaged K
  converges from one side);
* *within the floor* (:func:`within_floor`): every refinement step lowers ``|error|`` or raises
  it by at most ``FLOOR_SIGMAS * sqrt(s_a^2 + s_b^2)``, i.e. the rise is not resolved against the
  scatter of two independent alignments.

Solved directly on the exact distance field (``benchmarks/voxel_alignment.py``: periodic,
sub-voxel walls, a slab 4 voxels thick, tol 1e-8); at the unshifted alignment it gives the
product route's K of the convergence table (same distance field, same operator).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

from arrays import L
from voxel_alignment import run_case
from voxel_convergence import CONVERGENCE

from psdesign.flow.error import FLOOR, resolution_floor

#: Sub-voxel shifts (x, y) of the cylinders, voxels; the first is the table's own alignment. The
#: other seven are spread over the voxel (hand-picked, fixed: no random draw to seed).
OFFSETS = [
    (0.0, 0.0),
    (0.25, 0.1),
    (0.5, 0.37),
    (0.13, 0.61),
    (0.71, 0.29),
    (0.4, 0.83),
    (0.9, 0.55),
    (0.33, 0.33),
]

#: Voxels per spacing from which a row counts as resolved (``validation_tables.RESOLVED_VOXELS``).
RESOLVED = 40

#: Standard deviations of the difference of two alignments a rise may reach and still count as
#: unresolved (2: a 95 % band for a normal scatter).
FLOOR_SIGMAS = 2.0


def within_floor(errs: Sequence[float], sds: Sequence[float], sigmas: float = FLOOR_SIGMAS) -> bool:
    """True if ``|errs|`` never rises between consecutive resolutions by more than ``sigmas``
    standard deviations of the difference of two alignments (``sqrt(sd_a^2 + sd_b^2)``).

    Parameters
    ----------
    errs : sequence of float
        True relative errors, coarsest resolution first.
    sds : sequence of float
        Standard deviation of the true error over the sub-voxel offsets at each resolution.
    sigmas : float
        Band width in standard deviations.
    """
    for a, b, sa, sb in zip(errs, errs[1:], sds, sds[1:], strict=False):
        if abs(b) - abs(a) > sigmas * math.hypot(sa, sb):
            return False
    return True


def _stats(errs: list[float]) -> tuple[float, float]:
    mean = sum(errs) / len(errs)
    var = sum((e - mean) ** 2 for e in errs) / (len(errs) - 1)
    return mean, math.sqrt(var)


def _case_rows(cached: Callable, not_run: str, kind: str, flow: str, phi: float, n: int):
    """True errors at the offsets (None if a row was not run) and the iteration counts."""
    errs, its = [], []
    for dx, dy in OFFSETS:
        key = (
            f"voxel periodic alignment {kind} {flow}, phi {phi:g}, {n} voxels/L, "
            f"offset {dx:g},{dy:g}"
        )
        got = cached(
            key,
            lambda kind=kind, flow=flow, phi=phi, tok=f"{n}@{dx:g},{dy:g}": run_case(
                kind, flow, phi, tok
            ),
        )
        if got == not_run:
            return None, None
        errs.append(got["true_error"])
        its.append(got["iterations"])
    return errs, its


def bar_floor(phi: float, n: int, k: float) -> float:
    """The error bar's resolution floor ``C (h / R)^q`` of the sub-voxel walls
    (:data:`psdesign.flow.error.FLOOR`) for the array at ``n`` voxels per spacing: a lower
    bound of every bar the product reports there (the bar is at least this)."""
    return resolution_floor(L / n, k, 1.0 - phi, 1, FLOOR["subvoxel"])


def alignment_section(cached: Callable, reference_k: Callable, not_run: str) -> list[str]:
    """Markdown lines of the alignment-floor section (rows from ``cached(key, compute)``)."""
    lines = [
        "",
        "## Alignment floor of the sub-voxel walls (voxel, bc = periodic)",
        "",
        f"Each case of the convergence table solved with the cylinders shifted by {len(OFFSETS)} "
        "sub-voxel offsets (`benchmarks/alignment_floor.py`; direct solves on the exact "
        "distance, tol 1e-8). 'sd' is the standard deviation of the true error over the "
        "offsets: how much K moves with where the wall cuts the cells alone, the resolution's "
        "own error floor. Why it is there and what was tried against it: "
        "`benchmarks/RESULTS.md`, 'Issue 12 item 3, alignment scatter'.",
        "",
        "| case | voxels/L | error, unshifted | mean over offsets | sd | min .. max | "
        "bar floor | iterations (min-max) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    summary = []
    floor_rows = {"all": [0, 0], "resolved": [0, 0]}  # [rows, rows within the bar floor]
    for kind, flow, phis, ns in CONVERGENCE:
        for phi in phis:
            firsts, means, sds = [], [], []
            for n in ns:
                errs, its = _case_rows(cached, not_run, kind, flow, phi, n)
                if errs is None:
                    lines.append(f"| {kind} {flow}, phi {phi:g} | {n} | {not_run} | | | | | |")
                    continue
                mean, sd = _stats(errs)
                floor = bar_floor(phi, n, reference_k(kind, flow, phi) * (1 + mean))
                inside = sum(abs(e) <= floor for e in errs)
                for part in ("all", "resolved") if n >= RESOLVED else ("all",):
                    floor_rows[part][0] += len(errs)
                    floor_rows[part][1] += inside
                firsts.append(errs[0])
                means.append(mean)
                sds.append(sd)
                lines.append(
                    f"| {kind} {flow}, phi {phi:g} | {n} | {100 * errs[0]:+.3f} % | "
                    f"{100 * mean:+.3f} % | {100 * sd:.3f} % | {100 * min(errs):+.3f} .. "
                    f"{100 * max(errs):+.3f} % | {100 * floor:.2f} % | {min(its)}-{max(its)} |"
                )
            if len(means) == len(ns):
                summary.append((f"{kind} {flow}, phi {phi:g}", firsts, means, sds, ns))
    return lines + (_summary_lines(summary, floor_rows) if summary else [])


def _summary_lines(summary: list, floor_rows: dict) -> list[str]:
    """The per-case monotone counts under the three criteria and the bar-floor count."""
    lines = [
        "",
        "| case | monotone (unshifted) | offset mean monotone | within the floor "
        f"({FLOOR_SIGMAS:g} sd) | sd coarsest -> finest |",
        "|---|---|---|---|---|",
    ]
    counts = [0, 0, 0]
    misses = []
    for case, firsts, means, sds, ns in summary:
        flags = [
            all(abs(b) < abs(a) for a, b in zip(firsts, firsts[1:], strict=False)),
            all(abs(b) < abs(a) for a, b in zip(means, means[1:], strict=False)),
            within_floor(firsts, sds),
        ]
        counts = [c + f for c, f in zip(counts, flags, strict=True)]
        misses += [f"{case}: {m}" for m in _floor_misses(firsts, sds, ns)]
        words = ["yes" if f else "**no**" for f in flags]
        lines.append(
            f"| {case} | {words[0]} | {words[1]} | {words[2]} | "
            f"{' / '.join(f'{100 * s:.3f}' for s in sds)} % |"
        )
    total = len(summary)
    (n_rows, n_in), (r_rows, r_in) = floor_rows["all"], floor_rows["resolved"]
    lines += [
        "",
        f"Monotone at the unshifted alignment in {counts[0]} of {total} cases; the offset mean "
        f"in {counts[1]} of {total} (a mean of {len(OFFSETS)} offsets still carries sd / "
        f"{len(OFFSETS) ** 0.5:.1f}); within the floor in {counts[2]} of {total} (every rise of "
        f"|true error| at most {FLOOR_SIGMAS:g} sd of the difference of two alignments). "
        f"Rises beyond the floor: {'; '.join(misses) or 'none'}. "
        f"{n_in} of {n_rows} offset rows ({r_in} of {r_rows} at >= {RESOLVED} voxels per "
        "spacing) have |true error| within the error bar's resolution floor alone ('bar "
        "floor', `psdesign/flow/error.py` `FLOOR['subvoxel']`; every bar the product reports "
        "is at least that).",
    ]
    return lines


def _floor_misses(errs: Sequence[float], sds: Sequence[float], ns: Sequence[int]) -> list[str]:
    """The refinement steps (``ns`` the resolutions) that :func:`within_floor` rejects."""
    out = []
    for k in range(len(errs) - 1):
        if not within_floor(errs[k : k + 2], sds[k : k + 2]):
            rise = abs(errs[k + 1]) - abs(errs[k])
            band = FLOOR_SIGMAS * math.hypot(sds[k], sds[k + 1])
            out.append(
                f"{ns[k]} -> {ns[k + 1]} voxels/L: rise {100 * rise:.3f} % > {100 * band:.3f} %"
            )
    return out
