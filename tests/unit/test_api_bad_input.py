"""Bad input found past the spec reaches the Python API as a ``SpecError``.

README: "``except psdesign.SpecError`` catches any bad input". Session 42's walkthrough
(benchmarks/RESULTS.md, "a new user's walkthrough") found three plain ``ValueError``\\ s
through it, where the CLI exits 2 with their line: the mesher's ``PoreTopologyError``, the
voxel solver's ``NoFluidPathError`` and the FEM's ``PeriodicMeshError``. Each now is a
``SpecError`` with the key its line names, the same line, the original as ``__cause__``.
"""

from __future__ import annotations

import numpy as np
import pytest

import psdesign

L = 20e-6
#: a square array across at solid fraction 0.75: gap L - D = 0.46 um, under the 1 um voxel
SQUARE_075 = {
    "rve": {"size": [L, L, L], "voxel": 1e-6},
    "fibers": [
        {
            "shape": "cylinder",
            "diameter": float(2 * L * np.sqrt(0.75 / np.pi)),
            "center": [1e-5, 1e-5, 1e-5],
            "direction": [0, 0, 1],
        }
    ],
}
#: the reviewer's square array across at solid fraction 0.05 (session 52, walk-numbers finding
#: 1): L = 40 um, D = 10.09 um, 4 um voxels, so the default lattice step is 2 voxels = 8 um; its
#: vertices nearest the axis, (16 or 24, 16 or 24) um, lie 4 sqrt(2) = 5.66 um from it, outside
#: the 5.05 um radius: no vertex inside the fiber (plane geometry)
SQUARE_005 = {
    "rve": {"size": [4e-5, 4e-5, 1.6e-5], "voxel": 4e-6},
    "fibers": [
        {
            "shape": "cylinder",
            "diameter": float(2 * 4e-5 * np.sqrt(0.05 / np.pi)),
            "center": [2e-5, 2e-5, 8e-6],
            "direction": [0, 0, 1],
        }
    ],
}
#: one fiber tilted across the box: its opposite faces differ (not periodic)
TILTED = {
    "rve": {"size": [L, L, L], "voxel": 1e-6},
    "fibers": [
        {
            "shape": "cylinder",
            "diameter": 5e-6,
            "center": [1e-5, 1e-5, 1e-5],
            "direction": [0.4, 0.2, 1],
        }
    ],
}


def _channel_image(tmp_path):
    """Pore only in a channel along y: no path along x."""
    a = np.ones((8, 8, 8), np.uint8)
    a[3:5, :, 3:5] = 0
    np.save(tmp_path / "img.npy", a)
    return psdesign.from_image(tmp_path / "img.npy", voxel_size=1e-6)


@pytest.mark.filterwarnings("ignore")
@pytest.mark.parametrize(
    ("make", "call", "key", "cause", "line"),
    [
        (
            lambda _: psdesign.build(SQUARE_075),
            lambda m: m.permeability("x", solver="fem"),
            "rve.voxel",
            "PoreTopologyError",
            "rve.voxel: disconnected pore space",
        ),
        (
            _channel_image,
            lambda m: m.permeability("x", solver="voxel"),
            "image",
            "NoFluidPathError",
            "image: the pore space has no path along x",
        ),
        (
            lambda _: psdesign.build(TILTED),
            lambda m: m.permeability("z", solver="fem", bc="periodic"),
            "flow.bc",
            "PeriodicMeshError",
            "flow.bc = 'periodic': the geometry is not periodic",
        ),
        (  # a volume match divided by a zero wall area: rve.voxel, "pore space is empty"
            lambda _: psdesign.build(SQUARE_005),
            lambda m: m.permeability("x", solver="fem", bc="periodic"),
            "flow.lattice_step",
            "PoreTopologyError",
            "flow.lattice_step: the lattice step 8e-06 m leaves no lattice vertex inside any fiber",
        ),
    ],
)
def test_bad_input_past_the_spec_is_a_spec_error_naming_its_key(
    tmp_path, make, call, key, cause, line
):
    material = make(tmp_path)
    with pytest.raises(psdesign.SpecError) as info:
        call(material)
    err = info.value
    assert err.key == key
    assert str(err).startswith(line)  # the line the CLI prints (exit 2)
    assert type(err.__cause__).__name__ == cause
    assert str(err) == str(err.__cause__)


