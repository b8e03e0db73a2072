"""The FEM and voxel routes agree on the same RVE and boundary condition (issue 12, item 1).

Both routes solve the same voxelized analytic RVE (``RVE.voxelize``: the FEM meshes its distance
field, the voxel route uses it for sub-voxel walls). The assertion is ``|K_fem / K_voxel - 1| <=
2 %`` for

* ``bc = "periodic"``: square cylinder arrays (thin slabs: along and across the cylinders, also
  checked against the published values), and periodic random RVEs of straight and bent fibers
  and a plain-weave cell. The FEM periodic route needs matching opposite faces, so the random
  RVEs are built periodic: fibers along x or y at seeded random positions (a straight cylinder
  or a bent rod with a whole number of bends per period is periodic along its axis, its PS copies
  repeat across it); the woven cell of Eq. (19) repeats every two periods along its fibers, so
  its box is two periods wide in-plane and one period thick.
* ``bc = "permeameter"``: the same RVEs between empty reservoirs with slip sides. On the array
  both routes take the windowed-dissipation drop and agree; the one-period random RVEs are
  periodic along the flow, so both routes stack two copies (``flow.permeameter_copies``), where
  the windowed drop is exact again (docs/permeability.md, "Stacked permeameter"); the woven
  case is the shipped woven spec (``studies/table3/woven.toml``) stacked two copies deep; the
  shipped three_rods spec (porosity 0.91) is compared stacked three copies deep, where the
  entrance disturbance has left the window (two copies: -3.7 %, the sample length).

Measured values are in ``docs/solver-agreement.md`` (``benchmarks/solver_agreement.py``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from fem_arrays import array_rve
from reference_values import k_square_across, k_square_along

from psdesign.flow.permeability import permeability_fem, route_result
from psdesign.geometry.rve import RVE
from psdesign.packing.build import build_rve
from psdesign.schema.spec import load_spec, validate_spec

MU = 1.8e-5
S = 40e-6  #: array spacing (m)
AGREE = 0.02  #: FEM vs voxel, relative


def _pair(rve: RVE, fields, direction: str, flow: dict) -> tuple[dict, dict]:
    fem = route_result(rve, fields, direction, flow, "fem")
    vox = route_result(rve, fields, direction, flow, "voxel")
    for r in (fem, vox):
        assert r["converged"], r
        assert r["bc"] == flow["bc"]
    return fem, vox


def _report(name: str, fem: dict, vox: dict) -> float:
    diff = fem["permeability_m2"] / vox["permeability_m2"] - 1.0
    print(
        f"\n{name}: K fem {fem['permeability_m2']:.5e} voxel {vox['permeability_m2']:.5e} "
        f"fem/voxel - 1 = {100 * diff:+.2f} %"
    )
    return diff


# ------------------------------------------------------------------------------- arrays


def square_slab(phi: float, n_cells: int = 1, depth: float = 4e-6) -> tuple[RVE, float]:
    """``n_cells`` square-array cells in a row along x, cylinders along z, ``depth`` thick in z
    (the flow along and across is two-dimensional, so a thin periodic slab is exact); returns
    the RVE (:func:`fem_arrays.array_rve`) and the cylinder radius."""
    rve, _ = array_rve("across", phi, n_cells, depth)
    return rve, S * np.sqrt(phi / np.pi)


def _square_ref(direction: str, a: float, phi: float) -> float:
    return k_square_along(a, phi) if direction == "z" else k_square_across(a, phi)


@pytest.mark.parametrize("direction", ["z", "x"], ids=["along", "across"])
@pytest.mark.parametrize("phi", [0.2, 0.3])
def test_array_periodic_fem_and_voxel_agree(phi, direction):
    """Square array, one periodic cell, voxel 1 um (40 per spacing), FEM default lattice step.

    Truth: Drummond & Tahir (1984) along, Sangani & Acrivos (1982) Table 1 across; both routes
    within 1.5 % of it and within 2 % of each other.
    """
    rve, a = square_slab(phi)
    fields = rve.voxelize(1e-6)
    fem, vox = _pair(rve, fields, direction, {"viscosity": MU, "bc": "periodic"})
    diff = _report(f"square phi {phi} {direction}", fem, vox)
    ref = _square_ref(direction, a, phi)
    assert fem["permeability_m2"] == pytest.approx(ref, rel=0.015, abs=0)
    assert vox["permeability_m2"] == pytest.approx(ref, rel=0.015, abs=0)
    assert abs(diff) <= AGREE


def test_array_permeameter_fem_and_voxel_agree():
    """Across a square array three cells long between slip walls (symmetry planes), phi 0.2."""
    rve, a = square_slab(0.2, n_cells=3)
    fields = rve.voxelize(1e-6)
    flow = {"viscosity": MU, "bc": "permeameter", "aux_length": 0.2, "sides": "slip"}
    fem, vox = _pair(rve, fields, "x", flow)
    diff = _report("square phi 0.2 across, permeameter, 3 cells", fem, vox)
    assert fem["permeability_m2"] == pytest.approx(k_square_across(a, 0.2), rel=0.015, abs=0)
    assert abs(diff) <= AGREE


# ------------------------------------------------------------------- periodic random RVEs


def periodic_fibers(
    kind: str, seed: int, size: float = 40e-6, n: int = 5, diameter: float = 8e-6
) -> list[dict]:
    """``n`` fibers along x or y (seeded), centre lines at least one diameter + 2 um apart
    (minimum image; bent rods add their bend amplitude). ``kind``: 'straight' (exact cylinders)
    or 'bent' (bent rods, u = 0.25, 1 or 2 bends per period: periodic along the axis)."""
    rng = np.random.default_rng(seed)
    u = 0.25
    clearance = diameter + 2e-6 + (2 * u * size / (2 * np.pi) if kind == "bent" else 0.0)
    placed: list[tuple[int, float, float]] = []
    fibers: list[dict] = []
    for _ in range(20000):
        if len(fibers) == n:
            break
        ax = int(rng.integers(0, 2))
        pos, z = rng.uniform(0, size, 2)
        f = float(rng.integers(1, 3))

        def wrap(d: float) -> float:
            return (d + size / 2) % size - size / 2

        if any(
            (np.hypot(wrap(pos - p2), wrap(z - z2)) if a2 == ax else abs(wrap(z - z2))) < clearance
            for a2, p2, z2 in placed
        ):
            continue
        placed.append((ax, pos, z))
        centre = [0.0, pos, z] if ax == 0 else [pos, 0.0, z]
        direction = [1, 0, 0] if ax == 0 else [0, 1, 0]
        fb = {"diameter": diameter, "center": centre, "direction": direction}
        if kind == "straight":
            fibers.append({"shape": "cylinder", **fb})
        else:
            fibers.append({"shape": "bent-rod", **fb, "u": u, "f": f})
    if len(fibers) < n:
        raise ValueError(f"n: could not place {n} fibers in a {size} m box")
    return fibers


def periodic_spec(kind: str, seed: int = 1, voxel: float = 1e-6, flow: dict | None = None) -> dict:
    """Spec of a periodic RVE: 'straight' / 'bent' (40 um cube, five 8 um fibers) or 'woven'
    (the plain-weave cell of Eq. (19), period 30 um, box 60 x 60 x 30 um, one layer)."""
    if kind == "woven":
        period = 30e-6
        rve = {"size": [2 * period, 2 * period, period], "voxel": voxel, "period": period}
        fibers = [{"shape": "woven-cell", "thickness_axis": "z", "layers": 1}]
    else:
        rve = {"size": [40e-6] * 3, "voxel": voxel}
        fibers = periodic_fibers(kind, seed)
    return validate_spec({"rve": rve, "fibers": fibers, "flow": {"viscosity": MU, **(flow or {})}})


#: FEM lattice step of the periodic woven cell: at the default 2 um (two steps across a yarn) the
#: FEM is unresolved there (-4.3 % against the voxel route through-plane, its bar 15 %).
WOVEN_CELL_STEP = 1.5e-6


def _random_pair(kind: str, direction: str, bc: str, voxel: float = 1e-6, seed: int = 1):
    """FEM on the ``voxel`` grid's distance field (default lattice step, 2 voxels), voxel route
    on a grid twice as fine: at 8 voxels per diameter the voxel route is the one that carries
    the error (bent z, periodic: K voxel 7.877e-12 at 1 um, 7.752e-12 at 0.5 um, 7.7635e-12
    since the sub-voxel fix 6fe9f8d; FEM 7.651e-12, 7.6627e-12 on its own field since,
    its lattice step halved from 4 um moves it by < 1 %; docs/solver-agreement.md)."""
    flow = {"bc": bc}
    if bc == "permeameter":
        flow |= {"aux_length": 0.2, "sides": "slip"}
    if kind == "woven":  # 2.8 lattice steps across a 4.26 um yarn (see the test below)
        flow["lattice_step"] = WOVEN_CELL_STEP
    spec = periodic_spec(kind, seed=seed, voxel=voxel, flow=flow)
    built = build_rve(spec)
    fem = route_result(built.rve, built.voxelize(voxel), direction, spec["flow"], "fem")
    vox = route_result(built.rve, built.voxelize(voxel / 2), direction, spec["flow"], "voxel")
    for r in (fem, vox):
        assert r["converged"], r
        assert r["bc"] == bc
        if bc == "permeameter":
            assert r["permeameter_copies"] == 2
    name = f"{kind} seed {seed} {direction} {bc} fem voxel {voxel:g}, voxel {voxel / 2:g}"
    return _report(name, fem, vox)


def test_periodic_fibers_are_periodic():
    """The random RVEs' distance fields match across every face pair (what FEM periodic needs)."""
    for kind in ("straight", "bent", "woven"):
        built = build_rve(periodic_spec(kind))
        size = np.asarray(built.rve.size)
        p = np.random.default_rng(0).uniform(0, 1, (2000, 3)) * size
        for ax in range(3):
            lo, hi = p.copy(), p.copy()
            lo[:, ax], hi[:, ax] = 0.0, size[ax]
            gap = np.abs(built.rve.union_field(lo) - built.rve.union_field(hi)).max()
            assert gap < 1e-9 * size.max(), (kind, ax, gap)


