"""Generalized PS model: evaluation, gradient, transformations, periodicity."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from psdesign.geometry.model import GeneralizedPS, rotation_between, rotation_matrix

finite = st.floats(-3, 3, allow_nan=False, allow_infinity=False)


@st.composite
def models(draw):
    n = draw(st.integers(1, 5))
    k = draw(st.integers(0, 4))
    rng = np.random.default_rng(draw(st.integers(0, 2**31)))
    return GeneralizedPS(
        mu=rng.normal(size=n),
        kappa=rng.integers(1, 4, n),
        H=rng.normal(size=(n, 3)),
        alpha=rng.normal(size=n),
        minor_term=rng.integers(0, n, k),
        u=rng.normal(size=k) * 0.5,
        f=rng.uniform(0.2, 3, k),
        G=rng.normal(size=(k, 3)),
        beta=rng.normal(size=k),
    )


def eq16_direct(p, u, f):
    x, y, z = p.T
    return 4 * np.cos(2 * np.pi * x + u * np.cos(2 * np.pi * f * z)) + 4 * np.cos(2 * np.pi * y) + 3


def test_from_lmst_reproduces_eq16_with_carrier_term():
    u, f = 0.3, 2.0
    P = np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 0, 0]], float)
    uu = np.zeros((1, 3, 1, 1))
    uu[0, 0, 0, 0] = u
    ff = np.full((1, 3, 1), f)
    Q = np.zeros((1, 3, 1, 4))
    Q[0, 0, 0] = [0, 0, 1, 0]
    m = GeneralizedPS.from_lmst(mu=[[4, 4, 3]], kappa=[1], P=P, u=uu, f=ff, Q=Q)
    pts = np.random.default_rng(0).uniform(-1, 2, (500, 3))
    np.testing.assert_allclose(m.evaluate(pts), eq16_direct(pts, u, f), atol=1e-12)
    assert m.n_minor == 1  # zero minor moments are dropped


@settings(max_examples=60, deadline=None)
@given(models(), finite, finite, finite, st.integers(0, 2**31))
def test_rotation_equals_evaluating_at_inverse_rotated_points(model, th, om, ph, seed):
    R = rotation_matrix(np.degrees(th), np.degrees(om), np.degrees(ph))
    pts = np.random.default_rng(seed).uniform(-2, 2, (64, 3))
    np.testing.assert_allclose(
        model.rotated(R).evaluate(pts),
        model.evaluate(pts @ R),
        atol=1e-12 * (1 + np.abs(model.mu).sum()),
    )


@settings(max_examples=60, deadline=None)
@given(models(), finite, finite, finite, st.integers(0, 2**31))
def test_translation_equals_evaluating_at_shifted_points(model, tx, ty, tz, seed):
    t = np.array([tx, ty, tz])
    pts = np.random.default_rng(seed).uniform(-2, 2, (64, 3))
    np.testing.assert_allclose(
        model.translated(t).evaluate(pts),
        model.evaluate(pts - t),
        atol=1e-12 * (1 + np.abs(model.mu).sum()) * (1 + np.abs(t).sum()),
    )


@settings(max_examples=30, deadline=None)
@given(models(), st.integers(0, 2**31))
def test_analytic_gradient_matches_central_differences(model, seed):
    pts = np.random.default_rng(seed).uniform(-1, 1, (20, 3))
    h = 1e-6
    fd = np.column_stack(
        [(model.evaluate(pts + h * e) - model.evaluate(pts - h * e)) / (2 * h) for e in np.eye(3)]
    )
    scale = 1 + np.abs(model.mu).sum() * (1 + np.abs(model.kappa).max()) * 50
    np.testing.assert_allclose(model.gradient(pts), fd, atol=1e-6 * scale)


def test_integer_directions_are_exactly_periodic_and_others_not():
    m = GeneralizedPS(
        mu=[4, 4, 3],
        kappa=[1, 2, 1],
        H=[[1, 0, 0], [0, 1, 1], [0, 0, 0]],
        alpha=[0.1, 0.3, 0],
        minor_term=[0],
        u=[0.4],
        f=[3.0],
        G=[[0, 0, 1]],
        beta=[0.2],
    )
    assert m.is_periodic()
    pts = np.random.default_rng(1).uniform(0, 1, (200, 3))
    for shift in np.eye(3):
        np.testing.assert_allclose(m.evaluate(pts + shift), m.evaluate(pts), atol=1e-12)
    tilted = m.rotated(rotation_matrix(3.0, 17.0))
    assert not tilted.is_periodic()
    assert np.abs(tilted.evaluate(pts + [1, 0, 0]) - tilted.evaluate(pts)).max() > 1e-3


def test_chunked_and_grid_evaluation_agree_with_pointwise():
    m = GeneralizedPS(mu=[1, 2], kappa=[1, 3], H=[[1, 2, 0], [0, 1, -1]], alpha=[0.1, 0.2])
    pts = np.random.default_rng(2).uniform(0, 1, (1000, 3))
    np.testing.assert_allclose(m.evaluate(pts, chunk=7), m.evaluate(pts), atol=1e-13)
    ax = [np.linspace(0, 1, n) for n in (4, 5, 6)]
    g = m.evaluate_grid(ax)
    X, Y, Z = np.meshgrid(*ax, indexing="ij")
    np.testing.assert_allclose(
        g.ravel(), m.evaluate(np.column_stack([X.ravel(), Y.ravel(), Z.ravel()])), atol=1e-13
    )


def test_dict_round_trip_and_bad_input():
    m = GeneralizedPS(
        mu=[4, 4, 3],
        kappa=[1, 1, 1],
        H=np.eye(3),
        alpha=[0, 0, 0],
        minor_term=[0],
        u=[0.2],
        f=[2.0],
        G=[[0, 0, 1]],
        beta=[0.0],
    )
    m2 = GeneralizedPS.from_dict(m.to_dict())
    pts = np.random.default_rng(3).uniform(0, 1, (50, 3))
    np.testing.assert_array_equal(m.evaluate(pts), m2.evaluate(pts))
    import pytest

    with pytest.raises(ValueError, match="kappa"):
        GeneralizedPS(mu=[1, 2], kappa=[1], H=[[1, 0, 0], [0, 1, 0]], alpha=[0, 0])
    with pytest.raises(ValueError, match="finite"):
        GeneralizedPS(mu=[np.nan], kappa=[1], H=[[1, 0, 0]], alpha=[0])


def test_rotation_conventions():
    # Sec. 7.1: x-axis fiber rotated about y by theta then about z by omega
    d = rotation_matrix(10.0, 30.0) @ [1, 0, 0]
    th, om = np.radians(10), np.radians(30)
    np.testing.assert_allclose(d, [np.cos(th) * np.cos(om), np.cos(th) * np.sin(om), -np.sin(th)])
    for a, b in [([1, 0, 0], [0, 0, 1]), ([1, 2, 3], [-1, 0.5, 2]), ([0, 1, 0], [0, -1, 0])]:
        R = rotation_between(a, b)
        np.testing.assert_allclose(
            R @ (np.array(a) / np.linalg.norm(a)), np.array(b) / np.linalg.norm(b), atol=1e-12
        )
        np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
        assert np.isclose(np.linalg.det(R), 1.0)
