"""The exit status agrees with the statuses the command printed (session 45 review).

Four branches met in session 45: one exit rule (:func:`psdesign.cli.exit_status.status_code`),
``--bc both`` printing the other model's K, the transport and pore commands' statuses. The
truth here is the rule itself read off the printed JSON: every ``status`` (and ``*_status``) a
command's ``--json`` prints, at any depth, is ``ok`` (or a search's ``converged`` /
``at_bound``) exactly when it exits 0; else it exits 3. Each case also pins the code it must
give on the one-cylinder RVE (closed forms: the 8 um cylinder along z in a 20 um cell does not
span x, so an insulating fluid blocks sigma_eff along x and y), so the test is not vacuous.
"""

from __future__ import annotations

import json

import pytest
from cylinder_spec import CYLINDER_SPEC as SPEC
from printed_statuses import printed_statuses

from psdesign.cli.exit_status import status_code
from psdesign.cli.main import main


@pytest.mark.parametrize(
    ("argv", "code"),
    [
        (["diffusivity", "--direction", "z"], 0),
        (["conductivity", "--direction", "all", "--insulating", "fluid", "--solid", "10"], 3),
        (["conductivity", "--direction", "z", "--insulating", "fluid", "--solid", "10"], 0),
        (["permeability", "--solver", "voxel", "--direction", "z", "--bc", "both"], 0),
        (["pores"], 0),
    ],
)
def test_the_exit_status_is_the_rule_applied_to_the_printed_statuses(tmp_path, capsys, argv, code):
    spec = tmp_path / "s.toml"
    spec.write_text(SPEC)
    got = main([argv[0], str(spec), *argv[1:], "--json", "--quiet"])
    out = json.loads(capsys.readouterr().out)
    printed = printed_statuses(out)
    assert printed, out  # every command prints its status
    assert got == status_code(*printed), (got, printed)
    if code is not None:
        assert got == code, printed


@pytest.mark.parametrize(("y", "code"), [("13.3e-6", 0), ("17.6e-6", 3)])
def test_generate_exits_by_both_statuses_it_prints(tmp_path, capsys, y, code):
    """``generate`` prints the porosity's and Omega's statuses (session 46) and exits by the
    rule on both. Two perpendicular 8 um cylinders in a 20 um cell at 1 um voxels: axes 3.3 um
    apart, a lens 4.7 um deep, the second axis off the voxel faces (Omega resolved, ``ok``);
    7.6 um apart, a lens 0.4 um deep that
    holds no voxel centre (Omega ``0 +- 0`` against the exact 2.45e-4: ``untrustworthy``)."""
    cyl = '\n[[fibers]]\nshape = "cylinder"\ndiameter = 8e-6\n'
    spec = tmp_path / "s.toml"
    spec.write_text(
        "[rve]\nsize = [20e-6, 20e-6, 20e-6]\nvoxel = 1e-6\n"
        + cyl
        + "center = [10e-6, 10e-6, 10e-6]\ndirection = [1, 0, 0]\n"
        + cyl
        + f"center = [10e-6, {y}, 10e-6]\ndirection = [0, 0, 1]\n"
    )
    got = main(["generate", str(spec), "-o", str(tmp_path / "out"), "--no-preview", "--quiet"])
    printed = printed_statuses(json.loads(capsys.readouterr().out))
    assert len(printed) == 2, printed  # the porosity's and Omega's
    assert got == status_code(*printed) == code, printed