def test_other_errors_are_left_as_they_are():
    from psdesign.errors import as_spec_error
    from psdesign.meshing.errors import MeshFailedError, PoreTopologyError

    assert as_spec_error(MeshFailedError("pore volume exceeds the box volume")) is None
    err = as_spec_error(PoreTopologyError("the pore space is empty: `distance` is <= 0"))
    assert (err.key, str(err)) == ("rve.voxel", "the pore space is empty: `distance` is <= 0")


def _rve_or_fields_parameters():
    """(name, function, parameter) of every function of ``psdesign.__all__`` with an
    :class:`RVE` or :class:`VoxelFields` parameter (by its annotation)."""
    import inspect

    out = []
    for name in psdesign.__all__:
        fn = getattr(psdesign, name)
        if inspect.isfunction(fn):
            for p in inspect.signature(fn).parameters.values():
                if any(t in str(p.annotation) for t in ("RVE", "VoxelFields")):
                    out.append((name, fn, p.name))
    return out


@pytest.mark.parametrize("bad", [3, "x", None])
def test_public_functions_refuse_what_is_no_rve_or_fields_naming_the_parameter(bad):
    """Session 47 re-read: ``psdesign.permeability(3, ...)`` raised ``AttributeError: 'int'
    object has no attribute 'fibers'`` (``fields=3``: ``... 'grid'``) and ``psdesign.Material(3)``
    ``TypeError: argument of type 'int' is not iterable``. Walking ``psdesign.__all__`` with a
    wrong-typed first argument (3, "x", None; benchmarks/RESULTS.md, session 48) found 6 such
    tracebacks in 45 calls; now each is one SpecError line naming the parameter
    (``geometry.rve.checked_rve`` / ``checked_fields``), before any work; ``RVE(size)`` too."""
    m = psdesign.build(SQUARE_075)
    good = {"rve": m.rve, "fields": m.fields, "direction": "z", "flow": m.spec["flow"]}
    walked = _rve_or_fields_parameters()
    assert {(name, p) for name, _, p in walked} >= {
        ("permeability", "rve"),
        ("permeability", "fields"),
    }
    for name, fn, param in walked:
        with pytest.raises(psdesign.SpecError) as info:
            fn(**{**good, param: bad})
        assert info.value.key == param and "\n" not in str(info.value), (name, str(info.value))
    with pytest.raises(psdesign.SpecError) as info:
        psdesign.Material(bad)
    assert str(info.value).startswith("spec: must be a validated spec (a dict: psdesign.build")
    # psdesign.RVE(3): NumPy's "cannot reshape array of size 1 into shape (3,)" (a ValueError
    # naming no parameter, which `except psdesign.SpecError` missed) until session 48
    with pytest.raises(psdesign.SpecError) as info:
        psdesign.RVE(bad)
    assert str(info.value) == f"size: must be three positive lengths in metres, got {bad!r}"


@pytest.mark.parametrize("bad", [3, "x", None, [("bc", "periodic")]])
def test_permeability_refuses_a_flow_that_is_no_table_naming_flow(bad):
    """Review s48: ``psdesign.permeability(rve, fields, "z", flow=3)`` raised
    ``AttributeError: 'int' object has no attribute 'get'`` where docs/permeability.md says a
    wrong type is refused in one line; now one SpecError naming ``flow``, before any work
    (``flow.permeability.checked_flow``, the twin of ``checked_rve``)."""
    from psdesign.flow.compare import permeability_both_bc

    m = psdesign.build(SQUARE_075)
    for fn in (psdesign.permeability, permeability_both_bc):  # --bc both read it first
        with pytest.raises(psdesign.SpecError) as info:
            fn(m.rve, m.fields, "z", flow=bad)
        assert info.value.key == "flow"
        assert str(info.value) == (
            "flow: must be a table (a dict: the spec's [flow], "
            f"psdesign.build(spec).spec['flow']), got {bad!r}"
        )


