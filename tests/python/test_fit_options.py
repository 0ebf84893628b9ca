"""gonio.fit over its option space (model x fresnel x shadowing x lobes 0-4 x residual x loss x
roughness x anisotropic x diffuse, every pair of values in at least one call, a greedy all-pairs
cover): each call fits or raises gonio.Error before any work (the same refusal for data that do not
exist), and the interpreter survives every one. The Lambert-only fit (lobes=0), which once killed
the interpreter, recovers a Lambert truth."""

import os

import numpy as np
import pytest

import gonio
from conftest import synthetic_samples

# One option and its values; the first is the default (not passed, so that "auto" runs when the
# structure is left alone).
AXES = [
    ("model", ["ggx", "beckmann", "blinn-phong", "student-t", "tabulated", "auto"]),
    ("fresnel", ["schlick", "schlick-rgb", "dielectric", "conductor", "none"]),
    ("shadowing", ["smith-correlated", "smith-separable", "v-groove", "none"]),
    ("lobes", [1, 0, 2, 3, 4]),
    ("residual", ["log", "absolute", "relative", "cosine", "cbrt"]),
    ("loss", ["none", "huber", "cauchy"]),
    ("roughness", ["shared", "rgb"]),
    ("anisotropic", [False, True]),
    ("diffuse", [True, False]),
]

LAMBERT = {"diffuse": [0.62, 0.35, 0.08], "lobes": []}
BECKMANN = {
    "diffuse": [0.5, 0.3, 0.05],
    "lobes": [
        {
            "distribution": "beckmann",
            "alpha": 0.2,
            "shadowing": "smith-correlated",
            "fresnel": {"type": "schlick", "f0": 0.04},
            "scale": [1, 1, 1],
        }
    ],
}


def all_pairs(axes):
    """Rows of value indices covering every pair of values of two options (greedy, deterministic):
    each row starts from an uncovered pair and gives every other option the value that covers the
    most new pairs."""
    n = len(axes)
    uncovered = {
        (a, va, b, vb)
        for a in range(n)
        for b in range(a + 1, n)
        for va in range(len(axes[a][1]))
        for vb in range(len(axes[b][1]))
    }
    rows = []
    while uncovered:
        a, va, b, vb = min(uncovered)
        row = [None] * n
        row[a], row[b] = va, vb
        for k in range(n):
            if row[k] is not None:
                continue

            def gain(v):
                return sum(
                    ((k, v, j, row[j]) if k < j else (j, row[j], k, v)) in uncovered
                    for j in range(n)
                    if j != k and row[j] is not None
                )

            row[k] = max(range(len(axes[k][1])), key=lambda v: (gain(v), -v))
        for i in range(n):
            for j in range(i + 1, n):
                uncovered.discard((i, row[i], j, row[j]))
        rows.append(row)
    return rows


def options_of(row):
    return {AXES[k][0]: AXES[k][1][v] for k, v in enumerate(row) if v != 0}


def test_the_cover_holds_every_pair():
    rows = all_pairs(AXES)
    assert 30 <= len(rows) < 80
    for a in range(len(AXES)):
        for b in range(a + 1, len(AXES)):
            seen = {(r[a], r[b]) for r in rows}
            assert len(seen) == len(AXES[a][1]) * len(AXES[b][1])


@pytest.mark.parametrize("row", all_pairs(AXES), ids=lambda r: ",".join(map(str, r)))
def test_every_pair_of_options_fits_or_is_refused_before_work(row, workdir):
    options = dict(options_of(row))
    model = options.pop("model", "ggx")
    budget = dict(starts=2, max_iterations=30, threads=1, max_samples=400)
    refused_early = None
    try:
        gonio.fit(os.path.join(str(workdir), "no-such-data.csv"), model=model, **options, **budget)
    except gonio.Error as e:
        refused_early = "no-such-data.csv" not in str(e)
    assert refused_early is not None, "missing data must raise"
    data = synthetic_samples(BECKMANN, n_theta=7, n_phi=8)
    if refused_early:
        with pytest.raises(gonio.Error):
            gonio.fit(data, model=model, **options, **budget)
        return
    with np.errstate(all="ignore"):
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            fitted, report = gonio.fit(data, model=model, **options, **budget)
    assert report["solver"]["converged"] or report["solver"]["termination"], report["solver"]
    assert all(np.isfinite(report["metrics"]["log_rmse"])) or not report["solver"]["usable"]
    assert ("lobes" in fitted) and ("diffuse" in fitted or options.get("diffuse") is False)


