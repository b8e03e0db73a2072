"""The Python API (psdesign.build, Material, PermeabilityResult, run_study's main-guard check)."""

from __future__ import annotations

import math
import subprocess
import sys
import textwrap

import pytest

import psdesign
from psdesign.api import PermeabilityResult, _unguarded_call_in_main_script


def test_import_is_light() -> None:
    # a fresh interpreter: `import psdesign` pulls in none of the heavy stacks (issue 16 item 6)
    code = (
        "import sys, psdesign; heavy = [m for m in ('numba', 'scipy', 'pyvista', 'matplotlib',"
        " 'pandas', 'dask') if m in sys.modules]; print(heavy)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_cli_help_is_light() -> None:
    # `psdesign --help` (the console script's entry point) imports none of the heavy stacks
    code = (
        "import sys\nfrom psdesign.cli import main\ntry:\n    main(['--help'])\n"
        "except SystemExit:\n    pass\nheavy = [m for m in ('numba', 'scipy.stats', 'pyvista',"
        " 'matplotlib') if m in sys.modules]\nprint(heavy, file=sys.stderr)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert "usage" in out.stdout
    assert out.stderr.strip().splitlines()[-1] == "[]"


def test_build_porosity_matches_the_exact_cylinder_area() -> None:
    # one z-aligned circular cylinder of diameter 8 um in a 20 um box: porosity 1 - pi r^2 / A
    spec = {
        "rve": {"size": [20e-6, 20e-6, 20e-6], "voxel": 0.25e-6},
        "fibers": [{"shape": "cylinder", "diameter": 8e-6, "direction": [0, 0, 1]}],
    }
    m = psdesign.build(spec)
    exact = 1.0 - math.pi * 4e-6**2 / 20e-6**2
    assert m.porosity == pytest.approx(exact, abs=2e-3)
    assert "1 fibers" in repr(m)


def test_build_rejects_a_bad_spec_naming_the_key() -> None:
    with pytest.raises(psdesign.SpecError, match=r"rve\.size"):
        psdesign.build({"rve": {"size": [1, 2]}, "fibers": []})


def test_permeability_result_repr_and_html() -> None:
    d = {
        "direction": "z",
        "permeability_m2": 1.25e-12,
        "converged": False,
        "solver": "voxel",
        "bc": "periodic",
        "porosity": 0.8,
        "iterations": 3,
    }
    r = PermeabilityResult.from_dict(d)
    assert r.status == "not_converged" and r.details["iterations"] == 3
    assert "1.25e-12" in repr(r) and "details" not in repr(r)
    assert "1.2500e-12" in r._repr_html_()


@pytest.mark.parametrize(
    ("body", "unguarded"),
    [
        ("import psdesign\npsdesign.run_study('s.toml', 'out', workers=2)\n", True),
        ("from psdesign import run_study\ndf = run_study('s.toml', 'out')\n", True),
        ("import psdesign\nif __name__ == '__main__':\n    psdesign.run_study('s', 'o')\n", False),
        ("import psdesign\ndef main():\n    psdesign.run_study('s', 'o')\n", False),
    ],
)
def test_main_guard_detection(tmp_path, monkeypatch, body, unguarded) -> None:
    script = tmp_path / "script.py"
    script.write_text(textwrap.dedent(body))
    fake_main = type(sys)("__main__")
    fake_main.__file__ = str(script)
    monkeypatch.setitem(sys.modules, "__main__", fake_main)
    assert _unguarded_call_in_main_script("run_study") is unguarded


def test_unguarded_script_fails_with_one_line(tmp_path) -> None:
    script = tmp_path / "script.py"
    script.write_text("import psdesign\npsdesign.run_study('nope.toml', 'out', workers=2)\n")
    proc = subprocess.run(
        [sys.executable, str(script)], capture_output=True, text=True, cwd=tmp_path
    )
    assert proc.returncode != 0
    assert 'if __name__ == "__main__":' in proc.stderr
    assert not (tmp_path / "out").exists()


def test_permeability_result_html_marks_a_status_that_is_not_ok() -> None:
    d = {"direction": "x", "permeability_m2": 3e-12, "converged": True, "status": "untrustworthy"}
    d |= {"permeability_rel_error": 0.3, "warnings": ["error bar 30 % above the 20 % limit"]}
    page = PermeabilityResult.from_dict(d)._repr_html_()
    assert "background:#c00" in page and ">untrustworthy</span>" in page
    assert "&plusmn; 30 %" in page and "error bar 30 % above the 20 % limit" in page
    ok = PermeabilityResult.from_dict({**d, "status": "ok", "warnings": []})._repr_html_()
    assert "background:#c00" not in ok and ">ok</span>" in ok


def _transport_fields() -> dict:
    return {
        "direction": "z",
        "bc": "periodic",
        "porosity": 0.8,
        "converged": False,
        "residual": 1e-3,
        "iterations": 500,
        "flux_imbalance": 1e-3,
        "rel_error": 0.05,
        "error_method": "two-grid",
        "blocked": False,
        "message": "maximum iterations reached",
        "n_cells": 8000,
        "wall_time_s": 0.1,
    }


def test_transport_results_have_short_repr_and_html_with_units() -> None:
    from psdesign.transport.conductivity import ConductivityResult
    from psdesign.transport.diffusivity import DiffusivityResult

    column = [0.5] * 200  # one value per slice: kept out of the repr
    common = _transport_fields()
    dr = DiffusivityResult(
        relative_diffusivity=0.61,
        tortuosity_factor=1.31,
        relative_diffusivity_column=column,
        bulk_diffusivity_m2_s=2e-5,
        effective_diffusivity_m2_s=1.22e-5,
        **common,
    )
    assert len(repr(dr)) < 700 and "0.5, 0.5" not in repr(dr)
    assert dr.to_dict()["relative_diffusivity_column"] == column
    page = dr._repr_html_()
    assert dr.status == "not_converged" and ">not_converged</span>" in page
    assert "m<sup>2</sup>/s" in page and "1.2200e-05" in page and "&plusmn; 5 %" in page
    cr = ConductivityResult(
        effective_conductivity=12.0,
        conductivity_column=column,
        solid_conductivity=100.0,
        fluid_conductivity=0.03,
        insulating_phase="none",
        solid_fraction=0.2,
        wiener_bounds=[0.04, 20.0],
        hashin_shtrikman_bounds=[5.0, 14.0],
        **{**common, "converged": True, "message": "converged"},
    )
    assert len(repr(cr)) < 700 and "0.5, 0.5" not in repr(cr)
    page = cr._repr_html_()
    assert cr.status == "ok" and ">ok</span>" in page and "[5, 14]" in page
