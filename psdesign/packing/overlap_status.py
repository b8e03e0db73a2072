"""The status of Omega, the intersection volume fraction counted on the voxel grid.

The count (:attr:`psdesign.geometry.rve.VoxelFields.intersection_volume_fraction`) and its bar
(:func:`psdesign.geometry.porosity.count_fraction_error`) see an overlap lens only through the
voxel centres inside it. Session 45: two 8 um cylinders overlapping 0.4 um deep at 1 um voxels
counted ``0 +- 0`` against the exact 2.45e-4 of the box. The centre lines know better: two
round fibers (rod, cylinder, bent rod) overlap by a depth ``(D_i + D_j) / 2 - d`` at their
closest approach ``d`` (read off their fields: :func:`overlap_lenses`), in a lens of the volume
:func:`_lens_volume` (:func:`psdesign.packing.genetic.crossing_volume`; near-parallel pairs: at
most the circle lens along the box).

Calibration (``python benchmarks/porosity_error_coverage.py lens 400``, benchmarks/RESULTS.md
session 47; exact lens volumes): the bar covers lenses 1-12 voxels deep, 168 of 168 between
cylinders crossing at random places, 174 of 181 between fibers along grid axes on voxel faces
(a spec's round-number centres; 95 of 96 through voxel centres), 196 of 197 between parallel
fibers along an axis (89 of 93 with the axes on voxel faces, whole voxels apart; session
46's bar, which counted the rounding of a fiber along an axis as if every section were drawn
anew, covered 82 of 106 and 100 of 124 at 3-12 voxels: such lenses were rated
``untrustworthy`` by kind). Under a voxel deep it covers 33 of 54: a lens that thin holds a
voxel centre or not, counted 0 or whole voxels (up to 6x its volume), and no bar drawn from the
count sees it.

Rule (:func:`intersection_status`): Omega is ``untrustworthy`` when the count is 0 while the
centre lines find lenses (it missed them whole), or when what the bar is not calibrated on
exceeds the bar (:func:`_loose_volume`): ``|sum e|`` over the lenses whose count error ``e``
is measured, plus the volume of the thin lenses not measured (:func:`_thin`: shallower than
:data:`RESOLVED_LENS_VOXELS` voxel, or so little deeper that voxel-centre planes cut them in
chords under a voxel wide: a lens exactly 1 voxel deep between two centre planes holds no
centre, a float tie of ``depth < 1 voxel`` rated its ``0 +- 0`` ``ok``), which the count may
miss (or double) all of. A lens between two cylinders along grid axes
(:func:`on_grid_axis`: within ~4.5e-5 rad) is counted where it lies, on the fields' own
voxel centres, against its exact volume (:func:`_in_place_errors`),
and so is a lens family between two parallel cylinders tilted off an axis toward one other
axis (:func:`_lens_labels`; not counted in place, e.g. in a box over a period across its axis
or tilted toward both: each pair measured alone in the whole box, past its cap its whole
volume);
between cylinders off the axes by under a voxel and not parallel, ``k`` congruent lenses
(:func:`_congruent_groups`) err ``k`` times one measured with its pair alone in the whole box
(:func:`_whole_box_error`; unmeasured: their whole volume). Signed, since a regular layout on
round centres rounds its lenses alike, so their errors add linearly while the bar adds them in
quadrature (6-10x the bar in the session 47 review's arrays), and lenses of other shapes round
with other signs (session 47 re-read: a 16 x 16 array summed as absolute values per group was
``untrustworthy`` at 0.69x its bar). A lens holding a voxel in three or more fibers is
counted in place too, its pair's error alone: the pairs' counts differ from the count there by
the rounding of a shared part of no closed form, estimated where it lies
(:func:`psdesign.packing.shared_overlap.shared_part_error`, its error added; RESULTS.md
session 49); one cut by a face of a box of part of a period keeps the
bar's calibration. For cylinders along grid axes (:func:`on_grid_axis`) with no voxel in
three the sum is the count's own error, so the status rates it exactly: of the 800
calibration lenses 762 are rated ``ok``, all covered (session 47's rule: 772, 13 of them
outside the bar at 1.00-1.93x; RESULTS.md session 48). A fixed shape (woven,
compressed) or an image has no centre lines: its overlaps keep the bar's own calibration, while
the round fibers beside a fixed shape are still checked. Limitation: :func:`find_contacts`
keeps the closest piece pair per pair of fiber copies, so a bent rod meeting another fiber
twice in a period is counted once: the undercount errs toward ``ok``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, NamedTuple

import numpy as np

from psdesign.packing.shared_overlap import fibers_vary, shared_part_error

if TYPE_CHECKING:
    from psdesign.geometry.rve import RVE, VoxelFields
    from psdesign.packing.fiberset import Contacts, FiberState

#: Depth in voxels from which the count's bar covers an overlap lens (calibration: module doc).
#: Deeper limits rated well-measured packings ``untrustworthy``: a ``none`` packing of 7 um
#: rods at 1 um voxels (0.01794 +- 0.00052, the same at 0.25 um: 0.01803) holds 20 lenses under
#: 3 voxels with 0.0058 of the box, though their errors cancel (RESULTS.md session 46).
RESOLVED_LENS_VOXELS = 1.0

#: The status of an Omega that does not apply: an image (a segmented scan) has no fibres, so
#: nothing to overlap; its ``0 +- 0`` was printed ``ok`` until session 50, a measurement never
#: made. The value and its bar are then None (``null``, an empty cell), with
#: :data:`NOT_APPLICABLE_NOTE` beside them; the exit, the red box and the trusted table pass
#: it by (:func:`psdesign.cli.exit_status.status_code`, ``analysis.columns.k_not_ok``).
NOT_APPLICABLE = "not_applicable"
#: Why, as ``generate``'s line and summary.json say it (``intersection_volume_fraction_note``).
NOT_APPLICABLE_NOTE = "n/a (image: no fibres)"


class Lenses(NamedTuple):
    """The overlaps of an RVE's fibers, one entry per overlapping pair of fiber copies."""

    #: ``(D_i + D_j) / 2 - d`` at the closest approach ``d`` of the centre lines, metres
    depth_m: np.ndarray
    #: lens volume as a fraction of the box (:func:`_lens_volume`)
    volume: np.ndarray
    #: the two fibers' radii, metres, shape (m, 2)
    radius_m: np.ndarray
    #: the closest points of the two centre lines, metres from the box's corner, (m, 2, 3)
    point_m: np.ndarray
    #: the two centre lines' unit directions at those points, (m, 2, 3)
    direction: np.ndarray
    #: the two fibers' indices in the RVE's fibers list, (m, 2)
    pair: np.ndarray