@pytest.mark.slow
@pytest.mark.parametrize("direction", ["z", "x"], ids=["through", "in-plane"])
@pytest.mark.parametrize("kind", ["straight", "bent", "woven"])
def test_random_periodic_fem_and_voxel_agree(kind, direction):
    """Periodic random straight / bent RVE and woven cell: FEM on the 1 um field at its default
    step (2 um), voxel route at 0.5 um (16 voxels per diameter).

    Measured (seed 1, agree17, 2026-12-03 10:51-11:01, load 5-7, after the sub-voxel fix
    6fe9f8d): straight fem/voxel - 1 = -1.23 % through-plane (K fem 6.5895e-12, voxel
    6.6718e-12), -0.49 % in x (1.8071e-11, 1.8161e-11); bent -1.30 % through-plane (7.6627e-12,
    7.7635e-12), -0.58 % in x (1.8423e-11, 1.8531e-11); before it (load 11, 2026-12-01)
    -1.13 / -0.46 / -1.31 / -0.67 %; woven cell (yarns 4.3 um thick: 8.6 voxels at 0.5 um;
    the FEM samples its own 0.5 um field, psdesign.flow.fem_field, at a 1.5 um step,
    WOVEN_CELL_STEP) +0.10 % through-plane (1.5490e-12, 1.5474e-12), +0.16 % in x
    (4.0535e-11, 4.0469e-11), s42-paper 2026-12-06 05:37-05:40, load 6-7, with the woven
    diameter measured across the bent centre line (0d49c9d; before it +0.04 %, 1.5480e-12, and
    +0.16 %, 4.0533e-11, load 3-4, 2026-12-01 23:51-23:55; the voxel figures of the main at
    7a43228; against the earlier 1.5593e-12 / 4.0412e-11: -0.66 % / +0.30 %). Before the FEM
    sampled its own field it meshed the 1 um grid at 2 um: +1.30 % through-plane
    (1.5796e-12), +1.83 % in x, a cancellation of the field's error (the yarns' volume
    under-counted, K +5.9 % at 7a43228) and the lattice's (-4.3 % on the 0.5 um field at 2
    um)."""
    assert abs(_random_pair(kind, direction, "periodic")) <= AGREE


