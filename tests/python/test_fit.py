"""gonio.fit: recovery of a known model, the report, and the GIL released during the solve."""

import threading
import time

import numpy as np
import pytest

import gonio
from conftest import TRUTH, synthetic_samples


def test_fit_recovers_ground_truth():
    data = synthetic_samples(TRUTH, n_theta=10, n_phi=13)
    model, report = gonio.fit(
        data, model="ggx", fresnel="schlick-rgb", residual="log", truth=TRUTH, threads=1
    )
    assert report["solver"]["usable"], report["solver"]
    lobe = model["lobes"][0]
    assert abs(lobe["alpha"] - 0.18) < 1e-4
    np.testing.assert_allclose(model["diffuse"], TRUTH["diffuse"], rtol=1e-4)
    np.testing.assert_allclose(lobe["fresnel"]["f0"], TRUTH["lobes"][0]["fresnel"]["f0"], rtol=1e-3)
    assert max(report["metrics"]["log_rmse"]) < 1e-6
    assert report["ground_truth"]["lobes"][0]["alpha"] == 0.18
    names = [p["name"] for p in report["parameters"]]
    assert "lobes[0].alpha_x" in names and "diffuse[0]" in names
    assert report["samples"]["valid"] == len(data["theta_i"])
    assert report["residual"] == "log"


def test_fit_with_noise_reports_uncertainties_covering_the_truth():
    data = synthetic_samples(TRUTH, n_theta=10, n_phi=13, noise=0.02, seed=42)
    data["sigma"] = 0.02 * np.abs(data["value"]) + 1e-9
    model, report = gonio.fit(
        data, model="ggx", fresnel="schlick-rgb", residual="absolute", threads=1
    )
    assert report["solver"]["usable"]
    alpha = next(p for p in report["parameters"] if p["name"] == "lobes[0].alpha_x")
    assert alpha["sigma"] is not None and alpha["sigma"] > 0
    assert abs(alpha["value"] - 0.18) < 5 * alpha["sigma"] + 1e-3


def test_fit_with_max_samples_uses_a_reduction():
    data = synthetic_samples(TRUTH, n_theta=12, n_phi=16)
    _, report = gonio.fit(data, fresnel="schlick-rgb", max_samples=500, threads=1)
    assert report["samples"]["used"] < report["samples"]["valid"]
    assert report["samples"]["valid"] == len(data["theta_i"])


def tenths_with_progress(work):
    """Runs work() in one thread while a second thread counts; returns the result and how many
    tenths of work()'s span saw the counter make progress."""
    span = {}
    ticks = []
    stop = threading.Event()

    def working():
        span["start"] = time.monotonic()
        span["result"] = work()
        span["end"] = time.monotonic()
        stop.set()

    def counting():
        while not stop.is_set():
            ticks.append(time.monotonic())

    counter = threading.Thread(target=counting)
    worker = threading.Thread(target=working)
    counter.start()
    worker.start()
    worker.join()
    counter.join()
    start, end = span["start"], span["end"]
    inside = [t for t in ticks if start < t < end]
    return span["result"], {min(int(10 * (t - start) / (end - start)), 9) for t in inside}


def test_fit_releases_the_gil():
    # 288,000 samples (60 x 60 x 80 angles): the fit takes a few tenths of a second, so that a
    # tenth of its span is long against the GIL's switch interval and the scheduler's slices on a
    # loaded machine.
    data = synthetic_samples(TRUTH, n_theta=60, n_phi=80)
    # Held by the solve, the GIL would let the counter run only at the Python edges of the call
    # (a few switch intervals of 5 ms: at most 3 tenths, as the control below shows). Released,
    # the counter runs throughout: its ticks fall in most tenths of the fit's span. A loaded
    # machine can take the counter's core away for a while, so the fit is measured up to three
    # times and the best kept: a held GIL never reaches the bound in any of them.
    best = set()
    for _ in range(3):
        result, tenths = tenths_with_progress(
            lambda: gonio.fit(data, model="beckmann", starts=8, threads=1)
        )
        assert result[1]["solver"]["iterations"] > 0
        if len(tenths) > len(best):
            best = tenths
        if len(best) >= 8:
            break
    assert len(best) >= 8, sorted(best)


def test_gil_measure_detects_a_call_that_holds_it():
    # Control of the measure above: sorting floats is one C call that keeps the GIL throughout.
    values = np.random.default_rng(0).random(3_000_000).tolist()
    _, tenths = tenths_with_progress(lambda: sorted(values))
    assert len(tenths) <= 3, sorted(tenths)


def test_fit_auto_ranks_candidates_and_refuses_structure_options():
    data = synthetic_samples(TRUTH, n_theta=8, n_phi=9)
    model, report = gonio.fit(data, model="auto", threads=1, max_samples=400)
    # The generating family wins (one GGX lobe; the two-lobe GGX is the same family) and the
    # model returned is the chosen one.
    chosen = report["auto"]["chosen"]
    assert chosen.split()[0] == "ggx", chosen
    assert [lobe["distribution"] for lobe in model["lobes"]] == ["ggx"] * len(model["lobes"]), model
    assert report["auto"]["ranking"][0]["name"] == chosen, report["auto"]["ranking"]
    assert len(report["auto"]["ranking"]) >= 3
    assert "BIC" in report["auto"]["criterion"]
    for key, value in [("lobes", 2), ("fresnel", "none"), ("diffuse", False)]:
        try:
            gonio.fit(data, model="auto", **{key: value})
        except gonio.Error as e:
            assert key in str(e) and "auto" in str(e), str(e)
        else:
            raise AssertionError(f"{key} with model='auto' was not refused")


def test_fit_with_rgb_roughness_gives_each_channel_its_alpha():
    truth = {
        "diffuse": TRUTH["diffuse"],
        "lobes": [dict(TRUTH["lobes"][0], alpha=[0.12, 0.18, 0.3])],
    }
    data = synthetic_samples(truth, n_theta=10, n_phi=13)
    model, report = gonio.fit(
        data, model="ggx", fresnel="schlick-rgb", roughness="rgb", residual="log", threads=1
    )
    assert report["solver"]["usable"], report["solver"]
    np.testing.assert_allclose(model["lobes"][0]["alpha"], [0.12, 0.18, 0.3], rtol=1e-4)
    names = [p["name"] for p in report["parameters"]]
    assert "lobes[0].alpha_rgb[2]" in names and "lobes[0].alpha_x" not in names
    with pytest.raises(gonio.Error, match="roughness"):
        gonio.fit(data, model="blinn-phong", roughness="rgb", threads=1)
    with pytest.raises(gonio.Error, match="roughness"):
        gonio.fit(data, model="ggx", roughness="grey", threads=1)
