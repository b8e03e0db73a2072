"""Generators: named distributions, spec validation, porosity targeting, exports."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest
from scipy import integrate, stats

from psdesign.errors import SpecError
from psdesign.packing.distributions import (
    AnisotropicOrientation,
    Distribution,
    angles_from_directions,
)
from psdesign.packing.generators import GenerationError, build_fibers, write_medial_axes

N = 200_000


def _rng(seed=0):
    return np.random.default_rng(seed)


# ------------------------------------------------------------------ distributions
def test_beta_4_4_moments_match_closed_form():
    d = Distribution.from_spec("tz", {"dist": "beta", "a": 4, "b": 4})
    x = d.sample(_rng(), N)
    a = b = 4.0
    var = a * b / ((a + b) ** 2 * (a + b + 1))  # = 1/36
    assert abs(x.mean() - 0.5) < 5 * np.sqrt(var / N)
    assert x.var() == pytest.approx(var, rel=0.02)
    # scaled to [low, high]
    y = Distribution.from_spec("t", {"dist": "beta", "a": 2, "b": 5, "low": -1, "high": 3}).sample(
        _rng(1), N
    )
    assert y.min() >= -1 and y.max() <= 3
    assert y.mean() == pytest.approx(-1 + 4 * 2 / 7, abs=0.01)


def test_exponential_mean_and_truncation():
    x = Distribution.from_spec("w", {"dist": "exponential", "mean": 0.4}).sample(_rng(), N)
    assert x.mean() == pytest.approx(0.4, rel=0.01)
    assert x.std() == pytest.approx(0.4, rel=0.01)
    t = Distribution.from_spec("w", {"dist": "exponential", "mean": 1.0, "high": 1.0})
    y = t.sample(_rng(2), N)
    assert y.max() <= 1.0
    # mean of Exp(1) truncated to [0, 1]: 1 - 1/(e - 1)
    assert y.mean() == pytest.approx(1 - 1 / (np.e - 1), abs=0.005)
    assert t.mean() == pytest.approx(1 - 1 / (np.e - 1), rel=1e-9)


def test_truncated_normal_bounds_and_mean():
    spec = {"dist": "normal", "mean": 7e-6, "std": 1e-6, "low": 6.5e-6, "high": 9e-6}
    x = Distribution.from_spec("d", spec).sample(_rng(), N)
    assert x.min() >= 6.5e-6 and x.max() <= 9e-6
    al, be = -0.5, 2.0
    phi, Phi = stats.norm.pdf, stats.norm.cdf
    mean = 7e-6 + 1e-6 * (phi(al) - phi(be)) / (Phi(be) - Phi(al))
    assert x.mean() == pytest.approx(mean, rel=2e-3)


def test_uniform_and_constant():
    x = Distribution.from_spec("t", {"dist": "uniform", "low": -5, "high": 5}).sample(_rng(), N)
    assert x.min() >= -5 and x.max() <= 5
    assert x.var() == pytest.approx(100 / 12, rel=0.02)
    assert np.all(Distribution.from_spec("d", 7e-6).sample(_rng(), 5) == 7e-6)


@pytest.mark.parametrize("beta", [1.0, 3.0, 10.0])
def test_anisotropic_orientation_matches_density(beta):
    o = AnisotropicOrientation(beta)
    total, _ = integrate.quad(o.pdf_polar, 0, np.pi)
    assert total == pytest.approx(1.0, abs=1e-8)
    ec2, _ = integrate.quad(lambda t: np.cos(t) ** 2 * o.pdf_polar(t), 0, np.pi, limit=200)
    d = o.sample_directions(_rng(), N)
    assert np.allclose(np.linalg.norm(d, axis=1), 1.0)
    assert np.mean(d[:, 2] ** 2) == pytest.approx(ec2, abs=0.004)
    if beta == 1.0:
        assert ec2 == pytest.approx(1 / 3, abs=1e-9)  # isotropic


def test_anisotropy_in_plane_limit_and_angles():
    b = 1e4
    d = AnisotropicOrientation(b).sample_directions(_rng(), 100_000)
    # median |cos theta| from the CDF: b c / sqrt(1 + (b^2 - 1) c^2) = 1/2
    med = 1.0 / (2.0 * np.sqrt(b * b - (b * b - 1) / 4))
    assert np.median(np.abs(d[:, 2])) == pytest.approx(med, rel=0.02)
    assert med < 1e-4
    th, om = AnisotropicOrientation(2.0).sample_angles(_rng(), 1000)
    assert np.all((om >= 0) & (om < 180))
    # the angles reproduce the line direction d(theta, omega) up to sign
    dd = AnisotropicOrientation(2.0).sample_directions(_rng(), 1000)
    t, w = np.radians(angles_from_directions(dd))
    back = np.column_stack([np.cos(t) * np.cos(w), np.cos(t) * np.sin(w), -np.sin(t)])
    assert np.allclose(np.abs(np.einsum("ij,ij->i", back, dd)), 1.0)


@pytest.mark.parametrize(
    "spec, key",
    [
        ({"dist": "beta", "a": -1, "b": 4}, "x.a"),
        ({"dist": "uniform", "low": 2, "high": 1}, "x"),
        ({"dist": "normal", "mean": 1, "std": 0}, "x.std"),
        ({"dist": "exponential", "mean": -0.4}, "x.mean"),
        ({"dist": "gamma", "k": 1}, "x.dist"),
        ({"dist": "uniform", "low": 0}, "x"),
        ({"dist": "uniform", "low": 0, "high": 1, "mode": 3}, "x.mode"),
    ],
)
def test_bad_distribution_parameters(spec, key):
    with pytest.raises(SpecError) as e:
        Distribution.from_spec("x", spec)
    assert e.value.key == key


# ------------------------------------------------------------------ spec checks
def _spec(**gen):
    g = {"kind": "straight", "n_fibers": 5, "diameter": 7e-6, "seed": 3}
    g.update(gen)
    inter = {"method": g.pop("method", "none")}
    return {"rve": {"size": [50e-6] * 3, "voxel": 1e-6}, "generator": g, "intersections": inter}


@pytest.mark.parametrize(
    "gen, key",
    [
        ({"porosity": 1.2, "n_fibers": None}, "generator.porosity"),
        ({"porosity": 1.0, "n_fibers": None}, "generator.porosity"),
        ({"porosity": 0.05, "n_fibers": None, "method": "fast"}, "generator.porosity"),
        ({"n_fibers": 0}, "generator.n_fibers"),
        ({"kind": "wavy"}, "generator.kind"),
        ({"diameter": {"dist": "normal", "mean": 7e-6, "std": 1e-6}}, "generator.diameter"),
        ({"diameter": 30e-6}, "generator.diameter"),
        ({"u": 0.2}, "generator.u"),
        ({"colour": 1}, "generator.colour"),
        ({"method": "magic"}, "intersections.method"),
    ],
)
def test_spec_errors_name_the_key(gen, key):
    spec = _spec()
    for k, v in gen.items():
        if k == "method":
            spec["intersections"]["method"] = v
        elif v is None:
            spec["generator"].pop(k)
        else:
            spec["generator"][k] = v
    with pytest.raises(SpecError) as e:
        build_fibers(spec)
    assert e.value.key == key


# ------------------------------------------------------------------ generation
def test_same_seed_same_fibers_and_sec71_ranges():
    spec = _spec(n_fibers=12, kind="bent")
    a, b = build_fibers(spec), build_fibers(spec)
    for fa, fb in zip(a.fibers, b.fibers, strict=True):
        assert np.array_equal(fa.center, fb.center) and fa.theta == fb.theta and fa.u == fb.u
    th = np.array([f.theta for f in a.fibers])
    om = np.array([f.omega for f in a.fibers])
    u = np.array([f.u for f in a.fibers])
    f = np.array([f.f for f in a.fibers])
    assert np.all(np.abs(th) <= 5) and np.all((om >= 0) & (om <= 180))
    assert np.all((u >= 0.1) & (u <= 0.3)) and np.all((f >= 1) & (f <= 10))
    spec["generator"]["seed"] = 4
    c = build_fibers(spec)
    assert not np.array_equal(a.fibers[0].center, c.fibers[0].center)


def test_fast_porosity_target_on_voxels_with_zero_overlap():
    spec = {
        "rve": {"size": [60e-6] * 3, "voxel": 0.6e-6},
        "generator": {"kind": "straight", "porosity": 0.88, "diameter": 7e-6, "seed": 5},
        "intersections": {"method": "fast", "min_gap": 0.5e-6},
    }
    r = build_fibers(spec)
    vf = r.rve.voxelize(0.6e-6)  # independent re-measurement of the returned RVE
    assert abs(vf.porosity - 0.88) <= 0.005
    assert vf.porosity == pytest.approx(r.report["porosity"], abs=1e-12)
    assert vf.intersection_volume_fraction == 0.0
    assert r.report["omega_after"] == 0.0
    assert r.report["min_clearance_m"] >= 0.5e-6 - 1e-9
    # centre lines clear by min_gap: the analytic Omega is exactly 0, with its bar and status
    # (session 47: stored without them)
    after = [r.report[f"omega_analytic_after{k}"] for k in ("", "_error", "_status")]
    assert after == [0.0, 0.0, "ok"]
    assert r.report["n_fibers"] == len(r.fibers)


def test_none_method_reaches_porosity_with_overlaps():
    spec = {
        "rve": {"size": [60e-6] * 3, "voxel": 0.6e-6},
        "generator": {
            "kind": "bent",
            "porosity": 0.85,
            "diameter": 7e-6,
            "seed": 2,
            "tz": {"dist": "beta", "a": 4, "b": 4},
        },
        "intersections": {"method": "none"},
    }
    r = build_fibers(spec)
    assert abs(r.report["porosity"] - 0.85) <= 0.005
    assert r.report["porosity"] == pytest.approx(r.rve.voxelize(0.6e-6).porosity, abs=1e-12)
    # overlaps left: the analytic Omega carries a bar, and its status says that for bent rods
    # the nominal cylinders only bound the overlap from above (session 47: 0.0304 against the
    # voxel count's 0.0143 here; it was stored without a bar or status)
    value, bar = r.report["omega_analytic_after"], r.report["omega_analytic_after_error"]
    assert value > r.report["omega_after"] + r.report["omega_after_error"] and bar > 0.0
    assert r.report["omega_analytic_after_status"] == "untrustworthy"


@pytest.mark.parametrize("seed", [1, 2])
def test_fast_porosity_target_in_a_slab_thinner_than_its_fibers_can_cross(seed):
    """Session 52 walk (geometry): a 9 um slab of 7 um fibers at porosity 0.8 was refused,
    "closest porosity reached 0.8123 (the measured porosity did not converge)", read as a jam.
    It was none: the later rounds counted the kept fibers' length where they were drawn (0.334
    solid) not where they were placed (0.202), found the goal met and placed nothing. Truth: the
    target band itself, on the voxel grid's independent re-measurement of the returned RVE."""
    spec = {
        "rve": {"size": [80e-6, 80e-6, 9e-6], "voxel": 1e-6},
        "generator": {"porosity": 0.8, "diameter": 7e-6, "seed": seed, "porosity_tolerance": 0.01},
        "intersections": {"method": "fast"},
    }
    r = build_fibers(spec)
    vf = r.rve.voxelize(1e-6)
    assert abs(vf.porosity - 0.8) <= 0.01
    assert vf.intersection_volume_fraction == 0.0


