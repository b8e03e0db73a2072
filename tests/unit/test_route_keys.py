"""Keys the schema accepted but no code (or only one route) read: each is now honoured, refused
up front (exit 2, one line naming the key) or warned about (session 32's key audit)."""

from __future__ import annotations

import textwrap

import pytest

from psdesign.cli import main
from psdesign.errors import SpecError
from psdesign.flow.permeability import check_route_keys, permeability
from psdesign.packing.build import build_rve
from psdesign.schema.spec import validate_spec
from psdesign.study.studyfile import StudyError, load_study

RVE = {"size": [40e-6] * 3, "voxel": 2e-6}
GEN = {"n_fibers": 6, "diameter": 8e-6, "seed": 1}
# one straight fibre along z through a 20 um cube: a periodic voxel solve in about a second
ROD = {
    "rve": {"size": [20e-6] * 3, "voxel": 1e-6},
    "fibers": [{"shape": "cylinder", "diameter": 8e-6, "direction": [0, 0, 1]}],
}


def _key(spec: dict) -> str:
    with pytest.raises(SpecError) as exc:
        validate_spec(spec)
    return exc.value.key


# ------------------------------------------------------------------ [intersections]
@pytest.mark.parametrize(
    ("method", "key", "value"),
    [
        ("ga", "min_gap", 3e-6),  # the GA placed the fibres as without it, reporting 3e-6
        ("none", "min_gap", 1e-6),
        ("fast", "time_limit_s", 5.0),  # the fast placement has no time limit
        ("fast", "population", 8),
        ("none", "max_shift", 1e-6),
        ("ga", "exceed_bounds", False),
    ],
)
def test_intersection_key_of_another_method_is_refused(method, key, value):
    spec = {"rve": RVE, "generator": GEN, "intersections": {"method": method, key: value}}
    assert _key(spec) == f"intersections.{key}"


def test_intersection_keys_of_the_method_and_a_zero_gap_are_accepted():
    for inter in (
        {"method": "ga", "min_gap": 0.0, "population": 4, "shift_range": 0.2},
        {"method": "fast", "min_gap": 1e-6, "max_shift": 2e-6},
    ):
        validate_spec({"rve": RVE, "generator": GEN, "intersections": inter})


def test_intersections_without_a_generator_is_refused():
    # explicit [[fibers]] are placed as given: a fast min_gap there moved nothing
    spec = {**ROD, "intersections": {"method": "fast", "min_gap": 1e-6}}
    assert _key(spec) == "intersections"


