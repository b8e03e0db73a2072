"""Generate ``docs/spec-keys.md``, the key tables of the RVE spec and the study file.

Run ``python -m psdesign.schema.docs > docs/spec-keys.md`` after changing the schema;
``tests/unit/test_consistency.py`` fails while the file and the schema disagree.
"""

from __future__ import annotations

import sys

from psdesign.schema.budget import (
    GEOMETRY_BYTES_PER_VOXEL,
    PROCESS_FIXED_BYTES,
    TRANSPORT_BYTES_PER_VOXEL,
    VOXEL_SOLVER_BYTES_PER_VOXEL,
)
from psdesign.schema.keys import key_rows, study_rows

HEADER = """# Spec and study keys

Generated from the schema (`psdesign/schema/`) by `python -m psdesign.schema.docs`; do not
edit by hand. Every key is validated before any work starts: a bad value ends with exit
status 2 and one line `psdesign: error: KEY: message (allowed: ...)`. Unknown keys and tables
are errors with a "did you mean". Lengths in metres, angles in degrees.

Cross-field checks (`psdesign/schema/document.py`, `psdesign/schema/budget.py`):

* `rve.voxel` <= a quarter of the smallest edge and <= half the thinnest fiber diameter
  (explicit fibers and the lower end of `generator.diameter`); the voxel grid's estimated
  memory (16 B per voxel, plus {B} B per solved cell with `flow.solver = "voxel"`, 2100 with
  `flow.wall_treatment = "diffuse"`) within half the machine's memory (psutil; in a study or
  `rev` with several local workers, each case within its worker's share). A permeameter
  (`flow.bc`, or the FEM's default) counts its stack: `flow.permeameter_copies` copies
  (`"auto"` counts the copies it will stack first where the spec tells: explicit fibers or an
  image along the direction solved (their analytic end planes, the image's voxel seam: the test
  the built RVE gets, 2 on a periodic one-period RVE, else 1; a spec checked alone, before a
  command or study names the direction, counts the fewest over the three axes: its
  `flow.direction` is a default the command line may override); else 2, its most for a first
  solve;
  a longer stack it takes after a window term above 1 % is checked before it is solved) plus two
  reservoirs of `flow.aux_length` times one copy; with `flow.solver = "fem"` the Taylor-Hood
  solve's own estimate (`solvers/fem/memory.py`) of the stuffing mesh (6.5 tets and 1.5
  vertices per lattice cell of pore, `generator.porosity`, the porosity of a stack `"auto"`
  planned (below), or 1) must fit too (without
  `flow.lattice_step` the default step, the thinnest fiber diameter / 3, is coarsened to fit,
  never beyond `max(2 rve.voxel, min(size) / 30)`, which alone decides the refusal); with
  `flow.mesher = "pytetwild"` the mesh counted is pytetwild's (55 tets per cube of its target
  edge in the meshed box at the default edge and envelope, 0.85 and 1 / 28 thinnest-fiber
  diameters; 30 with `flow.edge_length`, whose envelope is half the marching-cubes step, more
  for an edge coarser than 0.85 diameters; `psdesign/meshing/options.py`), refused naming
  `flow.edge_length`. A spec that fits
  as one copy but not as the stack names `flow.permeameter_copies`. With
  `flow.max_memory_gb` every route's estimate over 1.25 x the cap is refused naming it and the
  route's resolution key, before any work: the stuffing mesh's (`flow.lattice_step`); the
  pytetwild mesh's divided by 6 (its estimate is 1.03-4.5 x the meshes made;
  `flow.edge_length`); the voxel solve's (`rve.voxel`, or `image.crop`). Each counts the
  copies `"auto"` plans for explicit fibers or an image along the direction solved, as above
  (every command, study case and `Material.permeability` pins its directions before any
  work; the FEM counts a planned stack at the image's porosity, or at an upper bound of the
  fibers' sampled from their field at 50 000 points, not at 1), else one (a generated RVE
  stacks one when not periodic along the flow); there the
  stack `"auto"` plans is checked the same way once the RVE is built, before it is meshed or
  solved (at the RVE's porosity). The FEM solve checks the cap again from the built mesh.
* Each command is held to the memory of the work it does: `permeability` (and
  `Material.permeability`, a study with a `k_*` output) to its solve as above; `psdesign mesh`
  to the route's estimate of the one copy it meshes (`flow.permeameter_copies = 1`: the
  stack is `permeability`'s); `generate`, `forcefield`, `psdesign.build` and a study of
  porosity alone to the voxel grid's own fields; `pores`, `diffusivity`, `conductivity` (and
  their study outputs) to the transport solve's {T} B per voxel and {F} GB (session 53: `mesh`,
  `build` and a study without a K were refused for an FEM solve they never run).
* Each FEM mesher reads its own resolution key: `flow.lattice_step` (stuffing; its range is
  checked with `flow.mesher = "stuffing"`, which `psdesign mesh` also uses for a voxel spec)
  and `flow.edge_length` (pytetwild). The other mesher's key on an FEM solve is not used and
  the result warns so.
* `rve.period`: at most 1000 periodic copies of a fiber in the box, at most 100 x the largest
  edge.
* `fibers[i].diameter` < the smallest edge and the period; at most 2000 explicit fibers.
* `generator.diameter` within (0, period / 2); `generator.porosity` below the porosity of the
  box with one fiber of the smallest diameter and below `1 - porosity_tolerance` (an empty RVE
  is an error); above `1 - pi / sqrt(12)` (densest packing) when `intersections.method` is
  `fast` or `ga`; below 0.72 with `fast` a warning: zero-overlap placement of near-planar
  straight fibers jams at 0.69-0.72 in a 100 um cube (`studies/porosity_sweep.toml`).
* `generator.n_fibers` <= `generator.max_fibers`, and (fast/ga) the fibers' volume below the
  densest packing; the fiber count a porosity needs <= `max_fibers`.
* GA work `population x generations x fibers` <= 5e9.
* `[forcefield.relax]`: only in an RVE spec given to `psdesign forcefield` (then the only
  `[forcefield]` key); its keys and ranges are checked by
  `psdesign/forcefield/relax.py` (`check_relax_table`) and listed in docs/forcefield.md.
* `[image]` (docs/images.md): no `[[fibers]]`, `[generator]`, `[intersections]` or
  `[forcefield]`; `[rve]` optional, and if given its `size` and `voxel` equal the image's; the
  file, its size (raw), the crop and the voxel size checked, then (within the memory budget)
  the voxels read: at least one pore and one solid voxel, at least 4 voxels per axis;
  `flow.wall_treatment = "subvoxel"` or `"diffuse"` refused (no analytic surface).
* `flow.wall_treatment = "diffuse"` (voxel solver; docs/permeability.md, "Voxel walls"):
  `flow.bc` periodic, `flow.periodic_treatment` periodic, no `[forcefield]`, no `[generator]`;
  every `fibers[i].shape` a straight `cylinder` or `rod`; where a fiber's copies do not repeat
  with the box (edges not whole periods), every fiber along a box axis (`fibers[i].direction`).
  On the command line `--bc permeameter|both` and `--fields` are refused with it. After the
  build: overlapping fibers, or a fiber cut by a face the copies do not repeat across; at the
  solve, no fluid path along the direction (cells with eps >= 0.5, as the default voxel solver
  refuses a grid that does not percolate: the solve would return the leak through the walls);
  where the voxel grid has the gap open (a gap under about 2 voxels: the wall layers close
  it), the line names `rve.voxel` with the voxel that opens it, and the `subvoxel` wall.
* Studies: at most 1000 seeds, 10000 levels per parameter, 100000 cases; `n_samples` only
  with latin-hypercube / sobol; the base spec and every parameter level validated at load.
"""