@pytest.mark.slow
def test_periodic_faces_of_bent_seed_3_match_and_agree():
    """The periodic bent RVE of seed 3, whose FEM periodic mesh used to fail ("the triangles of
    face x1 differ from those of face x0": a flat clipped tet next to a face was dropped on one
    face of the pair only); the mesher now makes the faces match by construction
    (docs/permeability.md, "Periodic"), and the two routes agree through-plane: K fem
    6.6785e-12, voxel 6.7849e-12, -1.57 % (agree17, 2026-12-03, load 5-6; -1.43 % before the
    sub-voxel fix 6fe9f8d, voxel 6.7755e-12)."""
    assert abs(_random_pair("bent", "z", "periodic", seed=3)) <= AGREE


#: The shipped woven spec: the plain-weave cell of Eq. (19) at period 100 um (yarns 14 um thick),
#: 3 layers per period, 100 um cube, voxel 1 um.
WOVEN_SPEC = Path(__file__).resolve().parents[2] / "studies" / "table3" / "woven.toml"


def woven_stack_spec(voxel: float = 1e-6) -> dict:
    """``studies/table3/woven.toml`` as shipped (``voxel`` aside), through the thickness in a
    permeameter stacked two copies deep (6 layers), slip sides."""
    shipped = load_spec(WOVEN_SPEC)
    rve = {k: v for k, v in shipped["rve"].items() if v is not None} | {"voxel": voxel}
    flow = {"viscosity": MU, "bc": "permeameter", "aux_length": 0.2, "sides": "slip"} | {
        "permeameter_copies": 2
    }
    return validate_spec({"rve": rve, "fibers": shipped["fibers"], "flow": flow})