def test_generate_exits_2_on_a_ga_min_gap(tmp_path, capsys):
    spec = tmp_path / "ga.toml"
    spec.write_text(
        textwrap.dedent(
            """
            [rve]
            size = [40e-6, 40e-6, 40e-6]
            voxel = 2e-6
            [generator]
            n_fibers = 6
            diameter = 8e-6
            [intersections]
            method = "ga"
            min_gap = 3e-6
            """
        )
    )
    assert main(["generate", str(spec), "-o", str(tmp_path / "out"), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        "psdesign: error: intersections.min_gap: only used with intersections.method = 'fast' "
        "(allowed: intersections.method = 'fast')"
    ]
    assert not (tmp_path / "out").exists()


# ------------------------------------------------------------------ flow.periodic_treatment
def test_mirror_with_the_voxel_permeameter_is_refused_by_the_schema():
    flow = {"solver": "voxel", "bc": "permeameter", "periodic_treatment": "mirror"}
    assert _key({**ROD, "flow": flow}) == "flow.periodic_treatment"


@pytest.mark.parametrize(
    "route",
    [{"solver": "fem"}, {"bc": "permeameter"}, {"solver": "fem", "bc": "periodic"}],
)
def test_schema_and_route_refuse_the_same_named_routes(route):
    """One rule (``schema.flow.treatment_refusal``): a spec naming a route that ignores the
    treatment is refused at load as the route refuses it at the solve (the schema let
    ``solver = "fem"`` with ``mirror`` through before, and the route refused it later)."""
    flow = {**route, "periodic_treatment": "mirror"}
    assert _key({**ROD, "flow": flow}) == "flow.periodic_treatment"
    with pytest.raises(SpecError, match="voxel solver's periodic bc only"):
        check_route_keys(flow, route.get("solver", "fem"))


@pytest.mark.parametrize("route", [{}, {"solver": "voxel"}, {"bc": "periodic", "solver": "voxel"}])
def test_schema_leaves_an_unnamed_or_fitting_route_to_the_command_line(route):
    """Without ``solver`` / ``bc`` the spec's treatment is for ``--solver voxel``."""
    validate_spec({**ROD, "flow": {**route, "periodic_treatment": "frame"}})


@pytest.mark.parametrize(
    ("solver", "bc"), [("fem", None), ("fem", "periodic"), ("voxel", "permeameter")]
)
def test_mirror_off_the_voxel_periodic_solve_is_refused_by_the_route(solver, bc):
    flow = {"periodic_treatment": "frame", **({"bc": bc} if bc else {})}
    with pytest.raises(SpecError, match="voxel solver's periodic bc only"):
        check_route_keys(flow, solver)
    check_route_keys({"periodic_treatment": "frame"}, "voxel")  # its own route


def test_permeability_refuses_mirror_with_the_fem_before_the_build(tmp_path, capsys, monkeypatch):
    spec = tmp_path / "m.toml"
    spec.write_text(
        '[rve]\nsize = [20e-6, 20e-6, 20e-6]\nvoxel = 1e-6\n[[fibers]]\nshape = "cylinder"\n'
        'diameter = 8e-6\ndirection = [0, 0, 1]\n[flow]\nperiodic_treatment = "mirror"\n'
    )
    built = []
    monkeypatch.setattr("psdesign.packing.build.build_rve", lambda s: built.append(s))
    assert main(["permeability", str(spec), "--quiet"]) == 2
    assert "flow.periodic_treatment: 'mirror' applies to the voxel solver's periodic bc only" in (
        capsys.readouterr().err
    )
    assert built == []
    for extra in (
        ["--solver", "voxel", "--bc", "permeameter"],
        ["--solver", "voxel", "--bc", "both"],
    ):
        assert main(["permeability", str(spec), "--quiet", *extra]) == 2
    assert built == []


# ------------------------------------------------------------------ permeameter keys, periodic bc
def test_sides_on_the_command_line_with_a_periodic_solve_exits_2(tmp_path, capsys):
    spec = tmp_path / "p.toml"
    spec.write_text(
        '[rve]\nsize = [20e-6, 20e-6, 20e-6]\nvoxel = 1e-6\n[[fibers]]\nshape = "cylinder"\n'
        'diameter = 8e-6\ndirection = [0, 0, 1]\n[flow]\nsolver = "voxel"\n'
    )
    assert main(["permeability", str(spec), "--sides", "noslip", "--quiet"]) == 2
    assert capsys.readouterr().err.startswith(
        "psdesign: error: --sides: the periodic bc (solver 'voxel') has no side walls"
    )


def test_permeameter_keys_on_a_periodic_solve_warn_and_change_nothing():
    spec = validate_spec({**ROD, "flow": {"solver": "voxel", "error_estimate": False}})
    built = build_rve(spec)
    fields = built.voxelize(spec["rve"]["voxel"])
    plain = permeability(built.rve, fields, "x", spec["flow"])
    flow = {**spec["flow"], "sides": "noslip", "aux_length": 0.5}
    walled = permeability(built.rve, fields, "x", flow)
    assert walled["bc"] == "periodic"
    assert walled["permeability_m2"] == plain["permeability_m2"] > 1e-13
    note = (
        "flow.sides = 'noslip', flow.aux_length = 0.5 are not used: the periodic bc has no side "
        "walls, reservoirs or stacked copies (it applies to bc = 'permeameter')"
    )
    assert note in walled["warnings"]
    assert not any("not used" in w for w in plain["warnings"])


# ------------------------------------------------------------------ studies
STUDY = """
[base]
rve = {{ size = [20e-6, 20e-6, 20e-6], voxel = 1e-6 }}
fibers = [{{ shape = "cylinder", diameter = 8e-6, direction = [0, 0, 1] }}]
flow = {{ solver = "voxel", direction = "x" }}
[study]
name = "t"
{study}
[parameters]
{param}
"""


def _study(tmp_path, param: str, study: str = ""):
    path = tmp_path / "s.toml"
    path.write_text(STUDY.format(param=param, study=study))
    return load_study(path)


@pytest.mark.parametrize("path", ["flow.direction", "flow.solver"])
def test_study_refuses_a_parameter_no_case_reads(tmp_path, path):
    # a flow.direction = ["x", "z"] study solved K_z in both cases (8.19e-11 twice)
    levels = '["x", "z"]' if path == "flow.direction" else '["fem", "voxel"]'
    with pytest.raises(StudyError, match=f"parameters.{path}: not a study parameter"):
        _study(tmp_path, f'"{path}" = {levels}')


def test_study_outputs_default_to_the_base_flow_direction(tmp_path):
    assert _study(tmp_path, '"flow.viscosity" = [1e-5, 2e-5]').outputs == ["porosity", "k_x"]
    given = _study(tmp_path, '"flow.viscosity" = [1e-5, 2e-5]', 'outputs = ["k_z"]')
    assert given.outputs == ["k_z"]


def test_study_refuses_mirror_with_a_fem_study(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(
        STUDY.format(param='"flow.viscosity" = [1e-5, 2e-5]', study='solver = "fem"').replace(
            'direction = "x"', 'periodic_treatment = "mirror"'
        )
    )
    with pytest.raises(StudyError, match="flow.periodic_treatment"):
        load_study(path)
