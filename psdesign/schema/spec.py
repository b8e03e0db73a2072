"""RVE spec files (TOML): load, validate, and build explicit fibers.

Every check raises :class:`~psdesign.errors.SpecError` naming the key and the
allowed range; nothing is built from an invalid spec. Lengths are in metres.
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path
from typing import Any

import numpy as np

from psdesign.errors import SpecError
from psdesign.geometry.fibers import SHAPES, Fiber, make_fiber

#: Tables an RVE spec may hold.
KNOWN_TABLES = (
    "rve",
    "fibers",
    "generator",
    "intersections",
    "flow",
    "mesh",
    "forcefield",
    "output",
)
RVE_KEYS = ("size", "voxel", "period")
FIBER_KEYS = (
    "shape",
    "diameter",
    "center",
    "theta",
    "omega",
    "direction",
    "u",
    "f",
    "isovalue",
    "thickness_axis",
    "layers",
    "layer_shift",
)
#: Shapes that expand to several fibers.
CELL_SHAPES = ("woven-cell",)
FLOW_KEYS = (
    "solver",
    "viscosity",
    "aux_length",
    "direction",
    "sides",
    "pressure_drop",
    "tol",
    "edge_length",
    "max_memory_gb",
    "periodic_treatment",
    "mesher",
    "lattice_step",
)
DEFAULT_FLOW = {
    "solver": "fem",
    "viscosity": 1.8e-5,
    "aux_length": 0.2,
    "sides": "slip",
    "pressure_drop": 1.0,
    "mesher": "stuffing",
}


def load_spec(path: str | Path) -> dict:
    """Read and validate an RVE spec file.

    Raises
    ------
    SpecError
        Missing or unreadable file, TOML syntax error, or a bad value.
    """
    p = Path(path)
    if not p.is_file():
        raise SpecError("spec", f"file not found: {p}")
    try:
        data = tomllib.loads(p.read_text())
    except tomllib.TOMLDecodeError as exc:
        raise SpecError("spec", f"TOML syntax error in {p}: {exc}") from None
    except (OSError, UnicodeDecodeError) as exc:
        raise SpecError("spec", f"cannot read {p}: {exc}") from None
    return validate_spec(data)


def _number(
    value: Any,
    key: str,
    *,
    positive: bool = False,
    low: float | None = None,
    high: float | None = None,
) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise SpecError(key, f"must be a number, got {value!r}")
    v = float(value)
    if not math.isfinite(v):
        raise SpecError(key, f"must be finite, got {value!r}")
    if positive and v <= 0:
        raise SpecError(key, f"must be > 0, got {value!r}")
    if low is not None and v < low:
        raise SpecError(key, f"must be >= {low}, got {value!r}")
    if high is not None and v > high:
        raise SpecError(key, f"must be <= {high}, got {value!r}")
    return v


def _vector(value: Any, key: str) -> list[float]:
    if not isinstance(value, list | tuple) or len(value) != 3:
        raise SpecError(key, f"must be a list of three numbers, got {value!r}")
    return [_number(v, f"{key}[{i}]") for i, v in enumerate(value)]


def validate_spec(data: dict) -> dict:
    """Validate a parsed spec and fill defaults; returns a new dict."""
    if not isinstance(data, dict):
        raise SpecError("spec", "must be a TOML table")
    for key in data:
        if key not in KNOWN_TABLES:
            raise SpecError(key, f"unknown table; allowed: {', '.join(KNOWN_TABLES)}")
    spec = {k: v for k, v in data.items()}
    rve = data.get("rve")
    if not isinstance(rve, dict):
        raise SpecError("rve", "missing [rve] table with size = [x, y, z] in metres")
    for key in rve:
        if key not in RVE_KEYS:
            raise SpecError(f"rve.{key}", f"unknown key; allowed: {', '.join(RVE_KEYS)}")
    if "size" not in rve:
        raise SpecError("rve.size", "missing; give [x, y, z] in metres")
    size = _vector(rve["size"], "rve.size")
    for i, s in enumerate(size):
        if s <= 0:
            raise SpecError(f"rve.size[{i}]", f"must be > 0 metres, got {s}")
    voxel = _number(rve.get("voxel", min(size) / 100), "rve.voxel", positive=True)
    if voxel > min(size) / 4:
        raise SpecError(
            "rve.voxel",
            f"must be <= {min(size) / 4:g} m (a quarter of the smallest edge), got {voxel:g}",
        )
    n_vox = np.prod([round(s / voxel) for s in size])
    if n_vox > 2_000_000_000:
        raise SpecError(
            "rve.voxel",
            f"gives {n_vox:.3g} voxels; use a voxel >= {(np.prod(size) / 2e9) ** (1 / 3):.3g} m",
        )
    period = rve.get("period")
    if period is not None:
        period = _number(period, "rve.period", positive=True)
    spec["rve"] = {"size": size, "voxel": voxel, "period": period}

    fibers = data.get("fibers", [])
    if isinstance(fibers, dict):
        fibers = [fibers]
    if not isinstance(fibers, list):
        raise SpecError("fibers", "must be an array of tables ([[fibers]])")
    ref = period or max(size)
    spec["fibers"] = [_validate_fiber(fb, i, size, ref) for i, fb in enumerate(fibers)]
    if not spec["fibers"] and "generator" not in data:
        raise SpecError("fibers", "no fibers: give [[fibers]] tables or a [generator] table")

    flow = dict(DEFAULT_FLOW)
    flow_in = data.get("flow", {})
    if not isinstance(flow_in, dict):
        raise SpecError("flow", "must be a table")
    for key, value in flow_in.items():
        if key not in FLOW_KEYS:
            raise SpecError(f"flow.{key}", f"unknown key; allowed: {', '.join(FLOW_KEYS)}")
        flow[key] = value
    if flow["solver"] not in ("fem", "voxel"):
        raise SpecError("flow.solver", f"must be 'fem' or 'voxel', got {flow['solver']!r}")
    flow["viscosity"] = _number(flow["viscosity"], "flow.viscosity", positive=True)
    flow["aux_length"] = _number(flow["aux_length"], "flow.aux_length", low=0.0, high=2.0)
    flow["pressure_drop"] = _number(flow["pressure_drop"], "flow.pressure_drop", positive=True)
    if flow.get("periodic_treatment", "periodic") not in ("periodic", "mirror", "frame"):
        raise SpecError(
            "flow.periodic_treatment",
            f"must be 'periodic', 'mirror' or 'frame', got {flow['periodic_treatment']!r}",
        )
    if flow["mesher"] not in ("stuffing", "pytetwild"):
        raise SpecError("flow.mesher", f"must be 'stuffing' or 'pytetwild', got {flow['mesher']!r}")
    if flow.get("lattice_step") is not None:
        step = _number(flow["lattice_step"], "flow.lattice_step", positive=True)
        if step > min(size) / 2:
            raise SpecError(
                "flow.lattice_step",
                f"must be <= {min(size) / 2:g} m (half the smallest edge), got {step:g}",
            )
    if flow["sides"] not in ("slip", "noslip"):
        raise SpecError("flow.sides", f"must be 'slip' or 'noslip', got {flow['sides']!r}")
    spec["flow"] = flow
    return spec


def _validate_fiber(fb: Any, i: int, size: list[float], ref: float) -> dict:
    key = f"fibers[{i}]"
    if not isinstance(fb, dict):
        raise SpecError(key, "must be a table")
    for k in fb:
        if k not in FIBER_KEYS:
            raise SpecError(f"{key}.{k}", f"unknown key; allowed: {', '.join(FIBER_KEYS)}")
    shape = fb.get("shape", "rod")
    if shape not in SHAPES + CELL_SHAPES:
        raise SpecError(
            f"{key}.shape", f"unknown shape {shape!r}; allowed: {', '.join(SHAPES + CELL_SHAPES)}"
        )
    out: dict[str, Any] = {"shape": shape}
    if shape == "woven-cell":
        axis = fb.get("thickness_axis", "z")
        if axis not in ("x", "z"):
            raise SpecError(f"{key}.thickness_axis", f"must be 'x' or 'z', got {axis!r}")
        extra = set(fb) - {"shape", "thickness_axis", "layers", "layer_shift"}
        if extra:
            raise SpecError(
                f"{key}.{sorted(extra)[0]}",
                "woven-cell takes only thickness_axis, layers, layer_shift",
            )
        layers = fb.get("layers", 1)
        if isinstance(layers, bool) or not isinstance(layers, int) or not 1 <= layers <= 8:
            raise SpecError(f"{key}.layers", f"must be an integer in [1, 8], got {layers!r}")
        shift = fb.get("layer_shift", [0.0, 0.0])
        if (
            not isinstance(shift, list)
            or len(shift) != 2
            or not all(isinstance(v, int | float) and not isinstance(v, bool) for v in shift)
            or not all(-1.0 <= v <= 1.0 for v in shift)
        ):
            raise SpecError(
                f"{key}.layer_shift", f"must be two numbers in [-1, 1] (periods), got {shift!r}"
            )
        return {
            "shape": shape,
            "thickness_axis": axis,
            "layers": layers,
            "layer_shift": [float(v) for v in shift],
        }
    if shape in ("rod", "cylinder", "bent-rod"):
        if "diameter" not in fb:
            raise SpecError(f"{key}.diameter", "missing; give the fiber diameter in metres")
        d = _number(fb["diameter"], f"{key}.diameter", positive=True)
        limit = min(min(size), ref)
        if d >= limit:
            raise SpecError(f"{key}.diameter", f"must be < {limit:g} m (the cell), got {d:g}")
        out["diameter"] = d
    if "center" in fb:
        out["center"] = _vector(fb["center"], f"{key}.center")
    if "direction" in fb:
        if "theta" in fb or "omega" in fb:
            raise SpecError(f"{key}.direction", "give either direction or theta/omega, not both")
        d = _vector(fb["direction"], f"{key}.direction")
        if np.linalg.norm(d) < 1e-12:
            raise SpecError(f"{key}.direction", "must have non-zero length")
        out["direction"] = d
    else:
        out["theta"] = _number(fb.get("theta", 0.0), f"{key}.theta", low=-360, high=360)
        out["omega"] = _number(fb.get("omega", 0.0), f"{key}.omega", low=-360, high=360)
    out["u"] = _number(fb.get("u", 0.0), f"{key}.u", low=-10, high=10)
    out["f"] = _number(fb.get("f", 1.0), f"{key}.f", positive=True)
    if out["u"] and shape != "bent-rod":
        raise SpecError(f"{key}.u", f"bending (u != 0) needs shape = 'bent-rod', got {shape!r}")
    if "isovalue" in fb:
        out["isovalue"] = _number(fb["isovalue"], f"{key}.isovalue")
    return out


def explicit_fibers(spec: dict) -> list[Fiber]:
    """Build the ``[[fibers]]`` of a validated spec (normalized coordinates)."""
    size = np.asarray(spec["rve"]["size"])
    ref = spec["rve"]["period"] or float(size.max())
    fibers = []
    for i, fb in enumerate(spec["fibers"]):
        if fb["shape"] == "woven-cell":
            from psdesign.geometry.fibers import woven_cell

            fibers.extend(
                woven_cell(
                    fb.get("thickness_axis", "z"),
                    fb.get("layers", 1),
                    tuple(fb.get("layer_shift", (0.0, 0.0))),
                )
            )
            continue
        center = np.asarray(fb.get("center", size / 2)) / ref
        try:
            fibers.append(
                make_fiber(
                    fb["shape"],
                    diameter=fb.get("diameter", 0.0) / ref or None,
                    center=center,
                    theta=fb.get("theta"),
                    omega=fb.get("omega"),
                    direction=fb.get("direction"),
                    u=fb.get("u", 0.0),
                    f=fb.get("f", 1.0),
                    isovalue=fb.get("isovalue"),
                )
            )
        except ValueError as exc:
            raise SpecError(f"fibers[{i}]", str(exc)) from None
    return fibers
