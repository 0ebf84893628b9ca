"""The measures of bench/rig_time_bench.py (the rig-time-to-error benchmark) against values
computed by hand: the cosine-weighted relative L2 of a scaled truth, the interpolation of the
rig time to an error level, and the fit and data errors of a truth's own values."""

import csv
import math
import os
import sys

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "bench"))
import rig_time_bench as rtb  # noqa: E402


def test_cos_weighted_l2_of_a_truth_scaled_by_two_percent_is_two_percent():
    grid = [(0.1, 0, 0.2, 3.0), (0.9, 0, 0.5, 1.0), (1.2, 0, 1.2, 3.14)]
    truth = [(1.0, 2.0, 3.0), (0.1, 0.1, 0.2), (5.0, 1.0, 0.5)]
    scaled = [tuple(1.02 * x for x in v) for v in truth]
    assert rtb.cos_weighted_l2(scaled, truth, grid) == pytest.approx(0.02, rel=1e-12)
    # Only the first value off, by 0.5: 0.5 cos(0.1) over the norm of the cos-weighted values.
    off = [(1.5, 2.0, 3.0)] + truth[1:]
    norm = math.sqrt(sum((math.cos(g[0]) * x) ** 2 for g, v in zip(grid, truth) for x in v))
    assert rtb.cos_weighted_l2(off, truth, grid) == pytest.approx(0.5 * math.cos(0.1) / norm)


def test_time_to_reach_interpolates_the_best_error_so_far_in_log_log():
    pts = [{"rig_s": 10.0, "e": 0.04}, {"rig_s": 20.0, "e": 0.05}, {"rig_s": 40.0, "e": 0.01}]
    # Between (10 s, 0.04) (the best before 40 s) and (40 s, 0.01): 0.02 lies half-way in log
    # error, so half-way in log time: sqrt(10 * 40) = 20 s.
    t, how = rtb.time_to_reach(pts, 0.02, "e")
    assert how == "interpolated"
    assert t == pytest.approx(20.0)
    assert rtb.time_to_reach(pts, 0.05, "e") == (10.0, "first")
    assert rtb.time_to_reach(pts, 0.005, "e") == (None, None)


def test_a_run_of_named_plans_reports_each_familys_time_to_an_error(capsys):
    # (label, measurements, rig s, (vs dense fit, vs truth, alpha), stopped), as run_family gives.
    per_family = {
        "uniform": [("uniform 7x5 mono stop-and-go", 105, 126.0, (0.004, 0.004, 0.001), "end"),
                    ("uniform 16x2 mono stop-and-go", 233, 193.0, (0.002, 0.002, 0.001), "end")],
        "fit": [("fit mono --fly", 120, 75.0, (0.0015, 0.0015, 0.0003), "end")],
    }
    rtb.report_ratios("ggx-0.05", per_family)
    out = capsys.readouterr().out
    # 1.5 x the 7x5 grid's 0.004 is 0.006: the 7x5 grid reaches it at 126 s, the fit plan at 75 s.
    assert "rig time to reach 0.0060" in out
    assert "uniform: 126 s" in out
    assert "fit: 75 s (uniform / this 1.68)" in out
    # 1 %: the same.
    assert "rig time to reach 0.0100" in out


def write_dataset(path, grid, values):
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(["theta_i", "phi_i", "theta_o", "phi_o", "r", "g", "b"])
        for r, v in zip(grid, values):
            w.writerow(["%.17g" % x for x in r + tuple(v)])


@pytest.mark.skipif(not os.environ.get("GONIO_EXE"), reason="needs the gonio binary (GONIO_EXE)")
def test_a_truths_own_values_scaled_by_two_percent_are_two_percent_off(tmp_path):
    work = str(tmp_path)
    truth = rtb.MissionTruth(os.environ["GONIO_EXE"], "ggx-0.3",
                             rtb.truth_path("ggx-0.3", "", work), False, work)
    assert truth.dense_alphas == [pytest.approx(0.3, rel=1e-6)]
    data = os.path.join(work, "scaled.csv")
    write_dataset(data, truth.grid, [tuple(1.02 * x for x in v) for v in truth.values])
    # A GGX lobe and a diffuse term scaled by 1.02 are the model with both scaled: the fit is the
    # truth times 1.02, 2 % from the truth and from the dense fit, with the same alpha.
    e = truth.fit_errors(data, os.path.join(work, "scaled_fit.json"))
    assert e["fit_truth"] == pytest.approx(0.02, rel=1e-3)
    assert e["fit_dense"] == pytest.approx(0.02, rel=1e-3)
    assert e["alpha"] < 1e-4
    # The data alone, interpolated, at the grid's own configurations: the values themselves.
    assert truth.data_error(data) == pytest.approx(0.02, rel=1e-3)


def test_ratios_to_the_fit_driven_plan_say_which_side_a_bound_is_on():
    pts = [{"rig_s": 300.0}, {"rig_s": 600.0}]
    assert rtb.ratio_text(100.0, "interpolated", pts, (20.0, "interpolated")) == "5.00"
    # Not reached in its longest campaign (600 s): more than 600 / 20.
    assert rtb.ratio_text(None, None, pts, (20.0, "interpolated")) == "> 30.00"
    # Reached at its smallest budget: at most; the fit-driven plan at its first: at least.
    assert rtb.ratio_text(100.0, "first", pts, (20.0, "interpolated")) == "<= 5.00"
    assert rtb.ratio_text(100.0, "interpolated", pts, (20.0, "first")) == ">= 5.00"
    assert rtb.met("5.00", 5) == "yes" and rtb.met("4.99", 5) == "no"
    assert rtb.met("> 30.00", 5) == "yes" and rtb.met("<= 4.00", 5) == "no"
    assert rtb.met(">= 3.69", 5).startswith("open")
