#!/usr/bin/python3
"""Rig time against error: point campaigns of several plans on the virtual rig with the reference
error budget (docs/error-budget.md), each fitted with the default model, on analytic and measured
truths served as the rig's ground truth.

    /usr/bin/python3 bench/rig_time_bench.py build/tools/gonio RGL_DIR [--out DIR] [--quick]

RGL_DIR holds the RGL files (acrylic_felt_green_rgb.bsdf, paper_white_rgb.bsdf,
satin_rosaline_rgb.bsdf); they are read from there. For each truth and plan the table gives the
measurements, the rig time the campaign recorded (metadata.json rig_time_s: motion, settle,
exposure and readout as the rig spends them) and the error of the campaign's fit:
- against the truth itself: the cosine-weighted relative L2 distance between the fitted model and
  the truth over a fixed grid of 2,000 direction pairs (theta up to 75 deg), and
- against the fit of the same model to the dense truth (the truth evaluated on the same grid):
  the same distance between the two fits (what a campaign can reach at best is 0).
Plans: uniform 7x5 grid, uniform 7x5 with one adaptive pass of 30 (the default campaign), the vndf
plan, and the uniform 10x8 grid with --until sigma=0.01 (stops when the fit is known).
"""

import argparse
import csv
import io
import json
import math
import os
import random
import shutil
import subprocess
import sys
import tempfile

GGX = ('{{"diffuse": [0.05, 0.05, 0.05], "lobes": [{{"distribution": "ggx", "alpha": {a}, '
       '"shadowing": "smith-correlated", "fresnel": {{"type": "schlick", "f0": [0.04, 0.04, 0.04]}}, '
       '"scale": [1, 1, 1]}}]}}')

PLANS = {
    "uniform 7x5": ["--n-theta", "7", "--n-dphi", "5", "--adaptive", "0"],
    "uniform 7x5 + adaptive 30": ["--n-theta", "7", "--n-dphi", "5", "--adaptive", "1"],
    "vndf": ["--plan", "vndf"],
    "uniform 10x8 --until sigma=0.01": ["--n-theta", "10", "--n-dphi", "8", "--adaptive", "0",
                                        "--until", "sigma=0.01"],
}


def run(cmd, **kw):
    r = subprocess.run(cmd, capture_output=True, text=True, **kw)
    if r.returncode != 0:
        raise RuntimeError(" ".join(cmd) + "\n" + r.stdout + r.stderr)
    return r.stdout


def direction_grid(n=2000, seed=7):
    """Seeded direction pairs, theta uniform in cos over [0, 75 deg], phi_o - phi_i uniform."""
    rnd = random.Random(seed)
    cmax = math.cos(math.radians(75))
    rows = []
    for _ in range(n):
        ti = math.acos(1 - rnd.random() * (1 - cmax))
        to = math.acos(1 - rnd.random() * (1 - cmax))
        rows.append((ti, 0.0, to, rnd.uniform(0, 2 * math.pi)))
    # Half of them near the mirror direction, where glossy lobes live.
    for k in range(n // 2):
        ti = rows[k][0]
        rows[k] = (ti, 0.0, min(ti + rnd.gauss(0, 0.05), math.radians(75)) if ti > 0.05 else ti,
                   math.pi + rnd.gauss(0, 0.05))
    return rows


def evaluate(gonio, brdf, grid_csv):
    out = run([gonio, "eval", brdf, "-i", grid_csv])
    return [tuple(float(x) for x in row) for row in list(csv.reader(io.StringIO(out)))[1:]]


def cos_weighted_l2(a, b, grid):
    """sqrt(sum (cos_i (a - b))^2 / sum (cos_i b)^2) over channels and directions."""
    num = den = 0.0
    for (ti, _, _, _), va, vb in zip(grid, a, b):
        c = math.cos(ti)
        for x, y in zip(va, vb):
            num += (c * (x - y)) ** 2
            den += (c * y) ** 2
    return math.sqrt(num / den)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("gonio")
    ap.add_argument("rgl_dir")
    ap.add_argument("--out", default=None)
    ap.add_argument("--quick", action="store_true", help="GGX 0.05 and one RGL file only")
    a = ap.parse_args()
    work = a.out or tempfile.mkdtemp(prefix="rig_time_bench_")
    os.makedirs(work, exist_ok=True)
    grid = direction_grid()
    grid_csv = os.path.join(work, "grid.csv")
    with open(grid_csv, "w") as f:
        f.write("theta_i,phi_i,theta_o,phi_o\n")
        for r in grid:
            f.write("%.17g,%.17g,%.17g,%.17g\n" % r)
    truths = {}
    for alpha in ("0.05", "0.3"):
        p = os.path.join(work, "ggx_%s.json" % alpha)
        with open(p, "w") as f:
            f.write(GGX.format(a=alpha))
        truths["GGX " + alpha] = p
    for name in ("satin_rosaline_rgb", "paper_white_rgb", "acrylic_felt_green_rgb"):
        truths[name] = os.path.join(a.rgl_dir, name + ".bsdf")
    if a.quick:
        truths = {k: truths[k] for k in ("GGX 0.05", "satin_rosaline_rgb")}
    print("| truth | plan | measurements | rig time (s) | fit vs truth | fit vs dense fit |")
    print("| --- | --- | --- | --- | --- | --- |")
    sys.stdout.flush()
    for tname, tpath in truths.items():
        truth_vals = evaluate(a.gonio, tpath, grid_csv)
        dense = os.path.join(work, tname.replace(" ", "_") + "_dense.csv")
        with open(dense, "w") as f:
            f.write("theta_i,phi_i,theta_o,phi_o,r,g,b\n")
            for r, v in zip(grid, truth_vals):
                f.write("%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g\n" % (r + v))
        dense_fit = os.path.join(work, tname.replace(" ", "_") + "_dense_fit.json")
        run([a.gonio, "fit", dense, "--out", dense_fit])
        dense_vals = evaluate(a.gonio, dense_fit, grid_csv)
        for pname, args in PLANS.items():
            d = os.path.join(work, (tname + "_" + pname).replace(" ", "_").replace("=", ""))
            shutil.rmtree(d, ignore_errors=True)
            try:
                run([a.gonio, "acquire", "--brdf", tpath, "--out", d, "--time-scale", "1000"] +
                    args)
                meta = json.load(open(os.path.join(d, "metadata.json")))
                fit = os.path.join(d, "fit.json")
                run([a.gonio, "fit", os.path.join(d, "dataset.csv"), "--out", fit])
                vals = evaluate(a.gonio, fit, grid_csv)
                print("| %s | %s | %d | %.0f | %.4f | %.4f |" % (
                    tname, pname, meta["measured"], meta["rig_time_s"],
                    cos_weighted_l2(vals, truth_vals, grid), cos_weighted_l2(vals, dense_vals, grid)))
            except RuntimeError as e:
                print("| %s | %s | failed: %s | | | |" % (tname, pname,
                                                        str(e).splitlines()[-1][:80]))
            sys.stdout.flush()


if __name__ == "__main__":
    main()
