"""Cost and value of the solid-per-fiber probe of ``psdesign rev``'s fiber count (session 53,
mendrev2).

:func:`psdesign.packing.generators._measured_solid_per_fiber` draws 20000 / m^2 fibers in a box
of m periods (isotropic 7 um fibers, 30 um period here); "fixed" draws 20000 at every size.
Side by side in one process, best of 2: ``PYTHONPATH=$PWD python benchmarks/bench_solid_probe.py``.
Prints E[L] / V (the solid per fiber over the mean cross-section / period^2) and the times.
"""

from __future__ import annotations

import time

import numpy as np

from psdesign.packing import generators as gen
from psdesign.packing.fiberset import carrier_lengths

SPEC = {
    "rve": {"size": [30e-6] * 3, "voxel": 1.5e-6, "period": 30e-6},
    "generator": {"n_fibers": 6, "diameter": 7e-6, "orientation": {"anisotropy": 1.0}},
    "intersections": {"method": "none"},
}


def _fixed(gs: gen.GeneratorSpec, size: np.ndarray, n: int = gen.SOLID_PROBE_FIBERS) -> float:
    """The probe with ``n`` fibers at every size (the first version of session 53)."""
    probe = gen.draw_fibers(gs, gs.seed + 10_000, n, size)
    hi, total = size / gs.period, 0.0
    for a in range(0, n, gen._PROBE_CHUNK):
        part = probe.subset(np.arange(a, min(a + gen._PROBE_CHUNK, n)))
        total += float(carrier_lengths(part, np.zeros(3), hi).sum())
    return float(np.mean(gen._areas(gen._probe(gs, size)))) * total / n / float(np.prod(hi))


def main() -> None:
    gs = gen.parse_generator(SPEC, np.full(3, 30e-6))
    for m in (1, 2, 3, 4):
        size = np.full(3, 30e-6 * m)
        t_new, t_fixed = [], []
        for _ in range(2):
            t = time.perf_counter()
            s_new = gen._measured_solid_per_fiber(gs, size)
            t_new.append(time.perf_counter() - t)
            t = time.perf_counter()
            s_fixed = _fixed(gs, size)
            t_fixed.append(time.perf_counter() - t)
        area = float(np.mean(gen._areas(gen._probe(gs, size))))
        print(
            f"{m} periods: E[L]/V {s_new / area:.4f} (20000/m^2) {s_fixed / area:.4f} (20000); "
            f"{min(t_new):.2f} s vs {min(t_fixed):.2f} s, fixed/new {min(t_fixed) / min(t_new):.1f}"
        )


if __name__ == "__main__":
    main()