def test_jammed_target_raises_with_closest_porosity():
    spec = {
        "rve": {"size": [40e-6] * 3, "voxel": 1e-6},
        "generator": {
            "kind": "straight",
            "porosity": 0.35,
            "diameter": 8e-6,
            "seed": 1,
            "theta": 0.0,
        },
        "intersections": {"method": "fast", "orientation_tries": 0},
    }
    with pytest.raises(GenerationError) as e:
        build_fibers(spec)
    assert e.value.closest_porosity is not None and e.value.closest_porosity > 0.35 + 0.005
    assert "closest porosity" in str(e.value)
    # the pool grows when rejections use it up, so the reason is the jam, not the pool size
    assert "packing jammed" in str(e.value)
    # session 53: the line names the key and a value to try (the closest porosity rounded up:
    # a hint, since where a packing jams depends on its target), here checked by building it
    import re

    said = re.search(
        r"raise generator\.porosity above (\d\.\d{4}) \(e\.g\. (\d\.\d\d)", str(e.value)
    )
    assert said is not None, str(e.value)
    assert float(said[1]) == round(e.value.closest_porosity, 4)
    works = float(said[2])
    assert e.value.closest_porosity <= works < e.value.closest_porosity + 0.01
    assert "intersections.method = 'none'" in str(e.value)
    spec["generator"]["porosity"] = works
    r = build_fibers(spec)
    assert abs(r.report["porosity"] - works) <= 0.005