def test_permeability_takes_a_flow_of_some_keys_and_refuses_a_bad_one():
    """Session 49 (new user's walk): ``psdesign.permeability(rve, fields, "z", {"solver":
    "voxel"})`` raised ``KeyError: 'viscosity'`` (the route read keys only a validated spec's
    table holds), and ``{"viscosity": "x"}`` failed inside the solve. The table is now checked
    as a spec file's [flow] is, its missing keys taken at their defaults: the same K as the
    spec's full table, bit for bit (a fibre along z in a 20 um box, voxel periodic, no second
    resolution), and one SpecError line naming ``flow.<key>`` and its range otherwise."""
    from psdesign.schema.flow import DEFAULT_FLOW

    m = psdesign.build(SQUARE_075)
    assert m.spec["flow"] == {**DEFAULT_FLOW, **m.spec["flow"]}  # the full table
    some = psdesign.permeability(m.rve, m.fields, "z", {"solver": "voxel"}, "voxel", None, False)
    full = psdesign.permeability(m.rve, m.fields, "z", m.spec["flow"], "voxel", None, False)
    assert some["permeability_m2"] == full["permeability_m2"] > 0
    for flow, key in (
        ({"viscosity": "x"}, "flow.viscosity"),
        ({"viscosty": 1e-5}, "flow.viscosty"),
    ):
        with pytest.raises(psdesign.SpecError) as info:
            psdesign.permeability(m.rve, m.fields, "z", flow, "voxel", None, False)
        assert info.value.key == key and "\n" not in str(info.value), str(info.value)
        assert str(info.value).startswith(f"{key}: ")


@pytest.mark.parametrize("bad", ["abc", 0, -1e-6, float("nan"), float("inf"), True, [L]])
def test_rve_refuses_a_period_that_is_no_positive_length_naming_period(bad):
    """Review s48: ``psdesign.RVE(size, period="abc")`` raised NumPy's ``TypeError``
    ("ufunc 'isfinite' not supported") and ``period=0`` a ``ValueError`` naming no key
    ("period must be positive"), which ``except psdesign.SpecError`` missed; ``size``'s
    pattern now: one SpecError line naming ``period``. A real number (an int, a NumPy
    scalar) is taken as metres, as a float."""
    with pytest.raises(psdesign.SpecError) as info:
        psdesign.RVE([L, L, L], period=bad)
    assert info.value.key == "period"
    assert str(info.value) == f"period: must be a positive length in metres, got {bad!r}"
    assert psdesign.RVE([L, L, L], period=np.float32(2 * L)).period == pytest.approx(2 * L)
    assert psdesign.RVE([L, L, L]).period == L


def test_permeability_checks_flow_with_the_solver_it_runs():
    """Review of session 49: the [flow] check read the table's own solver (a validated spec's
    default "fem"), not the ``solver`` argument the route runs, so a spec's
    ``periodic_treatment = "mirror"`` with ``solver="voxel"`` was refused naming solver 'fem'
    by ``permeability`` and ``permeability_both_bc`` (``--bc both``), which took it until
    b74d15a. Now the route's table is checked: the mirrored K is the periodic one (a centred
    cylinder is its own mirror image, docs/permeability.md), --bc both gives the periodic
    model's K and says the permeameter is n/a with the treatment's line; solver "fem" is
    refused with that line, naming the solver it runs."""
    from psdesign.flow.compare import permeability_both_bc

    spec = {**SQUARE_075, "fibers": [{**SQUARE_075["fibers"][0], "diameter": 8e-6}]}
    m = psdesign.build({**spec, "flow": {"periodic_treatment": "mirror"}})
    assert m.spec["flow"]["solver"] == "fem"  # the validated table's default
    periodic = {**m.spec["flow"], "periodic_treatment": "periodic"}
    k = psdesign.permeability(m.rve, m.fields, "z", periodic, "voxel", None, False)
    mirror = psdesign.permeability(m.rve, m.fields, "z", m.spec["flow"], "voxel", None, False)
    assert mirror["converged"] and mirror["permeability_m2"] == pytest.approx(
        k["permeability_m2"], rel=1e-6
    )
    both = permeability_both_bc(m.rve, m.fields, "z", m.spec["flow"], "voxel", None, False)
    assert both["bc_results"]["periodic"]["permeability_m2"] == mirror["permeability_m2"]
    assert both["bc_results"]["permeameter"].startswith("n/a: flow.periodic_treatment: 'mirror'")
    with pytest.raises(psdesign.SpecError) as info:
        psdesign.permeability(m.rve, m.fields, "z", m.spec["flow"], "fem", None, False)
    assert info.value.key == "flow.periodic_treatment" and "solver 'fem'" in str(info.value)


