"""The rod route of ``psdesign forcefield`` (issue 17 item 4): the incremental energy that makes
the relax of a 55-fiber GA RVE practical is the whole-set energy, point for point."""

from __future__ import annotations

import numpy as np

from psdesign.forcefield.relax import _RodEnergy, bending_area
from psdesign.packing.fiberset import FiberState, find_contacts
from psdesign.packing.genetic import analytic_omega

LO, HI = np.zeros(3), np.ones(3)
MS, UM, W1, W3 = 0.05, 0.3, 1e4, 1.0


def _crowded_set(bent: bool, seed: int = 4, n: int = 14) -> FiberState:
    """Random rods (and bent rods) of one diameter in the unit cube, many of them in contact."""
    rng = np.random.default_rng(seed)
    u = np.where(rng.random(n) < 0.4, rng.uniform(0.1, 0.3, n), 0.0) if bent else np.zeros(n)
    return FiberState(
        diameter=np.full(n, 0.12),
        center=rng.random((n, 3)),
        theta=rng.uniform(-5, 5, n),
        omega=rng.uniform(0, 180, n),
        u=u,
        f=np.where(u != 0, rng.uniform(1, 3, n), 1.0),
        fixed=np.zeros(n, bool),
    )


def _model(st: FiberState):
    c = find_contacts(st, LO, HI, 0.0)
    movable = np.unique(np.r_[c.i, c.j])
    assert len(movable) >= 8 and len(c) >= 6  # a crowded set: the test has pairs to track
    reach = 2 * (np.sqrt(2) * MS + UM / (2 * np.pi))
    model = _RodEnergy(st, movable, LO, HI, reach, W1, W3)

    def whole(x):
        s = model.state_at(x)
        return W1 * analytic_omega(s, LO, HI) + W3 * float(bending_area(s, LO, HI).sum())

    return model, whole, np.tile([MS, MS, UM], len(movable))


def _walk(model, bound, seed: int, steps: int = 60):
    """Points of a compass-search-like walk: one variable changed per poll, some accepted."""
    rng = np.random.default_rng(seed)
    x, out = np.zeros(len(bound)), []
    for _ in range(steps):
        y = x.copy()
        i = rng.integers(len(y))
        y[i] = np.clip(
            y[i] + rng.choice([-1, 1]) * bound[i] * rng.uniform(0.2, 1), -bound[i], bound[i]
        )
        out.append((y, model.energy(y)))
        if rng.random() < 0.4:
            x = y
    return out


def test_rod_relax_energy_is_the_whole_set_energy():
    model, whole, bound = _model(_crowded_set(bent=False))
    bound[2::3] = 0.0  # shifts only: the rods stay straight (bending one makes a bent rod)
    x = np.zeros(len(bound))
    assert model.energy(x) == whole(x) > W1 * 1e-4
    for y, e in _walk(model, bound, seed=1):  # each poll and each move of the reference
        assert abs(e - whole(y)) <= 1e-9 * whole(y)
    y = np.random.default_rng(2).uniform(-1, 1, len(bound)) * bound  # every fiber at once
    assert abs(model.energy(y) - whole(y)) <= 1e-9 * whole(y)
    assert model.energy(y) != model.energy(x)


def test_rod_relax_energy_of_bent_rods_depends_on_the_state_alone():
    model, whole, bound = _model(_crowded_set(bent=True))
    walk = _walk(model, bound, seed=3)
    # the same points again, reached along another path (the reference has moved): same values
    for y, e in walk[::-1]:
        assert abs(model.energy(y) - e) <= 1e-9 * e
    # and close to the whole-set value, which breaks ties between the two pieces meeting at a
    # vertex of a bent axis by its search order
    err = [abs(e - whole(y)) / whole(y) for y, e in walk]
    assert np.median(err) < 1e-9 and max(err) < 0.1