@pytest.mark.slow
def test_woven_stack_fem_and_voxel_agree():
    """The shipped woven spec stacked through the thickness with slip sides: FEM at its default
    lattice step (3.33 um: 4.3 steps across a yarn) and voxel route (14 voxels across a yarn),
    both on the spec's 1 um field.

    Measured (s42-fixes, 2026-12-06 05:28-05:32, load 3-5, after 0d49c9d's woven diameter):
    stacked K FEM 5.9802e-12, voxel 5.8750e-12, fem/voxel - 1 = +1.79 % (slow16, main 8ab1e27,
    2026-12-03, before 0d49c9d: FEM 5.9745e-12, +1.69 %; 2026-12-01, before the sub-voxel fix
    6fe9f8d: voxel 5.8661e-12, +1.85 %). Both are resolved (one copy, the same K to 0.05 %): the
    FEM moves -0.28 % from a 3.33 to a 2.5 um step and -0.48 % from the 1 to a 0.5 um field; the
    voxel route 6.0101e-12 / 5.8750e-12 / 5.8532e-12 at 2 / 1 / 0.5 um (observed order 2.6,
    limit about 5.849e-12), so the converged pair is +1.6 % apart (FEM on the 0.5 um field vs
    voxel at 0.5 um: +1.63 %; s42-paper, 2026-12-06). The periodic woven cell of
    :func:`periodic_spec` cannot be resolved by the FEM within the memory cap
    (docs/solver-agreement.md: yarns 4.2 um thick, about 2 lattice steps across at 2 um; on the
    0.5 um field the stacked FEM K moved +5.7 % from a 2 to a 1.5 um step and -0.83 % to 1.25
    um, +0.95 % against the voxel route there at 4.4 GB, not yet monotone; after 0d49c9d -1.06 %
    from 1.5 to 1.25 um, +0.54 % against the stacked voxel K at 0.5 um, 4.3 GB), so the stacked
    comparison is asserted on the shipped cell."""
    spec = woven_stack_spec()
    built = build_rve(spec)
    fields = built.voxelize(1e-6)
    fem, vox = _pair(built.rve, fields, "z", spec["flow"])
    assert fem["permeameter_copies"] == vox["permeameter_copies"] == 2
    assert fem["mesh_quality"]["lattice_step_m"] == pytest.approx(100e-6 / 30)
    assert abs(_report("woven (studies/table3/woven.toml) z stacked", fem, vox)) <= AGREE