def test_medial_axes_export(tmp_path):
    r = build_fibers(_spec(n_fibers=4, kind="bent"))
    csv_path, json_path = write_medial_axes(r.rve, tmp_path)
    rows = list(csv.DictReader(open(csv_path)))
    doc = json.loads(json_path.read_text())
    assert doc["units"] == "m" and len(doc["fibers"]) == 4
    n_pts = sum(len(c) for fb in doc["fibers"] for c in fb["copies"])
    assert len(rows) == n_pts > 0
    xyz = np.array([[float(r_[k]) for k in ("x_m", "y_m", "z_m")] for r_ in rows])
    # medial axes are clipped to the box (50 um); bent ones sway by <= u / (2 pi) periods
    assert xyz.min() >= -0.3 / (2 * np.pi) * 50e-6 - 1e-12
    assert xyz.max() <= 50e-6 * (1 + 0.3 / (2 * np.pi)) + 1e-12
    assert doc["fibers"][0]["diameter_m"] == pytest.approx(7e-6)


def test_ga_method_reports_and_never_worsens_its_objective():
    spec = _spec(n_fibers=8, method="ga")
    spec["intersections"].update({"population": 8, "generations": 4})
    r = build_fibers(spec)
    ga = r.report["ga"][0]
    assert ga["objective_final"] <= ga["objective_initial"]
    assert r.report["method"] == "ga" and r.report["n_fibers"] == 8
    assert r.report["rotation_deg"]["max"] <= np.sqrt(2) + 1e-6  # theta, omega each +-1 deg
    # one round (fixed count): every move inside the paper's Sec. 7.1 ranges, reported so
    bounds = r.report["bounds"]
    assert bounds["status"] == "within_bounds" and bounds["n_exceeded"] == 0
    assert bounds["max_shift_m"] <= 0.1 * 50e-6 * (1 + 1e-9)
    assert bounds["max_turn_deg"] <= 1.0 + 1e-9


