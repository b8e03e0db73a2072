"""Euclidean distance transforms of voxel masks: open-faced and periodic.

One definition for the image route's signed distance (:mod:`psdesign.image.fields`) and the
pore-size scan (:mod:`psdesign.transport.pores`).

* :func:`edt`, faces open (nothing beyond them): the multi-threaded ``edt`` library
  (Silversmith, seung-lab; also PoreSpy's), a float32 output beside the mask, about 5 bytes
  per voxel.
* :func:`periodic_edt`, the medium the mask is one period of: the separable exact transform of
  Felzenszwalb & Huttenlocher (Theory of Computing 8, 415, 2012), one pass of lower parabola
  envelopes per axis over each line extended by half a period on either side (the nearest site
  of a periodic line is never farther), in place on one float32 array: 4 bytes per voxel beside
  the mask, whatever the pore size. It replaced padding the mask by up to half a period per side
  for scipy's transform, which peaked at 154-409 B per image voxel at 200^3 (8x the voxels and
  scipy's int32 feature transform, index grid and float64 copies; ``benchmarks/RESULTS.md``,
  session 33).
"""

from __future__ import annotations

import numba as nb
import numpy as np

import solvers.jit  # noqa: F401  (its cache locator stamps this module's kernels)


def edt(mask: np.ndarray) -> np.ndarray:
    """Euclidean distance (voxel centres, in voxels, float32) of every True voxel to the
    nearest False voxel; the faces of the grid are open (nothing beyond them).

    >>> edt(np.array([[False, True, True, True]]))
    array([[0., 1., 2., 3.]], dtype=float32)
    """
    import edt as _edt_lib  # a declared dependency (pyproject)

    mask = np.ascontiguousarray(mask)
    if mask.dtype == bool:
        mask = mask.view(np.uint8)  # the same labels; edt runs faster on uint8 than on bool
    return _edt_lib.edt(mask, black_border=False, parallel=nb.get_num_threads())


@nb.njit(cache=True)
def _envelope(f, out, v, z, n):  # pragma: no cover - compiled
    """Lower envelope of the parabolas ``f[q] + (p - q)^2`` of a line of ``len(f)`` sites,
    written for the ``n`` middle points (the line extended by ``(len(f) - n) // 2`` on either
    side). Infinite ``f`` (no site) is skipped; no finite one leaves ``inf``."""
    m = f.shape[0]
    h = (m - n) // 2
    k = -1
    for q in range(m):
        fq = f[q]
        if fq == np.inf:
            continue
        while k >= 0:
            r = v[k]
            s = ((fq + q * q) - (f[r] + r * r)) / (2.0 * (q - r))
            if s > z[k]:
                break
            k -= 1
        k += 1
        v[k] = q
        z[k] = (
            -np.inf
            if k == 0
            else ((fq + q * q) - (f[v[k - 1]] + v[k - 1] ** 2)) / (2.0 * (q - v[k - 1]))
        )
    if k < 0:
        out[:] = np.inf
        return
    j = 0
    for p in range(h, h + n):
        while j < k and z[j + 1] < p:
            j += 1
        d = p - v[j]
        out[p - h] = f[v[j]] + d * d


@nb.njit(cache=True)
def _pass_last_axis(a, wrap):  # pragma: no cover - compiled
    """One envelope pass along the last axis of the 3-D float32 array ``a``, in place;
    ``wrap``: periodic, each line extended by ``n // 2 + 1`` wrapped sites on either side,
    else by as many empty ones (faces open: nothing beyond them)."""
    n0, n1, n = a.shape
    h = n // 2 + 1
    m = n + 2 * h
    f = np.empty(m, np.float64)
    out = np.empty(n, np.float64)
    v = np.empty(m, np.int64)
    z = np.empty(m + 1, np.float64)
    for i in range(n0):
        for j in range(n1):
            for q in range(m):
                f[q] = a[i, j, (q - h) % n] if wrap or 0 <= q - h < n else np.inf
            _envelope(f, out, v, z, n)
            for p in range(n):
                a[i, j, p] = out[p]


def periodic_edt(
    mask: np.ndarray, periodic: tuple[bool, bool, bool] = (True, True, True)
) -> np.ndarray:
    """Euclidean distance (voxel centres, in voxels, float32) of every True voxel to the
    nearest False voxel of the periodic medium ``mask`` is one period of.

    Parameters
    ----------
    mask : ndarray of bool, 3-D
        Must hold at least one False voxel.
    periodic : three bools
        The axes the medium repeats along; along another the faces are open (nothing beyond
        them, as :func:`edt`'s).

    Returns
    -------
    ndarray of float32, the shape of ``mask``

    Examples
    --------
    A slit two voxels wide, whose walls are one period apart across the faces:

    >>> m = np.ones((6, 1, 1), bool); m[2] = False
    >>> periodic_edt(m)[:, 0, 0]
    array([2., 1., 0., 1., 2., 3.], dtype=float32)
    >>> periodic_edt(m, (False, True, True))[:, 0, 0]
    array([2., 1., 0., 1., 2., 3.], dtype=float32)
    >>> periodic_edt(np.roll(m, 2, axis=0), (False, True, True))[:, 0, 0]
    array([4., 3., 2., 1., 0., 1.], dtype=float32)
    """
    if mask.ndim != 3:
        raise ValueError(f"mask: must be 3-D, got {mask.ndim}-D")
    if mask.all():
        raise ValueError("mask: must hold at least one False voxel")
    sq = np.where(mask, np.float32(np.inf), np.float32(0.0))
    for axis in (2, 1, 0):  # any order gives the same result
        _pass_last_axis(np.moveaxis(sq, axis, 2), bool(periodic[axis]))
    return np.sqrt(sq, out=sq)