@pytest.mark.slow
def test_woven_stack_same_field_agrees():
    """The periodic woven cell (:func:`periodic_spec`) stacked through the thickness with slip
    sides, both routes on the same 1 um field (FEM 1.6982e-12, voxel 1.7041e-12: -0.35 %, load
    9, 2026-12-01 18:20; at 7a43228 FEM 1.6983e-12, voxel 1.7089e-12: -0.62 %, load 3-4,
    23:56; since the woven diameter fix 0d49c9d FEM 1.6802e-12: -1.68 %, s42-fixes 2026-12-06).
    The stack, its seam and the windowed drop are the same in both (the windowed, plane-window and
    face drops agree to 1e-4 of the applied drop in each). Against
    the voxel route at 0.5 um (1.5597e-12) neither is resolved on this cell: the 1 um field
    carries the slip walls' and the thin yarns' sampling (docs/solver-agreement.md)."""
    from psdesign.flow.fem import _mesh
    from psdesign.flow.stack import stack_fields, stacked_flow

    spec = periodic_spec("woven", voxel=1e-6, flow={"bc": "permeameter", "sides": "slip"})
    built = build_rve(spec)
    fields = built.voxelize(1e-6)
    # the FEM meshes the 1 um field itself (its own field would be 0.5 um: psdesign.flow.fem_field)
    flow = stacked_flow(spec["flow"], 2)
    mesh = _mesh(built.rve, stack_fields(fields, 2, 2), "z", flow, "permeameter")
    fem = permeability_fem(built.rve, fields, "z", spec["flow"], mesh=mesh)
    vox = route_result(built.rve, fields, "z", spec["flow"], "voxel")
    assert fem["converged"] and vox["converged"]
    assert fem["bc"] == vox["bc"] == "permeameter"
    assert fem["permeameter_copies"] == vox["permeameter_copies"] == 2
    assert abs(_report("woven z stacked, same 1 um field", fem, vox)) <= AGREE


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["straight", "bent"])
def test_random_permeameter_fem_and_voxel_agree(kind):
    """The same RVEs through-plane between empty reservoirs with slip sides, stacked: these
    one-period RVEs are periodic along z, so both routes solve two copies (``permeameter_copies
    = "auto"``, psdesign.flow.stack; one copy: FEM 4.222e-12, voxel 4.314e-12, both 36 % below
    the periodic K, docs/permeability.md "Stacked permeameter")."""
    assert abs(_random_pair(kind, "z", "permeameter")) <= AGREE


#: The shipped three crossing rods (``studies/examples/three_rods.toml``: porosity 0.91, rods
#: 20 um across in a 100 um cube, periodic along z): the most open stacked spec, where the
#: permeameter's entrance disturbance reaches furthest into the window.
THREE_RODS_SPEC = Path(__file__).resolve().parents[2] / "studies" / "examples" / "three_rods.toml"


def three_rods_stack(copies: int, voxel: float = 2e-6):
    """The shipped three_rods RVE on a ``voxel`` grid and its ``[flow]`` as a permeameter of
    ``copies`` copies along z (slip sides); returns (built, fields, flow)."""
    spec = load_spec(THREE_RODS_SPEC)
    built = build_rve(spec)
    flow = {k: v for k, v in spec["flow"].items() if isinstance(v, (int, float, str))}
    flow |= {"bc": "permeameter", "permeameter_copies": copies}
    return built, built.voxelize(voxel), flow


@pytest.mark.slow
def test_three_rods_stack_converges_to_the_slip_column():
    """Voxel route, 2 um grid (10 voxels per rod): the stacked permeameter converges with its
    copies to the periodic K of the RVE mirrored across its side faces
    (:func:`psdesign.flow.stack.mirror_sides`: a slip wall is a mirror plane, so that is the
    endless slip-sided column), and the two-copy miss lies within the window term of the error
    bar that flags it.

    Measured (docs/solver-agreement.md, ``benchmarks/solver_agreement.py probe``, load 9-10,
    2026-12-02 04:05-04:20): mirrored K 1.6417e-10 (2 um) and 1.6322e-10 (1 um); the stack at
    2 um: 2 copies -3.93 % (window term 5.5 %), 3 copies +0.91 % (1.2 %); at 1 um: 2 copies
    -3.94 %, 3 +0.91 %, 4 -0.21 %, 6 +0.03 %."""
    from psdesign.flow.permeability import permeability
    from psdesign.flow.stack import mirror_sides

    built, fields, flow = three_rods_stack(6)
    periodic = {**flow, "bc": "periodic"}
    limit = route_result(built.rve, mirror_sides(fields, 2), "z", periodic, "voxel")
    six = route_result(built.rve, fields, "z", flow, "voxel")
    assert limit["converged"] and six["converged"]
    assert six["permeameter_copies"] == 6
    k_limit = limit["permeability_m2"]
    print(f"\nthree_rods 2 um: mirrored {k_limit:.5e}, 6 copies {six['permeability_m2']:.5e}")
    assert abs(six["permeability_m2"] / k_limit - 1) <= 0.005
    two = permeability(built.rve, fields, "z", {**flow, "permeameter_copies": 2}, "voxel")
    miss = two["permeability_m2"] / k_limit - 1
    print(f"2 copies {two['permeability_m2']:.5e} ({100 * miss:+.2f} %)")
    assert abs(miss) <= two["error_estimate"]["window"]


