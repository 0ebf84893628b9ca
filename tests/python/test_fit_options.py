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