def test_ga_bounds_report_counts_moves_added_over_rounds():
    """Two rounds of +-0.1 L each can move a fiber 0.16 L from its drawn place (measured on the
    Table III GA, docs/paper-reproduction.md 2.6): the report must count it against the drawn
    state, not the last round's start."""
    from psdesign.packing.ga_settings import GASettings
    from psdesign.packing.generators import _ga_bounds_report, draw_fibers, parse_generator

    size = np.array([50e-6] * 3)
    gs = parse_generator(_spec(n_fibers=3), size)
    size_norm = size / gs.period
    st0 = draw_fibers(gs, 1, 3, size_norm)
    moved = st0.copy()
    moved.center[0, 0] += 0.16 * size_norm[0]  # two rounds' worth along x
    moved.theta[1] += 0.5  # inside +-1 deg
    moved.omega[2] += 1.7  # two rounds' worth of turn
    settings = GASettings(shift_range=0.1, angle_range_deg=1.0)
    rep = _ga_bounds_report(moved, st0, settings, size_norm, gs.period)
    assert rep["n_exceeded"] == 2 and rep["status"] == "exceeded_bounds"
    assert rep["max_shift_m"] == pytest.approx(0.16 * 50e-6)
    assert rep["max_turn_deg"] == pytest.approx(1.7)