@pytest.mark.slow
def test_three_rods_longer_stack_fem_and_voxel_agree():
    """three_rods through the stack with 3 copies (the 'permeameter-longer' row of session 7;
    ``"auto"`` now takes 4: ``test_auto_copies_solve.py``), on the
    table's grid (2 um: 10 voxels per rod; FEM at its default 4 um step on that field): FEM
    1.6492e-10, voxel 1.6566e-10, -0.45 % (load 9, 2026-12-02 04:26-04:34, and as this test at
    load 6, 04:57-05:00, 171 s; on the spec's 1 um grid and field, FEM at 3.33 um: +0.13 %).
    With the 2 copies of ``"auto"`` the routes are -3.74 % apart: the entrance disturbance of
    this open RVE (porosity 0.91) still reaches the window there, and each route's reservoirs
    shape it differently (docs/solver-agreement.md;
    :func:`test_three_rods_stack_converges_to_the_slip_column`)."""
    built, fields, flow = three_rods_stack(3)
    fem, vox = _pair(built.rve, fields, "z", flow)
    assert fem["permeameter_copies"] == vox["permeameter_copies"] == 3
    assert abs(_report("three_rods z stacked, 3 copies", fem, vox)) <= AGREE


#: The shipped REV spec of the Toray-like paper (``studies/rev_toray.toml``: straight 7 um fibers,
#: porosity 0.8, tilts within +-5 deg) as the solver-agreement table builds it: 60 um cube, voxel
#: 60 / 72 um (8.4 voxels per diameter; the 50 um cube misses the porosity target).
REV_TORAY_SPEC = Path(__file__).resolve().parents[2] / "studies" / "rev_toray.toml"


@pytest.mark.slow
def test_rev_toray_one_copy_fem_and_voxel_agree_resolved():
    """A random RVE, one copy (``permeameter_copies = 1``: the permeameter K of this sample,
    entrance layers included), slip sides, through the thickness, both routes resolved: voxel
    route at 0.5 um (14 voxels per diameter), FEM at a 1.67 um step on the build's 0.833 um
    field. Its z end planes are 0.46 um apart (0.77 % of L): since session 19 (seam19) that is
    periodic enough to stack and ``"auto"`` takes two copies at every voxel (K 10 % lower); the
    one copy is asked for here, the sample this pair was measured on.

    Measured (agree18, docs/solver-agreement.md 'rev_toray', load 5-7, 2026-12-03 13:44-14:20):
    FEM 6.0099e-12, voxel 6.0354e-12, fem/voxel - 1 = -0.42 %. At the table's resolution (voxel
    0.833 um, FEM at its default 2 um step) -2.08 %: the voxel route is +1.8 % above its limit
    there (6.1094 / 6.0580 / 6.0354e-12 at 0.833 / 0.625 / 0.5 um, observed order 2.2, limit
    about 5.9997e-12), the FEM moves +0.46 / +0.05 / +0.15 % from 2 to 1.67, 1.43 and 1.25 um."""
    spec = load_spec(REV_TORAY_SPEC)
    rve = {**spec["rve"], "size": [60e-6] * 3, "voxel": 60e-6 / 72}
    flow = {k: v for k, v in spec["flow"].items() if isinstance(v, (int, float, str))}
    flow |= {"bc": "permeameter", "aux_length": 0.2, "sides": "slip", "permeameter_copies": 1}
    spec = validate_spec({**spec, "rve": rve, "flow": flow})
    built = build_rve(spec)
    fields = built.voxelize(60e-6 / 72)
    assert abs(fields.porosity - 0.80021) < 1e-4  # the table's RVE (its build record)
    fem = route_result(built.rve, fields, "z", {**flow, "lattice_step": 60e-6 / 36}, "fem")
    vox = route_result(built.rve, built.voxelize(5e-7), "z", flow, "voxel")
    for r in (fem, vox):
        assert r["converged"], r
        assert r["permeameter_copies"] == 1 and r["geometry_periodic_along_flow"]
    assert abs(_report("rev_toray z one copy, resolved", fem, vox)) <= AGREE
