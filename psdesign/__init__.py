"""psdesign: design fibrous porous media with generalized periodic-surface (PS) models.

Public API (imported lazily, so ``import psdesign`` is fast)::

    spec = psdesign.load_spec("studies/table3/straight.toml")
    m = psdesign.build(spec)                  # Material: .rve, .fields, .porosity
    k = m.permeability("z", solver="voxel")   # PermeabilityResult
    m = psdesign.from_image("scan.tif", voxel_size=1e-6, solid_label=1)   # a CT image
    df = psdesign.run_study("studies/quickstart.toml", "out/q")

The stages of the data flow are subpackages: ``schema`` (spec files) -> ``geometry`` (PS models,
fibers, RVE, voxel fields) -> ``packing`` (random fiber sets, intersection removal) ->
``meshing`` -> ``flow`` (permeability) -> ``study`` -> ``report``; ``cli`` is the command line.
"""

from __future__ import annotations

import importlib

import solvers  # noqa: F401  (its import sets the process's thread policies, solvers/__init__.py)

__version__ = "0.1.0"

_LAZY = {
    "build": "psdesign.api",
    "from_image": "psdesign.api",
    "load_spec": "psdesign.api",
    "run_study": "psdesign.api",
    "RunOptions": "psdesign.study",
    "Material": "psdesign.api",
    "PermeabilityResult": "psdesign.api",
    "validate_spec": "psdesign.schema.spec",
    "SpecError": "psdesign.errors",
    "StudyError": "psdesign.study",
    "OutputError": "psdesign.io.outputs",
    "FlaggedCasesWarning": "psdesign.analysis.columns",  # README names it bare (session 54)
    "RVE": "psdesign.geometry.rve",
    "GeneralizedPS": "psdesign.geometry.model",
    "make_fiber": "psdesign.geometry.fibers",
    "load_study": "psdesign.study",
    "expand_design": "psdesign.study",
    "write_report": "psdesign.study",
    "permeability": "psdesign.flow.permeability",
    "mesh_pore_space": "psdesign.meshing.pore_mesh",
}

__all__ = sorted(_LAZY)


def __getattr__(name: str):
    if name in _LAZY:
        return getattr(importlib.import_module(_LAZY[name]), name)
    raise AttributeError(f"module 'psdesign' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted([*__all__, "__version__"])
