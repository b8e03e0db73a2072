"""``psdesign warmup`` compiles every force-field kernel that Python code calls
(``psdesign.warmup._forcefield``).

A kernel the warm-up does not call compiles on the user's first relaxation instead (session 8:
the suite's first force-field test took 27.7 s after a warm-up without this step, 6.9 s the
second time; session 9: after a warm-up with it on an empty cache, the two force-field test
files take 27.4 s, as on a second run, 27.1 s), so each entry kernel of the force-field
modules must hold a compiled signature after the warm-up's force-field step. Kernels called
only from other kernels (``psi_point``, ``_split_tables``, ``_solve4``) are compiled into
their callers.
"""

from __future__ import annotations

from psdesign import warmup
from psdesign.forcefield import fields, kernels, potentials

ENTRY_KERNELS = {
    fields: ("_derivs_kernel", "_value_kernel"),
    kernels: (
        "section_centres",
        "section_roots",
        "fill_tables",
        "pair_max_grid",
        "lens_candidates",
        "lens_minima",
        "deepest_point",
    ),
    potentials: ("_curvatures",),
}


def test_forcefield_step_compiles_every_entry_kernel():
    warmup._forcefield()
    missed = [
        f"{module.__name__}.{name}"
        for module, names in ENTRY_KERNELS.items()
        for name in names
        if not getattr(module, name).signatures
    ]
    assert not missed, f"kernels the warm-up leaves uncompiled: {missed}"
