"""Spec -> validated ``[transport]`` table, RVE and voxel fields (shared by the commands)."""

from __future__ import annotations

from dataclasses import dataclass

from psdesign.geometry.rve import RVE, VoxelFields


@dataclass
class TransportCase:
    """A built RVE with its validated spec and ``[transport]`` table."""

    spec: dict
    transport: dict
    rve: RVE
    fields: VoxelFields

    @property
    def cells_per_diameter(self) -> float | None:
        """Voxels across the thinnest fiber (None without fibers)."""
        from psdesign.flow.error import cells_per_diameter

        return cells_per_diameter(self.rve, float(self.fields.grid.spacing[0]))

    @property
    def resolution_measure(self) -> str:
        """What :attr:`cells_per_diameter` counts across: ``"fiber thin width"`` for a woven
        or compressed fiber (:func:`psdesign.geometry.rve.resolution_measure`)."""
        from psdesign.geometry.rve import resolution_measure

        return resolution_measure(self.rve)


def load_case(
    path: str, overrides: dict | None = None, flags: dict[str, str] | None = None
) -> TransportCase:
    """Load and validate a spec file, build the RVE and voxelize it at ``rve.voxel``.

    Parameters
    ----------
    path : str
        The spec file.
    overrides : dict, optional
        ``[transport]`` keys given on the command line (``None`` values are ignored); they
        replace the spec's and are validated with it, before the RVE is built.
    flags : dict, optional
        The command-line option of each override key (``{"tol": "--tol"}``): a bad override
        is named by the option the user typed and its key, ``--tol (transport.tol): ...``.

    Raises
    ------
    SpecError
        A bad key anywhere in the spec or in ``overrides`` (``transport.<key>``).
    """
    from pathlib import Path

    from psdesign.errors import SpecError
    from psdesign.packing.build import build_rve
    from psdesign.schema.budget import check_transport, unplanned_route
    from psdesign.schema.spec import load_spec, read_toml, validate_spec
    from psdesign.schema.transport import validate_transport

    p = Path(path)
    # the one reader of spec files: a folder, a missing or unreadable file, one over the size
    # limit, not UTF-8, bad TOML (an unreadable file was an OSError, exit 1)
    raw = read_toml(p)
    transport = validate_transport(raw)
    given = {k: v for k, v in (overrides or {}).items() if v is not None}
    if given:
        try:
            transport = validate_transport({"transport": {**transport, **given}})
        except SpecError as exc:
            key = exc.key.removeprefix("transport.")
            if key not in given or key not in (flags or {}):
                raise
            raise SpecError(f"{flags[key]} ({exc.key})", exc.message) from None
    rest = {k: v for k, v in raw.items() if k != "transport"}
    # pores, diffusivity and conductivity solve no flow: the spec is held to its voxel grid's
    # memory, not to the [flow] solve a permeability run would plan (session 52 walk: refused
    # for a 16.7 GiB FEM permeameter they never run)
    # held to the transport solve's own memory instead (review E, session 52: inside
    # unplanned_route alone the grid's 16 B per voxel let an out-of-memory run through); an
    # image's from its header, before the spec check reads its voxels (session 54)
    with unplanned_route(transport=True):
        spec = validate_spec(rest, base=p.parent) if rest else load_spec(p)
        check_transport(spec)
        spec["transport"] = transport
        built = build_rve(spec)
        fields = built.voxelize(spec["rve"]["voxel"])
    return TransportCase(spec, transport, built.rve, fields)