@pytest.mark.parametrize(
    "name", ["fig13_straight", "fig15_bent", "fig17_beta_z", "fig18_exponential"]
)
def test_example_specs_parse(name):
    import tomllib
    from pathlib import Path

    from psdesign.packing.generators import parse_generator, parse_rve

    spec = tomllib.loads(
        (Path(__file__).parents[2] / "studies" / "examples" / f"{name}.toml").read_text()
    )
    size, voxel, period = parse_rve(spec)
    gs = parse_generator(spec, size, period)
    # issue 17: Figs 13 and 17 use the paper's GA (zero-overlap placement cannot keep their
    # drawn statistics), Figs 15 and 18 the bounded zero-overlap placement
    expected = {"fig13_straight": "ga", "fig17_beta_z": "ga"}.get(name, "fast")
    assert voxel == 0.5e-6 and gs.method == expected


def test_draws_are_prefix_stable():
    from psdesign.packing.generators import draw_fibers, parse_generator

    spec = _spec(
        kind="bent",
        diameter={"dist": "normal", "mean": 7e-6, "std": 1e-6, "low": 5e-6, "high": 9e-6},
        tz={"dist": "beta", "a": 4, "b": 4},
        orientation={"anisotropy": 5.0},
    )
    spec["generator"].pop("theta", None)
    size = np.array(spec["rve"]["size"])
    gs = parse_generator(spec, size, float(size.max()))
    a, b = draw_fibers(gs, 7, 10, size), draw_fibers(gs, 7, 50, size)
    for k in ("diameter", "center", "theta", "omega", "u", "f"):
        assert np.array_equal(getattr(a, k), getattr(b, k)[:10]), k


def test_the_ga_methods_defaults_are_ga_settings(monkeypatch):
    """Session 42 gave the GA its settings class (GASettings: ranges 1 degree / 0.1, population
    24, 40 generations) while generators._ga kept its own literal fallbacks for every key the
    spec leaves out, and the paper's ranges stood a third time in PAPER_MAX_SHIFT /
    PAPER_MAX_ROTATION_DEG (review s42-review). _ga now falls back on GASettings' defaults."""
    from dataclasses import dataclass

    from psdesign.packing import ga_settings, generators

    @dataclass(frozen=True)
    class Other(ga_settings.GASettings):
        angle_range_deg: float = 0.5
        shift_range: float = 0.05
        population: int = 7
        generations: int = 3

    seen = []

    def capture(st, lo, hi, size_norm, settings, **kw):
        seen.append(settings)
        raise RuntimeError("captured")

    monkeypatch.setattr(generators, "GASettings", Other)
    monkeypatch.setattr(generators, "genetic", capture)
    with pytest.raises(RuntimeError, match="captured"):
        build_fibers(_spec(n_fibers=4, method="ga"))
    (s,) = seen
    assert (s.angle_range_deg, s.shift_range, s.population, s.generations) == (0.5, 0.05, 7, 3)
    assert generators.PAPER_MAX_SHIFT is ga_settings.PAPER_MAX_SHIFT