@pytest.mark.parametrize("model", ["ggx", "beckmann", "blinn-phong"])
def test_lambert_only_fit_recovers_the_albedo(model):
    data = synthetic_samples(LAMBERT, n_theta=9, n_phi=12)
    for starts in (1, 6):
        fitted, report = gonio.fit(data, model=model, lobes=0, starts=starts, threads=1)
        assert report["solver"]["usable"], report["solver"]
        assert fitted["lobes"] == []
        np.testing.assert_allclose(fitted["diffuse"], LAMBERT["diffuse"], rtol=1e-4)


def retro_samples():
    """A retro-reflection peak that no microfacet lobe at the mirror direction follows."""
    data = synthetic_samples(LAMBERT, n_theta=9, n_phi=12)
    ti, pi, to, po = (data[k] for k in ("theta_i", "phi_i", "theta_o", "phi_o"))
    wi = np.stack([np.sin(ti) * np.cos(pi), np.sin(ti) * np.sin(pi), np.cos(ti)], axis=1)
    wo = np.stack([np.sin(to) * np.cos(po), np.sin(to) * np.sin(po), np.cos(to)], axis=1)
    c = np.clip(np.sum(wi * wo, axis=1), 0, None)
    peak = 20 * c**30
    data["value"] = data["value"] + np.stack([peak, 0.5 * peak, 0.2 * peak], axis=1)
    return data


def test_the_verdict_is_the_same_headline_as_the_command_and_strict_fails_only_a_misfit():
    # The demo's material with the default GGX: a visible misfit of the blue channel, usable.
    data = synthetic_samples(gonio.material("red-plastic"), n_theta=9, n_phi=12)
    with pytest.warns(UserWarning) as caught:
        _, report = gonio.fit(data, model="ggx", threads=1, strict=True)
    goodness = report["goodness"]
    assert goodness["verdict"] == "visible-misfit", goodness
    assert "channel b" in goodness["headline"]
    assert goodness["headline"] in str(caught[0].message)
    # A retro peak: does not represent; strict raises with the same headline.
    with pytest.warns(UserWarning, match="MISFIT: does not represent these data"):
        _, report = gonio.fit(retro_samples(), threads=1)
    assert report["goodness"]["verdict"] == "does-not-represent"
    assert "--model auto" in report["goodness"]["suggestion"]
    with pytest.raises(gonio.Error, match="MISFIT: does not represent these data"):
        gonio.fit(retro_samples(), threads=1, strict=True)
    # After auto the suggestion is the measurement as a table, never auto again.
    with pytest.warns(UserWarning):
        _, report = gonio.fit(retro_samples(), model="auto", threads=1)
    assert "--model auto" not in report["goodness"]["suggestion"]
    assert "table.gtab --grid 32x16x8" in report["goodness"]["suggestion"]


def test_values_below_zero_within_noise_are_kept_and_a_far_one_is_rejected():
    data = synthetic_samples(LAMBERT, n_theta=9, n_phi=12)
    rng = np.random.default_rng(5)
    data["value"][:, 2] = rng.normal(0.0, 1e-6, len(data["theta_i"]))  # a black channel
    assert (data["value"][:, 2] < 0).sum() > 100
    fitted, report = gonio.fit(data, lobes=0, threads=1)
    assert report["samples"]["valid"] == len(data["theta_i"])
    assert report["samples"]["rejected"] == 0
    np.testing.assert_allclose(fitted["diffuse"][:2], LAMBERT["diffuse"][:2], rtol=1e-4)
    assert abs(fitted["diffuse"][2]) < 1e-4
    data["value"][7, 2] = -0.05
    _, report = gonio.fit(data, lobes=0, threads=1)
    assert report["samples"]["rejected"] == 1
