"""One spelling of a solve's value: the command lines (``permeability``, ``diffusivity``,
``conductivity``) and the field pictures' titles (``psdesign.fields.writer.result_words``)
start with ``psdesign.lines.value_text`` (session 49's review: four copies of the formats).
"""

from __future__ import annotations

import pytest

from psdesign.cli import permeability as perm
from psdesign.fields.writer import result_words
from psdesign.transport import conductivity, diffusivity

BASE = {"direction": "y", "status": "untrustworthy", "converged": True, "porosity": 0.8}
CASES = [
    (
        "voxel_flow",
        perm._line,
        {
            "permeability_m2": 2.1678e-11,
            "permeability_rel_error": 0.086,
            "bc": "periodic",
            "solver": "voxel",
            "flux_imbalance": 1e-9,
        },
        "K_y = 2.1678e-11 m^2 +- 8.6 %",
    ),
    (
        "diffusivity",
        diffusivity.result_line,
        {"relative_diffusivity": 0.83491, "rel_error": 0.012, "tortuosity_factor": 0.958},
        "D_eff/D_y = 0.8349 +- 1.2 %",
    ),
    (
        "conductivity",
        conductivity.result_line,
        {
            "effective_conductivity": 0.0352154,
            "rel_error": None,
            "conductivity_unit": "W/(m K)",
            "solid_conductivity": 1.7,
            "fluid_conductivity": 0.026,
        },
        "sigma_eff_y = 0.035215 W/(m K)",
    ),
]


@pytest.mark.parametrize(("kind", "line", "extra", "text"), CASES, ids=[c[0] for c in CASES])
def test_the_command_line_and_the_picture_title_spell_the_value_alike(kind, line, extra, text):
    r = {**BASE, **extra}
    assert line(r).startswith(f"{text}  [untrustworthy]"), line(r)
    assert result_words(kind, "y", r) == f"{text}  [untrustworthy]"
    # the printed value reads back as the value to its printed digits
    key = next(iter(extra))  # each case's value first
    printed = float(text.split(" = ")[1].split()[0])
    assert printed == pytest.approx(r[key], rel=5e-5)
    assert result_words(kind, "y", {**r, key: None}) == ""
