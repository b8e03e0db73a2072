"""Report plots of the transport outputs (issue 13): pore sizes / intrusion and diffusivity vs
porosity with the Tomadakis-Sotirchos curves.

:func:`transport_figure` takes the study table and returns a base64 PNG (or None when the study
has no transport columns) for ``report/html.py`` to embed; :func:`pore_figure` writes the
``psdesign pores --plot`` picture.
"""

from __future__ import annotations

import base64
import io
from pathlib import Path

import numpy as np

#: Tomadakis & Sotirchos (1993), 2-D random fibre structures: eps_p, alpha in / through plane.
TS_2D = (0.11, 0.521, 0.785)


def _fig_png(fig) -> bytes:
    import matplotlib.pyplot as plt

    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=110, bbox_inches="tight")
    plt.close(fig)
    return buf.getvalue()


def pore_figure(pores: dict, path: str | Path) -> Path:
    """Pore size distribution (volume fraction per diameter) and intrusion curve, PNG."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(9, 3.4))
    d = np.asarray(pores["diameters_m"])  # metres, as every output
    a.bar(d, pores["volume_fraction"], width=0.8 * (d[1] - d[0]) if d.size > 1 else 1e-6)
    for q in ("pore_d10_m", "pore_d50_m", "pore_d90_m"):
        a.axvline(pores[q], color="k", lw=0.8, ls="--")
    a.set_xlabel("local thickness diameter (m)")
    a.set_ylabel("pore volume fraction")
    b.plot(np.asarray(pores["intrusion_diameter_m"]), pores["intrusion_saturation"], "o-")
    b.set_xscale("log")
    b.invert_xaxis()
    b.set_xlabel("accessible diameter (m)")
    b.set_ylabel("non-wetting saturation")
    out = Path(path)
    out.write_bytes(_fig_png(fig))
    return out


def transport_figure(df) -> tuple[str | None, str]:
    """Relative diffusivity vs porosity of a study table with the Tomadakis-Sotirchos curves;
    ``(base64 png or None, caption)``."""
    cols = [c for c in ("diffusivity_x", "diffusivity_y", "diffusivity_z") if c in df.columns]
    if not cols or "porosity" not in df.columns:
        return None, ""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(5, 3.6))
    for c in cols:
        ax.plot(df["porosity"], df[c], "o", label=c)
    eps = np.linspace(0.12, 0.99, 100)
    ep, a_in, a_tp = TS_2D
    for alpha, name in ((a_in, "in-plane"), (a_tp, "through-plane")):
        ax.plot(eps, eps * ((eps - ep) / (1 - ep)) ** alpha, "-", lw=1, label=f"T-S {name}")
    ax.set_xlabel("porosity")
    ax.set_ylabel("D_eff / D_bulk")
    ax.legend(fontsize=7)
    png = base64.b64encode(_fig_png(fig)).decode()
    caption = (
        "Relative diffusivity against porosity; lines: Tomadakis & Sotirchos (1993) for random "
        "overlapping 2-D fibre structures (eps_p = 0.11, alpha = 0.521 in-plane, 0.785 "
        "through-plane)."
    )
    return png, caption