def overlap_lenses(rve: RVE) -> Lenses | None:
    """The overlaps between two round fibers of ``rve`` (:class:`Lenses`), from their centre
    lines, each lens once (:func:`_lens_labels`: a lens seen from several periodic copies of
    its pair, or a tilted parallel pair's lens family, is one entry); None when ``rve`` has
    fewer than two round fibers beside a fixed shape (woven, compressed) or no fibers list (an
    image), where no centre line says. A fixed shape's own overlaps are not seen: the round
    pairs are still checked (one compressed fiber far off must not switch their check off).

    The volume is exact for two infinite cylinders crossing at an angle; a rod's Eq. (4)
    section lies inside its nominal circle, so for rods depth and volume are upper bounds.

    >>> from psdesign.geometry.fibers import make_fiber
    >>> from psdesign.geometry.rve import RVE
    >>> pair = [make_fiber("cylinder", 0.4, center=[0.5, 0.5, 0.5], direction=u)
    ...         for u in ([1, 0, 0], [0, 0, 1])]
    >>> lenses = overlap_lenses(RVE(size=[1e-4] * 3, fibers=pair))
    >>> lenses.depth_m.round(9).tolist(), round(float(lenses.volume.sum()), 4)  # 16 r^3 / 3
    ([4e-05], 0.0427)
    """
    from psdesign.geometry.fibers import ROUND_SHAPES

    fibers = getattr(rve, "fibers", None)
    if fibers is None:
        return None
    index = [n for n, fb in enumerate(fibers) if fb.shape in ROUND_SHAPES]
    round_fibers = [fibers[n] for n in index]
    if len(round_fibers) < 2:
        if len(round_fibers) < len(fibers):
            return None
        return _no_lenses()
    from psdesign.packing.fiberset import FiberState, find_contacts

    st = FiberState.from_fibers(round_fibers)
    index = np.asarray(index)
    lo, hi = rve.box_normalized
    c = find_contacts(st, lo, hi, 0.0)
    depth = _lens_depth(round_fibers, c)
    label, family = _lens_labels(c, st, lo, hi)
    k = (depth > LENS_DEPTH_TOLERANCE) & _first_of_each(label)
    ri, rj = 0.5 * st.diameter[c.i[k]], 0.5 * st.diameter[c.j[k]]
    sin_a = np.linalg.norm(np.cross(c.di[k], c.dj[k]), axis=1)
    ax = np.argmax(np.abs(c.di[k]), axis=1)
    along = np.abs(c.di[k][np.arange(len(ax)), ax])
    # a parallel lens runs the box's whole length (a box of 2 periods holds 2 periods of it);
    # a family of lattice copies (parallel fibers off the grid axes) the mean length inside the
    # box of the lattice lines through its lens (_family_length)
    length = (hi - lo)[ax] / np.maximum(along, 1e-12)
    rows = np.flatnonzero(k)[family[k]]
    dist = (ri + rj - depth[k])[family[k]]
    length[family[k]] = _family_length(round_fibers, c, rows, dist, lo, hi)
    # the lens of the nominal circles at the depth the fields show (rods: less)
    volume = _lens_volume(ri + rj - depth[k], ri, rj, sin_a, length)
    period = float(rve.period)
    return Lenses(
        depth[k] * period,
        volume / np.prod(hi - lo),
        np.column_stack([ri, rj]) * period,
        np.stack([c.pi[k] - lo, c.pj[k] - lo], axis=1) * period,
        np.stack([c.di[k], c.dj[k]], axis=1),
        np.column_stack([index[c.i[k]], index[c.j[k]]]),
    )


def _no_lenses() -> Lenses:
    z = np.zeros
    return Lenses(z(0), z(0), z((0, 2)), z((0, 2, 3)), z((0, 2, 3)), z((0, 2), np.int64))


#: Depth (normalized by the period) under which a lens is rounding, not overlap: fibers that
#: exactly touch (axes ``(D_i + D_j) / 2`` apart) read depths of ~1e-21 m off their fields,
#: lenses of ~1e-33 of the box that an exact ``0 +- 0`` count would be rated untrustworthy
#: for (7 of 128 touching layouts, session 46 review). 1e-9 of a period is 1e-13 m in a
#: 100 um box, far below any voxel, and far above double rounding (1e-16).
LENS_DEPTH_TOLERANCE = 1e-9

#: Grid (normalized) on which :func:`_lens_labels` compares lens midpoints across periodic
#: copies: the copies' midpoints differ by rounding (1e-16), distinct lenses by far more. Also
#: the threshold under which two fibers' directions count as parallel (``|d_i x d_j|``, and
#: ``1 -`` the largest component for a fiber along a grid axis): a tilted parallel pair is a
#: lens family. Nearly parallel pairs above it (e.g. 1e-8 apart) are not: each copy counts
#: the crossing formula's lens capped at the circle lens along the box, an over-count that
#: errs toward ``untrustworthy``.
LENS_MIDPOINT_GRID = 1e-9


def on_grid_axis(direction: np.ndarray) -> np.ndarray:
    """Whether each unit direction (rows, shape (m, 3)) runs along a grid axis: its largest
    component within :data:`LENS_MIDPOINT_GRID` of 1 (a tilt under ~4.5e-5 rad, whose next
    lattice copy lies ``1 / cos - 1`` < 1e-9 periods off a period).

    >>> d = np.array([[0.0, 0.0, -1.0], [1e-6, 0.0, 1.0], [1e-4, 0.0, 1.0]])
    >>> on_grid_axis(d / np.linalg.norm(d, axis=1)[:, None]).tolist()
    [True, True, False]
    """
    return np.max(np.abs(direction), axis=1) > 1.0 - LENS_MIDPOINT_GRID


def parallel_off_axes(first: np.ndarray, second: np.ndarray) -> np.ndarray:
    """Whether two fibers' unit directions (rows of ``first`` and ``second``, shape (m, 3)) are
    parallel (``|d_i x d_j| <`` :data:`LENS_MIDPOINT_GRID`) and off the grid axes (not
    :func:`on_grid_axis`): the one rule of a tilted lens family for :func:`_lens_labels`,
    :func:`_tilted_parallel` and :func:`_lens_window` (until session 50 each had its own:
    ``1 -`` the largest component over 1e-9, over 0, and ``!= 1.0`` exactly, so a tilt of
    1e-6 was along an axis to the labels, a family to the loose volume and windowed as a tilt).

    >>> d = np.array([[0.0, 0.0, 1.0], [0.6, 0.0, 0.8], [0.6, 0.0, 0.8]])
    >>> parallel_off_axes(d, d[[0, 1, 0]]).tolist()
    [False, True, False]
    """
    cross = np.linalg.norm(np.cross(first, second), axis=1)
    return (cross < LENS_MIDPOINT_GRID) & ~on_grid_axis(first)