def _table(title: str, rows: list[tuple[str, str, str]]) -> str:
    out = [f"## {title}", "", "| key | default | allowed |", "| --- | --- | --- |"]
    for key, default, allowed in rows:
        out.append(f"| `{key}` | {default.replace('|', '/')} | {allowed.replace('|', '/')} |")
    return "\n".join(out) + "\n"


def render() -> str:
    """The whole ``docs/spec-keys.md`` text."""
    # the figures from the constants the checks use: one definition (s54 review: 130 / 0.35)
    figures = {
        "{B}": str(VOXEL_SOLVER_BYTES_PER_VOXEL),
        "{T}": str(TRANSPORT_BYTES_PER_VOXEL + GEOMETRY_BYTES_PER_VOXEL),
        "{F}": f"{PROCESS_FIXED_BYTES / 1e9:g}",
    }
    header = HEADER
    for mark, value in figures.items():
        header = header.replace(mark, value)
    parts = [header]
    for name, rows in key_rows().items():
        title = "distribution tables" if name == "distribution" else f"[{name}]"
        parts.append(_table(title, rows))
    for name, rows in study_rows().items():
        parts.append(_table(f"study file: {name}", rows))
    return "\n".join(parts)


if __name__ == "__main__":
    sys.stdout.write(render())