@pytest.mark.filterwarnings("ignore")
@pytest.mark.parametrize("thin", [2, 3])
def test_permeability_refuses_hand_built_fields_under_4_voxels_an_axis(thin):
    """Session 49 note: a spec's ``rve.voxel`` over a quarter of the smallest edge is refused
    (docs/spec-keys.md), an image under 4 voxels an axis too (``image.path``), but fields built
    by hand (``image_fields``) 16 x 16 x 2-3 voxels varying along their thin axis were solved
    and rated, K with a bar of the resolution floor alone (no second resolution could be
    solved). Now one SpecError line naming ``fields`` and the allowed range, before any work
    (``psdesign.permeability`` and ``--bc both``'s ``permeability_both_bc``); 4 voxels is
    solved, K the plane Poiseuille closed form ``g^3 / (12 H)`` (Bird, Stewart & Lightfoot,
    Sec. 2.2) within its bar."""
    from psdesign.flow.compare import permeability_both_bc

    h, flow = 1e-6, {"solver": "voxel", "bc": "periodic"}
    for fn in (psdesign.permeability, permeability_both_bc):
        with pytest.raises(psdesign.SpecError) as info:
            fn(*_slit(thin, post=True), "x", flow, "voxel", None, False)
        assert info.value.key == "fields" and "\n" not in str(info.value)
        assert str(info.value) == (
            f"fields: the voxel grid is [16, 16, {thin}] voxels (allowed: at least 4 voxels "
            "per axis the geometry varies along, as a spec's rve.voxel <= a quarter of the "
            "smallest edge)"
        )
    k = psdesign.permeability(*_slit(4, post=False), "x", flow, "voxel", None, True)
    exact = (13 * h) ** 3 / (12 * 16 * h)  # the slit's flow over the whole 16-voxel period
    assert k["converged"] and abs(k["permeability_m2"] / exact - 1) <= k["permeability_rel_error"]
    # 4 voxels along an axis the geometry varies along is allowed (the rule is "at least 4")
    k = psdesign.permeability(*_slit(4, post=True), "x", flow, "voxel", None, False)
    assert k["converged"] and 0.5 < k["permeability_m2"] / exact < 1.0  # the post slows it (0.75)


def _slit(nz: int, post: bool):
    """``(rve, fields)`` of a slit along x, 13 voxels open between walls 3 voxels thick, 16 x
    16 x ``nz`` voxels of 1 um; ``post``: one solid voxel at z = 0 in it (the geometry varies
    along z)."""
    from psdesign.image.fields import image_fields

    h = 1e-6
    solid = np.zeros((16, 16, nz), bool)
    solid[:, :3, :] = True
    solid[8, 8, 0] = post
    return psdesign.RVE(np.array(solid.shape) * h), image_fields(solid, h)


@pytest.mark.filterwarnings("ignore")
@pytest.mark.parametrize("thin", [1, 2])
def test_permeability_solves_an_extruded_field_under_4_voxels_an_axis(thin):
    """A field the same along its thin axis (quasi-2-D; one voxel along an axis always is) is
    an exact extrusion: solved, not refused (the rule refuses only an axis the geometry varies
    along). K of the slit is the plane Poiseuille closed form ``g^3 / (12 H)`` (Bird, Stewart &
    Lightfoot, Sec. 2.2) within its bar, the same K as 4 voxels thick to 1e-6."""
    h, flow = 1e-6, {"solver": "voxel", "bc": "periodic"}
    k = psdesign.permeability(*_slit(thin, post=False), "x", flow, "voxel", None, False)
    k4 = psdesign.permeability(*_slit(4, post=False), "x", flow, "voxel", None, False)
    exact = (13 * h) ** 3 / (12 * 16 * h)
    assert k["converged"] and abs(k["permeability_m2"] / exact - 1) <= k["permeability_rel_error"]
    assert k["permeability_m2"] == pytest.approx(k4["permeability_m2"], rel=1e-6)