def rated_analytic_omega(st: FiberState, lo: np.ndarray, hi: np.ndarray) -> dict[str, object]:
    """:func:`psdesign.packing.genetic.analytic_omega` of ``st`` with its error bar and status:
    ``{"value", "error", "status"}`` (fractions of the box), what ``generate``'s report and the
    relax route's ``summary.json`` store as ``omega_analytic_<before|after>[_error|_status]``
    (they stored the value alone until session 47).

    The value is the nominal cylinders' crossing volume summed over the contacts of
    :func:`~psdesign.packing.fiberset.find_contacts` (the objective the GA and the relax route
    minimize, kept as it is). Its bar adds (a) the quadrature's ``|fine - coarse|`` at
    ``GL_NODES`` and half as many nodes (the relax route's ``U_error`` rule) and (b) every lens
    the value counts more than once: a lens near a box face is one contact per periodic copy
    of the pair (:func:`_one_per_lens`; twice at a face, up to four times at a corner). Status:
    ``ok`` for 0 (no two nominal cylinders overlap, so no two fibers do: exact); for
    overlapping cylinders ``ok`` up to a 20 % bar (:func:`psdesign.analysis.columns.
    bar_status`, the rule of every rated value), else ``untrustworthy``; ``untrustworthy``
    whenever a rod or bent rod overlaps: its Eq. (4) section lies inside its nominal circle,
    so the value only bounds the fibers' overlap from above, by far more than the bar (session
    47, 60 um ``none`` packings of 7 um fibers at porosity 0.85: 0.0158 against the voxel
    count's converged 0.0110 for rods, 0.0304 against 0.0143 for bent rods). Not in the bar
    either: a bent rod meeting another fiber twice in a period is one contact.

    >>> from psdesign.geometry.fibers import make_fiber
    >>> from psdesign.geometry.rve import RVE
    >>> from psdesign.packing.fiberset import FiberState
    >>> pair = [make_fiber("cylinder", 0.4, center=c, direction=u)  # crossing on a box face
    ...         for c, u in (([0.5, 0.5, 0.0], [1, 0, 0]), ([0.5, 0.5, 0.0], [0, 1, 0]))]
    >>> rve = RVE(size=[1e-4] * 3, fibers=pair)
    >>> r = rated_analytic_omega(FiberState.from_fibers(pair), *rve.box_normalized)
    >>> exact = 16 * 0.2**3 / 3  # one Steinmetz solid of r = 0.2 in the unit box
    >>> round(r["value"] / exact, 3), abs(r["value"] - exact) <= r["error"], r["status"]
    (2.0, True, 'untrustworthy')
    """
    from psdesign.analysis.columns import bar_status
    from psdesign.packing.fiberset import find_contacts
    from psdesign.packing.genetic import GL_NODES, contact_volumes

    c = find_contacts(st, lo, hi, 0.0)
    if len(c) == 0:
        return {"value": 0.0, "error": 0.0, "status": "ok"}
    box = float(np.prod(hi - lo))
    fine = contact_volumes(st, c)
    coarse = contact_volumes(st, c, GL_NODES // 2)
    value = float(fine.sum() / box)
    twice = float(fine[~_one_per_lens(c, st, lo, hi)].sum() / box)
    error = abs(value - float(coarse.sum() / box)) + twice
    shapes = np.array([st.shape[k] if k < len(st.shape) else "?" for k in range(len(st))])
    model_only = ((shapes[c.i] != "cylinder") | (shapes[c.j] != "cylinder")) & (fine > 0)
    if value == 0.0:
        status = "ok"
    elif model_only.any():  # the nominal circle holds a rod's section: an upper bound only
        status = "untrustworthy"
    else:
        status = bar_status(error / value)
    return {"value": value, "error": error, "status": status}


def analytic_omega_keys(states: dict[str, FiberState], lo, hi) -> dict[str, object]:
    """``omega_analytic_<tag>``, ``..._error`` and ``..._status`` of each fiber set in
    ``states`` (``{"before": ..., "after": ...}``; an empty set is ``0 +- 0``, ``ok``) by
    :func:`rated_analytic_omega`: the keys a report or summary stores."""
    out: dict[str, object] = {}
    for tag, st in states.items():
        r = rated_analytic_omega(st, lo, hi) if len(st) else {"value": 0.0, "error": 0.0}
        out[f"omega_analytic_{tag}"] = r["value"]
        out[f"omega_analytic_{tag}_error"] = r["error"]
        out[f"omega_analytic_{tag}_status"] = r.get("status", "ok")
    return out


def _one_per_lens(c: Contacts, st: FiberState, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """Mask keeping one contact per lens (:func:`_lens_labels`): the first of each label.
    Only for the lenses' volume: the GA's contacts
    (:func:`psdesign.packing.genetic.analytic_omega`) stay as they are."""
    return _first_of_each(_lens_labels(c, st, lo, hi)[0])


def _first_of_each(label: np.ndarray) -> np.ndarray:
    """Mask of the first entry of each distinct value of ``label``."""
    _, keep = np.unique(label, return_index=True)
    mask = np.zeros(len(label), bool)
    mask[keep] = True
    return mask


def _lens_labels(
    c: Contacts, st: FiberState, lo: np.ndarray, hi: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """A label per contact, shared by the contacts that see one lens, and a mask of the
    contacts that see a lens family (below).

    :func:`psdesign.packing.fiberset.find_contacts` sees a lens near a box face once per
    periodic copy of the pair (twice at a face, four times at a corner where both fibers run
    along grid axes: 0.00432 of the box against the exact 0.00108, session 46 review), so
    contacts with the same fibers and the same lens midpoint modulo the period are one lens.
    Parallel fibers along a grid axis (a lens longer than the period, which
    :func:`psdesign.packing.genetic.crossing_volume` caps at one period) touch anywhere along
    it: their midpoint's coordinate along the axis is left out.

    Two straight fibers parallel to each other but off the grid axes (tilted) repeat on a
    lattice across their axis that is not the box's: each copy of the pair enters the box
    through one face and leaves through another, the next copy (a lattice step on, not a
    period) taking over, at a midpoint elsewhere along the axis. Their copies are one lens
    family, labelled by the vector between the two centre lines (the same for every copy),
    whose volume is the lens area times the mean summed length inside the box of the lattice
    lines through it (:func:`_family_length`; session 48 review: counted per copy, a 4 x 4 array of
    cylinders tilted 0.2-0.9 voxel over the box read 1.16-1.41x its lens volume and loose
    volumes 16-30x the bar)."""
    if len(c.i) == 0:
        return np.zeros(0, np.int64), np.zeros(0, bool)
    period, mid = hi - lo, 0.5 * (c.pi + c.pj)
    width = np.minimum(st.diameter[c.i], st.diameter[c.j])
    sin_a = np.linalg.norm(np.cross(c.di, c.dj), axis=1)
    ax = np.argmax(np.abs(c.di), axis=1)
    along = (sin_a < width) & on_grid_axis(c.di)
    straight = (st.u[c.i] == 0.0) & (st.u[c.j] == 0.0)
    family = straight & parallel_off_axes(c.di, c.dj)
    q = np.mod(mid - lo, period) / period
    q[along, ax[along]] = 0.0
    cell = np.round(q / LENS_MIDPOINT_GRID).astype(np.int64)
    cell %= int(round(1.0 / LENS_MIDPOINT_GRID))  # 1 - 1e-17 and 0 are the same place
    vector = np.where((c.i < c.j)[:, None], c.pj - c.pi, c.pi - c.pj)
    vector -= np.einsum("ij,ij->i", vector, c.di)[:, None] * c.di  # across the axis
    pair = np.column_stack([np.minimum(c.i, c.j), np.maximum(c.i, c.j), family])
    cell[family] = np.round(vector[family] / LENS_MIDPOINT_GRID).astype(np.int64)
    label = np.unique(np.column_stack([pair, cell]), axis=0, return_inverse=True)[1].ravel()
    return label, family


#: Points per axis at which :func:`_family_length` samples a lens family's cross-section.
FAMILY_SAMPLES = 48


def _family_length(
    fibers: list, c: Contacts, rows: np.ndarray, dist: np.ndarray, lo: np.ndarray, hi: np.ndarray
) -> np.ndarray:
    """The length (normalized) that a tilted lens family's cross-section area stands for: the
    mean, over :data:`FAMILY_SAMPLES` ``^2`` points of the lens between the circles of the two
    fibers of contact ``rows`` (axes ``dist`` apart, a row each), of the summed length inside
    the box ``[lo, hi]`` of the lattice lines through the point (one per lattice copy). The
    length of the copies' centre lines alone (session 49) differs where the lens crosses an
    edge of the box: the copies' lines leave through different faces across it (session 50,
    benchmarks/omega_audit.py: 4 x 4 arrays 18 voxels thick at 48^3 tilted on both axes read
    their 56-64 lenses 1.1-6.5x the bar over the lattice-coordinate integral of ``C(c, 2)``,
    and flagged 9 of 10 counts inside their bars)."""
    from itertools import product

    from psdesign.packing.fiberset import _clip_lines

    g = (np.arange(FAMILY_SAMPLES) + 0.5) / FAMILY_SAMPLES
    corners = np.array(list(product(*zip(lo, hi, strict=True))))
    out = np.zeros(len(rows))
    for n, (k, sep) in enumerate(zip(rows, dist, strict=True)):
        e1, e2 = fibers[c.i[k]].lattice
        d = np.cross(e1, e2)
        ri, rj = 0.5 * fibers[c.i[k]].diameter, 0.5 * fibers[c.j[k]].diameter
        w = c.pj[k] - c.pi[k]
        w = w - (w @ d) * d
        eu = w / np.linalg.norm(w) if np.linalg.norm(w) > 0.0 else e1
        u, v = np.meshgrid(sep - rj + g * (ri + rj - sep), (2 * g - 1) * min(ri, rj))
        keep = (u * u + v * v <= ri * ri) & ((u - sep) ** 2 + v * v <= rj * rj)
        u, v = (u[keep], v[keep]) if keep.any() else (np.array([0.5 * (sep - rj + ri)]), [0.0])
        # a lens thinner than the samples' spacing (fibers a hair closer than their radii's
        # sum: a tilted array whose pitch is its diameter) is read at its centre alone
        q = c.pi[k] + np.outer(u, eu) + np.outer(v, np.cross(d, eu))
        span = [(corners @ e)[:, None] - (q @ e)[None] for e in (e1, e2)]
        length = np.zeros(len(q))
        for a, b in product(
            *(range(int(np.floor(x.min())), int(np.ceil(x.max())) + 1) for x in span)
        ):
            s0, s1 = _clip_lines(q + a * e1 + b * e2, np.broadcast_to(d, q.shape), lo, hi)
            length += np.maximum(s1 - s0, 0.0)
        out[n] = length.mean()
    return out


#: Points on the segment between two centre lines' closest points where :func:`_lens_depth`
#: reads the fibers' fields, and the rounds that zoom in on the deepest of them.
LENS_SAMPLES = 17
LENS_ROUNDS = 8


def _lens_depth(fibers: list, c: Contacts) -> np.ndarray:
    """Depth (normalized) of each contact's lens by the fibers' own fields: ``-2 min_t
    max(phi_i, phi_j)`` on the segment between the centre lines' closest points, where the
    two surfaces face each other (``(D_i + D_j) / 2 - d`` for two cylinders; less for rods,
    whose Eq. (4) section lies inside the nominal circle); <= 0 where they do not overlap.
    Each round samples :data:`LENS_SAMPLES` points about the deepest one of the last (the
    ``max`` is V-shaped: a lens 1e-3 of the segment deep lies between two coarse samples)."""
    m = len(c.i)
    if m == 0:
        return np.zeros(0)
    lo, hi = np.zeros(m), np.ones(m)
    best = np.full(m, np.inf)
    u = np.linspace(0.0, 1.0, LENS_SAMPLES)
    for _ in range(LENS_ROUNDS):
        t = lo[:, None] + (hi - lo)[:, None] * u[None, :]
        pts = c.pi[:, None, :] + t[:, :, None] * (c.pj - c.pi)[:, None, :]
        worst = np.full(t.shape, -np.inf)
        for side in (c.i, c.j):
            for f in np.unique(side):
                sel = side == f
                phi = fibers[int(f)].field(pts[sel].reshape(-1, 3)).reshape(-1, LENS_SAMPLES)
                worst[sel] = np.maximum(worst[sel], phi)
        k = np.argmin(worst, axis=1)
        best = np.minimum(best, worst[np.arange(m), k])
        step = (hi - lo) / (LENS_SAMPLES - 1)
        lo, hi = np.clip(t[np.arange(m), k] - step, 0, 1), np.clip(t[np.arange(m), k] + step, 0, 1)
    return -2.0 * best


def _lens_volume(dist, ri, rj, sin_a, length) -> np.ndarray:
    """Lens volume (normalized) of two cylinders of radii ``ri``, ``rj`` whose axes cross at
    ``sin_a`` ``dist`` apart: :func:`psdesign.packing.genetic.crossing_volume`, except where it
    caps a near-parallel pair (``|sin a| < min(D_i, D_j)``, dividing ``int w_i w_j dz`` by
    ``min(D_i, D_j)``: 0.12-0.37x the exact parallel lens for lenses 0.001-0.01 of a period
    deep, the ones the status weighs). There the crossing formula ``int w_i w_j dz / |sin a|``
    holds while under the parallel lens, the circle-lens area times ``length``, which is exact
    at ``sin a = 0``. The GA's objective (:func:`psdesign.packing.genetic.analytic_omega`)
    keeps crossing_volume's cap."""
    from psdesign.packing.genetic import crossing_volume

    volume = crossing_volume(dist, ri, rj, sin_a)
    width = np.minimum(2 * ri, 2 * rj)
    capped = sin_a < width
    with np.errstate(divide="ignore", invalid="ignore"):  # sin a = 0: unbounded
        free = volume * width / sin_a  # crossing_volume divided a capped pair by width
    parallel = circle_lens_area(dist, ri, rj) * length
    return np.where(capped, np.fmin(free, parallel), volume)


def circle_lens_area(dist, r1, r2) -> np.ndarray:
    """Area common to two circles of radii ``r1``, ``r2`` with centres ``dist`` apart (Weisstein,
    "Circle-Circle Intersection", MathWorld, eq. 14): the section of two parallel cylinders'
    lens. One circle inside the other: the smaller circle's area.

    >>> round(float(circle_lens_area(0.0, 1.0, 1.0)), 6), float(circle_lens_area(2.0, 1.0, 1.0))
    (3.141593, 0.0)
    """
    d, r1, r2 = (np.asarray(v, float) for v in (dist, r1, r2))
    d = np.maximum(d, 1e-300)  # concentric: the arccos arguments clip to +-1 or read 0
    a1 = r1**2 * np.arccos(np.clip((d**2 + r1**2 - r2**2) / (2 * d * r1), -1.0, 1.0))
    a2 = r2**2 * np.arccos(np.clip((d**2 + r2**2 - r1**2) / (2 * d * r2), -1.0, 1.0))
    k = (-d + r1 + r2) * (d + r1 - r2) * (d - r1 + r2) * (d + r1 + r2)
    return np.where(d >= r1 + r2, 0.0, a1 + a2 - 0.5 * np.sqrt(np.maximum(k, 0.0)))


def _loose_volume(
    rve: RVE, lenses: Lenses, spacing: float | np.ndarray, count: np.ndarray | None = None
) -> float:
    """Volume fraction of the box in overlaps of ``rve`` (``lenses``: :func:`overlap_lenses`)
    whose count the bar is not calibrated on (module doc) on a grid of ``spacing`` metres:
    ``|sum e|`` over the lenses whose signed count error ``e`` is measured (between two
    cylinders along grid axes, each in place: :func:`_in_place_errors`; fibers off the axes
    by under a voxel: ``k`` times one of ``k`` congruent lenses, :func:`_whole_box_error`;
    tilted parallel families neither: each pair alone, :func:`_pairs_alone_errors`),
    plus, without a sign, the volume of the thin lenses not measured (:func:`_thin`), of the
    tilted parallel families not measured (:func:`_tilted_parallel`) and of the groups that
    cannot be measured. Signed: lenses
    round with different signs (session 47 re-read: a 16 x 16 array of cylinders at 250^3
    voxels, summed as absolute values per group, read 7.6e-3 against its true error 7.4e-4
    and its bar 1.07e-3). With the fields' ``count``, the rounding of the part in three or
    more fibers (:func:`psdesign.packing.shared_overlap.shared_part_error`) joins the sum,
    and its estimate's error is added."""

    spacing = np.broadcast_to(np.asarray(spacing, float), (3,))
    error, cut = _in_place_errors(rve, lenses, spacing)
    placed = ~np.isnan(error)
    shared, shared_error = (0.0, 0.0) if count is None else shared_part_error(rve, count, spacing)
    signed = float(error[placed].sum()) - shared
    # a parallel pair off the grid axes is a lens family the bar is not calibrated on: unless
    # measured, its whole volume is weighed (session 49 review: a box of 2 x 2 periods across
    # a 4 x 4 array tilted 2 voxels measured none of it, ``ok`` at 1.34x the bar); a lens cut
    # by a face keeps the bar's calibration, tilted or not (weighed whole, a 0.75-period box
    # across a tilted 4 x 4 array read 1.07x / 2.12x the bar for a count 0.06x off)
    family = _tilted_parallel(lenses) & ~placed & ~cut
    weighed = (_thin(lenses, float(np.max(spacing))) & ~placed & ~cut) | family
    # a family's pairs are measured each alone (_pairs_alone_errors), not as congruent
    # groups: at surface ties congruent members round differently (a 4 x 4 array 21 voxels
    # thick on voxel faces, tilted 0.5 voxel along (1, 1), read 0.19x the bar for 1.60x)
    group = np.where(placed | cut | family, -1, _congruent_groups(lenses, spacing, rve.size))
    cheap = np.prod(np.asarray(rve.size) / spacing) <= CHEAP_WHOLE_BOX_VOXELS
    for g in np.unique(group[group >= 0]):
        members = np.flatnonzero(group == g)
        if len(members) == 1 and not cheap:
            continue  # a single lens keeps the bar's calibration (thin or a family: weighed)
        pair = [rve.fibers[int(k)] for k in lenses.pair[members[0]]]
        e = _whole_box_error(rve, pair, spacing)
        if e is None:  # rods, too big: a group weighs its volume, a single lens if thin
            weighed[members] |= len(members) > 1
        else:  # its error stands for its volume, thin or not
            signed += len(members) * e
            weighed[members] = False
    error_sum, measured = _pairs_alone_errors(rve, lenses, family, spacing)
    signed += error_sum
    weighed &= ~measured
    return abs(signed) + shared_error + float(lenses.volume[weighed].sum())


def _pairs_alone_errors(
    rve: RVE, lenses: Lenses, which: np.ndarray, spacing: np.ndarray
) -> tuple[float, np.ndarray]:
    """The summed signed count error of the lenses ``which`` (a mask), each pair's measured
    once with its two cylinders alone in the whole box (:func:`_whole_box_error`, its
    :data:`MEASURED_GROUP_VOXELS` cap), and the mask of those measured. For tilted parallel
    families no window holds and no congruent group measures (session 49 review: 14 random
    cylinders 0.12 thick along ``(tan 30 deg, 0, 1)`` at 48^3, counts 0.12-1.21x the bar, were
    all weighed whole, ``untrustworthy``; measured, 0.10-1.30x: the right statuses)."""
    signed, measured = 0.0, np.zeros(len(which), bool)
    for pair in np.unique(lenses.pair[which], axis=0):
        own = which & np.all(lenses.pair == pair, axis=1)
        e = _whole_box_error(rve, [rve.fibers[int(k)] for k in pair], spacing)
        if e is not None:
            signed += int(own.sum()) * e
            measured |= own
    return signed, measured


def _tilted_parallel(lenses: Lenses) -> np.ndarray:
    """Lenses between two parallel fibers off the grid axes (a lens family,
    :func:`_lens_labels`)."""
    return parallel_off_axes(lenses.direction[:, 0], lenses.direction[:, 1])


#: Voxels up to which :func:`_whole_box_error` voxelizes a congruent lens's pair alone in the
#: whole box (256^3: about 85 MB of fields at 5 bytes a voxel); beyond, the group weighs its
#: whole volume.
MEASURED_GROUP_VOXELS = 256**3

#: Voxels up to which :func:`_loose_volume` measures a single lens that is not measured in
#: place in the whole box (about 10 ms at 64^3): a random packing of fibers slightly off the
#: grid axes would cost one whole-box voxelization per lens on a fine grid (the bar's
#: calibration stands for them there).
CHEAP_WHOLE_BOX_VOXELS = 64**3

#: Voxels :func:`_lens_window` leaves around a lens's bounding box.
WINDOW_PAD_VOXELS = 2


def _whole_box_error(rve: RVE, pair: list, spacing: np.ndarray) -> float | None:
    """The signed count error (count - exact, a fraction of the box) of one lens between the
    two cylinders ``pair``, measured with them alone in the whole box on the same grid
    against their exact lens volume: the mean over their lenses there; None for a rod or
    bent rod (its volume is a bound), past :data:`MEASURED_GROUP_VOXELS` voxels, or when the
    grid differs. Session 47 measured every group so (4.2 s for the 164 groups of a 16 x 16
    array at 250^3 voxels); two fibers along grid axes (:func:`on_grid_axis`) are now
    measured in place (:func:`_in_place_errors`)."""
    from psdesign.geometry.rve import RVE

    too_big = np.prod(np.asarray(rve.size) / spacing) > MEASURED_GROUP_VOXELS
    if too_big or any(fb.shape != "cylinder" for fb in pair):
        return None
    alone = RVE(size=rve.size, fibers=pair, period=rve.period)
    if not np.allclose(alone.grid(float(spacing[0])).spacing, spacing, rtol=1e-9):
        return None  # checked before the voxelization it would waste (voxelize builds this grid)
    own = overlap_lenses(alone)
    if len(own.volume) == 0:
        return None
    fields = alone.voxelize(float(spacing[0]))
    return (fields.intersection_volume_fraction - float(own.volume.sum())) / len(own.volume)


def _in_place_errors(
    rve: RVE, lenses: Lenses, spacing: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The signed count error (count - exact, a fraction of the box) of each lens between two
    cylinders along grid axes (:func:`on_grid_axis`), or parallel and tilted off one
    (:func:`_lens_window`), counted where it lies: the voxel centres of a small
    window of the grid around it (:func:`_lens_window`) inside both cylinders, by the
    rasterizer's own arithmetic (:func:`_inside_cylinder`), so that each voxel rounds as in
    the fields, a centre on a surface too (tests/unit/test_overlap_status.py: the pairs'
    counts sum to the fields' count, voxel for voxel, plus the voxels in ``c >= 3`` fibers
    ``C(c, 2) - 1`` times more); NaN for the other lenses. A lens holding voxels in three or
    more fibers is counted so too: its pair's error is exact, while the count differs from
    the pairs' sum there by the rounding of a shared part no closed form gives, which
    :func:`psdesign.packing.shared_overlap.shared_part_error` estimates (session 48 review:
    added whole, that part rated 16 of 16 random packings whose counts the bar covers
    ``untrustworthy``, up to 49x the bar; session 49 review: left out, square arrays whose
    diagonal neighbours overlap were ``ok`` at 1.19-1.77x the bar). Session 48 measured such
    lenses alone in the whole box (the same error, one voxelization per congruent group:
    7.6 s on a 16 x 16 array at 250^3 whose diagonal neighbours overlap) and not at all for a
    single one on grids over 64^3.

    Also a mask of the lenses whose window a face of a box of part of a period cuts (the box
    is not periodic there): the count holds only the part inside, so no exact volume is known
    (session 48 review: measured whole, a lens on the z = 0 face of a box 0.75 of a period
    tall read its cut-off part as count error, ``untrustworthy`` at 40-68^3)."""
    out, cut = np.full(len(lenses.depth_m), np.nan), np.zeros(len(lenses.depth_m), bool)
    shape = np.round(np.asarray(rve.size) / spacing).astype(np.int64)
    h = spacing / rve.period  # normalized, as RVE.voxelize rasterizes
    whole = np.abs(rve.size / rve.period - np.round(rve.size / rve.period)) < 1e-9
    for n in range(len(out)):
        pair = [rve.fibers[int(k)] for k in lenses.pair[n]]
        window = _lens_window(lenses, n, spacing, float(rve.period), shape)
        if window is None or any(fb.shape != "cylinder" for fb in pair):
            continue
        wraps = [w.min() < 0 or w.max() >= s for w, s in zip(window, shape, strict=True)]
        if any(wr and not wh for wr, wh in zip(wraps, whole, strict=True)):
            cut[n] = True  # a box of part of a period is not periodic: its faces cut the lens
            continue
        index = [w % s for w, s in zip(window, shape, strict=True)]
        x = [(i + 0.5) * ha for i, ha in zip(index, h, strict=True)]
        both, slices = _count_both(pair, x)
        out[n] = int(np.count_nonzero(both)) * slices / np.prod(shape) - lenses.volume[n]
    return out, cut


def _count_both(pair: list, x: list[np.ndarray]) -> tuple[np.ndarray, int]:
    """Which voxel centres ``x[0] x x[1] x x[2]`` lie inside both cylinders of ``pair``
    (:func:`_inside_cylinder`), and how many slices each stands for. Along an axis where
    neither fiber's lattice has a component (a parallel pair's: adding 0.0 leaves each sum as
    it is) every slice rounds alike, so one stands for all (``len(x[a])`` of them; the mask
    has length 1 there and broadcasts)."""
    x, slices = list(x), 1
    for a, varies in enumerate(fibers_vary(pair)):
        if not varies:
            x[a], slices = x[a][:1], slices * len(x[a])
    return _inside_cylinder(pair[0], x) & _inside_cylinder(pair[1], x), slices


def _lens_window(
    lenses: Lenses, n: int, spacing: np.ndarray, period: float, shape: np.ndarray
) -> list[np.ndarray] | None:
    """The voxel indices (per axis, unwrapped) of a window of the grid that holds lens ``n``:
    along an axis that one of its fibers crosses, within that fiber's radius of its centre
    line where it enters or leaves the box (both: the tighter), plus
    :data:`WINDOW_PAD_VOXELS`; along a parallel pair's axis the whole grid. A tilted parallel
    pair's window wraps at the box's faces onto the next copy of its lens family
    (:func:`_lens_labels`), which lies ``1 / cos - 1`` periods off a period: the window widens
    by that many voxels on both sides (session 49 review: required under half a voxel, a
    4 x 4 array tilted 10 voxels over 64^3 went unmeasured). None when a fiber does not run
    along a grid axis (:func:`on_grid_axis`) and is not such a parallel pair
    (:func:`parallel_off_axes`), a parallel pair sits in a box
    over a period across its axis (several copies of the family, a window holds one: a
    2-period box read half of it; :func:`_loose_volume` measures such a family with each pair
    alone, or weighs it), the window is wider than the grid, or a radius and the pad
    reach half a period: another copy of a fiber lies a period off across its axis, so its
    lens with the other fiber lies outside a window under
    ``2 (r + pad)`` wide in that direction (a
    guard on the sum of the two radii sent fat pairs to :func:`_whole_box_error`, whose
    congruent members round differently at surface ties: a 3 x 3 array 26 voxels thick at
    60^3 read 0.0258 against its 0.0152)."""
    d = lenses.direction[n]
    ax = np.argmax(np.abs(d), axis=1)
    radius, point = lenses.radius_m[n], lenses.point_m[n]
    pad = WINDOW_PAD_VOXELS * float(np.max(spacing))
    along = np.abs(d[[0, 1], ax])
    # parallel and off the axes: the next copy across the box lies ``1 / along - 1`` periods
    # from a period off, so the window widens by that many voxels on both sides (session 49
    # review: required under half a voxel, a 4 x 4 array tilted 10 voxels over 64^3 had no
    # window, its lenses unmeasured, ``ok`` at 1.31x the bar)
    tilted = bool(parallel_off_axes(d[:1], d[1:])[0])
    extra = int(np.ceil((1.0 / along[0] - 1.0) * period / float(np.min(spacing)))) if tilted else 0
    across = np.arange(3) != ax[0]
    # a box over a period across the axis holds several copies of the family, a window one;
    # tilted on both across axes the fibre's copies form a sheared lattice whose next copy
    # the widened window misses (session 49 review: 14 needless flags in 40 4 x 4 arrays
    # tilted (tx, ty, 1), one ``ok`` right by chance): only a single-axis tilt is windowed
    tilted &= bool(np.all(shape[across] * spacing[across] <= period * (1.0 + 1e-9)))
    tilted &= int(np.count_nonzero(d[0, across])) == 1
    if not (np.all(on_grid_axis(d)) or tilted) or radius.max() + pad >= 0.5 * period:
        return None
    lo, hi = np.full(3, -np.inf), np.full(3, np.inf)
    for s in (0, 1):
        across = np.arange(3) != ax[s]
        # the centre line where it enters and leaves the box (one point for a grid axis)
        ends = point[s] + np.outer(
            ([0.0, shape[ax[s]] * spacing[ax[s]]] - point[s, ax[s]]) / d[s, ax[s]], d[s]
        )
        lo[across] = np.maximum(lo[across], ends[:, across].min(axis=0) - radius[s])
        hi[across] = np.minimum(hi[across], ends[:, across].max(axis=0) + radius[s])
    along = ~np.isfinite(lo)  # a parallel pair's axis
    pad_voxels = WINDOW_PAD_VOXELS + extra
    first = np.where(along, 0, np.floor(lo / spacing) - pad_voxels).astype(np.int64)
    last = np.where(along, shape, np.ceil(hi / spacing) + pad_voxels).astype(np.int64)
    if np.any(last - first > shape):
        return None
    return [np.arange(a, b) for a, b in zip(first, last, strict=True)]


def _inside_cylinder(fb, x: list[np.ndarray]) -> np.ndarray:
    """Whether the voxel centres ``x[0] x x[1] x x[2]`` (normalized coordinates per axis) lie
    in the cylinder ``fb``, by the operations of
    :func:`psdesign.geometry.raster.rasterize_copy` in their order (``val <= 0``), so that a
    centre on the surface rounds as it does in the fields."""
    e = [x[0][:, None, None] - fb.center[0], x[1][None, :, None] - fb.center[1]]
    e.append(x[2][None, None, :] - fb.center[2])
    a = e[0] * fb.lattice[0][0] + e[1] * fb.lattice[0][1] + e[2] * fb.lattice[0][2]
    b = e[0] * fb.lattice[1][0] + e[1] * fb.lattice[1][1] + e[2] * fb.lattice[1][2]
    a -= np.round(a)
    b -= np.round(b)
    return np.sqrt(a * a + b * b) - fb.diameter / 2.0 <= 0.0


def _thin(lenses: Lenses, voxel: float) -> np.ndarray:
    """Lenses that may hold no voxel centre: under one voxel deep, or so little deeper that
    the chords where voxel-centre planes cut them are under a voxel wide. A circle of radius
    ``R`` is cut ``e`` inside its edge in a chord ``2 sqrt(2 R e)``, under one voxel ``h``
    while ``e < h^2 / (8 R)``; a lens with both edges so close to centre planes is up to
    ``h (1 + h / (4 R_min))`` deep (session 47 review: two 5 um cylinders 4 um apart at 1 um
    voxels, a lens 1.0 voxel deep between voxel-centre planes, counted ``0 +- 0`` against the
    exact 1.28e-3 of the box and rated ``ok``: ``depth < h`` was a float tie)."""
    r_min = np.min(lenses.radius_m, axis=1)  # (0,) for no lenses
    limit = RESOLVED_LENS_VOXELS * voxel * (1.0 + voxel / (4.0 * np.maximum(r_min, 1e-300)))
    return lenses.depth_m < limit


#: Tick (voxels) to which :func:`_congruent_groups` rounds two lenses' radii, depths, sub-voxel
#: offsets and relative vectors: a power of two, so that round-number layouts (centres at
#: k / 2^j of a voxel) fall on whole ticks, not on the half-ticks where rounding noise of
#: 1e-16 splits a group (1e-3 until session 48: 16 of the 512 lenses of a 16 x 16 array at
#: 250^3 voxels, offsets 0.1875 = 187.5 ticks, fell out of their groups).
CONGRUENT_VOXELS = 2.0**-10


def _congruent_groups(lenses: Lenses, spacing: np.ndarray, box_m: np.ndarray) -> np.ndarray:
    """A label per lens, shared by the lenses congruent to each other on the grid (-1: a fiber
    not along a grid axis): both fibers along grid axes (drifting under a voxel over the box), the
    same radii, depth and axes, the same offset of the centre lines' closest points to the
    voxel centres (along a parallel pair's axis any), and the same vector between those
    points (:func:`_pair_vector`): a pair of axis neighbours and a diagonal pair of the same
    offsets are not congruent (session 47 re-read: without it the status depended on the
    order of the fibers, one axis pair before 63 diagonal ones ``ok`` at 1.3x the bar).
    The grid rounds congruent lenses alike, so their count's errors add linearly where the
    bar (:func:`psdesign.geometry.porosity.count_fraction_error`) adds runs in quadrature:
    a 4 x 4 square array of parallel fibers 3 voxels deep counted 0.125 against the exact
    0.163, 9.4x the bar; one pair 1.8x its bar, 32 copies 10.3x (session 47 review). Every
    lens gets a label, a single lens its own; -1 only where a fiber drifts a voxel or more off
    the grid axes over the box. :func:`_loose_volume` measures a single lens in the whole box
    only on grids up to :data:`CHEAP_WHOLE_BOX_VOXELS`; above, it keeps the bar's calibration
    (thin: weighed)."""
    if len(lenses.depth_m) == 0:
        return np.zeros(0, np.int64)
    voxel = float(np.max(spacing))
    ax = np.stack([_grid_axis(lenses.direction[:, s], box_m, voxel) for s in (0, 1)], axis=1)
    offset = np.mod(lenses.point_m / spacing, 1.0)  # (m, 2, 3), in voxels
    parallel = ax[:, 0] == ax[:, 1]
    rows = np.flatnonzero(parallel & (ax[:, 0] >= 0))
    offset[rows, :, ax[rows, 0]] = 0.0  # a parallel lens runs along its axis
    tick = CONGRUENT_VOXELS
    off = np.mod(np.round(offset / tick).astype(np.int64), int(round(1.0 / tick)))
    sides = [
        np.column_stack([np.round(lenses.radius_m[:, s] / voxel / tick), ax[:, s], off[:, s]])
        for s in (0, 1)
    ]
    first = ~_lexless(sides[1], sides[0])  # each pair's sides in one order
    lo_side = np.where(first[:, None], sides[0], sides[1])
    hi_side = np.where(first[:, None], sides[1], sides[0])
    depth = np.round(lenses.depth_m / voxel / tick)[:, None]
    vector = _pair_vector(lenses, spacing, rows, ax, first, (sides[0] == sides[1]).all(axis=1))
    key = np.column_stack([depth, lo_side, hi_side, vector]).astype(np.int64)
    _, inverse = np.unique(key, axis=0, return_inverse=True)
    return np.where((ax >= 0).all(axis=1), inverse.ravel(), -1)


def _pair_vector(lenses: Lenses, spacing, parallel, ax, first, same) -> np.ndarray:
    """The vector (ticks of :data:`CONGRUENT_VOXELS` voxels) from the closest point of each
    lens's first side to its second's, in the sides' order of :func:`_congruent_groups`
    (``first``: side 0 comes first); 0 along the axis of a ``parallel`` pair (rows), where
    any point is closest; where both sides are alike (``same``) the pair has no order, so
    the vector and its negative are one: the lexicographically larger one stands."""
    vector = (lenses.point_m[:, 1] - lenses.point_m[:, 0]) / spacing
    vector[parallel, ax[parallel, 0]] = 0.0
    vector = np.round(np.where(first[:, None], vector, -vector) / CONGRUENT_VOXELS) + 0.0
    flip = same & _lexless(vector, -vector)
    vector[flip] = -vector[flip] + 0.0  # + 0.0: no -0 ticks
    return vector


def _lexless(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise ``a < b`` in lexicographic order (rows of equal length)."""
    diff = a != b
    first = np.argmax(diff, axis=1)
    rows = np.arange(len(a))
    return diff.any(axis=1) & (a[rows, first] < b[rows, first])


def _grid_axis(d: np.ndarray, box_m: np.ndarray, voxel: float) -> np.ndarray:
    """The grid axis (0, 1, 2) each unit direction ``d`` runs along, drifting less than one
    ``voxel`` off it over the box's edge ``box_m`` (metres); -1 where it does not (session 46)."""
    ax = np.argmax(np.abs(d), axis=1)
    along = np.abs(d[np.arange(len(d)), ax])
    off = np.sqrt(np.clip(1.0 - along**2, 0.0, None))
    return np.where(off * np.asarray(box_m, float)[ax] < voxel * along, ax, -1)


def intersection_status(rve: RVE, fields: VoxelFields) -> str:
    """``ok`` or ``untrustworthy``: the status of ``fields.intersection_volume_fraction``
    (module doc). ``untrustworthy`` when the count is 0 while the centre lines of ``rve``
    find lenses, or when the overlaps that the count's bar ``fields.intersection_error`` is
    not calibrated on (:func:`_loose_volume`) hold more of the box than that
    bar. Without centre lines (an image, or fewer than two round
    fibers beside a fixed shape: woven, compressed) the bar's own calibration stands: ``ok``.

    >>> from psdesign.geometry.fibers import make_fiber
    >>> from psdesign.geometry.rve import RVE
    >>> pair = [make_fiber("cylinder", 0.4, center=[0.5, 0.5 + o, 0.5], direction=u)
    ...         for o, u in ((0.0, [1, 0, 0]), (0.38, [0, 0, 1]))]  # a lens 0.4 um deep
    >>> rve = RVE(size=[20e-6] * 3, fibers=pair)
    >>> [(f.intersection_volume_fraction, intersection_status(rve, f))
    ...  for f in (rve.voxelize(1e-6), rve.voxelize(0.5e-6))]
    [(0.0, 'untrustworthy'), (0.000375, 'ok')]
    """
    lenses = overlap_lenses(rve)
    if lenses is None:
        return "ok"
    if lenses.volume.sum() > 0.0 and fields.intersection_volume_fraction == 0.0:
        return "untrustworthy"  # lenses the count missed whole: its 0 +- 0 says nothing
    loose = _loose_volume(rve, lenses, fields.grid.spacing, fields.count)
    return "ok" if loose <= fields.intersection_error else "untrustworthy"
