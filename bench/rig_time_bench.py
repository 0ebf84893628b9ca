#!/usr/bin/python3
"""Rig time against error: point campaigns of several plans on the virtual rig with the reference
error budget (docs/error-budget.md), each fitted with the default model, on analytic and measured
truths served as the rig's ground truth.

    /usr/bin/python3 bench/rig_time_bench.py build/tools/gonio RGL_DIR [--out DIR]
        [--truth NAME[,NAME...]] [--plan NAME[,NAME...]] [--json FILE] [--plot PNG]
    /usr/bin/python3 bench/rig_time_bench.py --plot-only RESULTS.json OUT.png|OUT.svg|--tables

RGL_DIR holds the RGL files (acrylic_felt_green_rgb.bsdf, paper_white_rgb.bsdf,
satin_rosaline_rgb.bsdf); they are read from there. Truths: ggx-0.05, ggx-0.3, brushed (anisotropic
GGX, alpha 0.1 x 0.3, turned 30 deg), satin, paper, felt. Plans (families): uniform (grids 4x3, 5x4,
7x5, 10x8: a curve), half-diff, vndf, adaptive (uniform 5x4 and 7x5 with one neighbour-adaptive
pass of 30), uniform-until (10x8 --until sigma=0.01), fit (--plan fit to its budget of 120: a
curve, one point per batch, each the fit of the measurements before it) and fit-until (--plan fit
--until sigma=0.01), and fly (stop-and-go against `--fly` on the same plan, on the monochrome
rig data/rigs/sim4-mono.json: uniform 7x5, uniform 16x2 (in-plane), and the fit plan; brushed: the
anisotropic fit plan alone). The brushed truth runs the anisotropic variants (uniform: --anisotropic;
vndf: --plan vndf --anisotropic; fit: --plan fit --anisotropic; half-diff and adaptive have none)
and is fitted with --anisotropic.

For each point: the measurements, the rig time the campaign recorded (metadata.json rig_time_s:
motion, settle, exposure and readout as the rig spends them) and the error of its fit:
- "vs dense fit": the cosine-weighted relative L2 distance between the campaign's fit and the
  same model fitted to the truth on a fixed grid of 2,000 direction pairs (theta up to 75 deg,
  half of them near the mirror direction): how far the campaign is from what the model can do;
- "vs truth": the same distance to the truth itself;
- "alpha": the relative difference of the first lobe's alpha (alpha_x) from the dense fit's.
Then, per truth, the rig time each family needs to reach the error of the uniform 7x5 grid (the
default campaign's grid) and the ratio of the uniform plan's to it.

The mission's table (docs/benchmarks/rig-time.md):

    /usr/bin/python3 bench/rig_time_bench.py build/tools/gonio RGL_DIR --mission [--quick]
        [--out DIR [--reuse]] [--json FILE] [--plot FIGURE.svg] [--fly-time-scale S]

Every plan at a ladder of budgets, stop-and-go and with fly scans (`--fly`), all on the monochrome
rig data/rigs/sim4-mono.json (reference error budget; fly scans refuse a colour filter changer, and
one rig for every campaign keeps the plans comparable): uniform 3x2, 4x3, 5x4, 7x5 (brushed: the
anisotropic grid 3x2 .. 5x4), half-diff (its default 8x8x6: the command line does not size it),
vndf (--vndf-resolution 6, 10, 16; brushed: the anisotropic vndf plan at 4 and 8 with 4 theta_i
and 4 phi_i), neighbour-adaptive (uniform 4x3, 5x4, 7x5 with one adaptive pass) and fit (to its
budget, one point per batch). The truths as a monochrome detector sees them: the mean of R, G and
B. Errors per point: the fit's against the dense fit's and the truth's (as above), the first
lobe's alphas against the dense fit's, and "data alone": the campaign's values without a fit
(the vndf plan's dataset.bsdf; the other plans' measurements interpolated as the vndf benchmark
does, inverse-distance weighting of the 8 nearest in ln f) against the truth, cosine-weighted
relative L2 on the same grid. Per truth and measure, the rig time each plan and mode needs to
reach a common error level (common_level()), interpolated on its curve (time_to_reach()), and
its ratio to the fit-driven plan's (with fly scans where `--plan fit --fly` runs, else
stop-and-go). --quick: GGX 0.3, the uniform and fit plans, two budgets (about a minute).
--plot writes FIGURE.svg (fit vs dense fit) and FIGURE_data.svg (data alone).
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
BRUSHED = ('{"diffuse": [0.05, 0.05, 0.05], "lobes": [{"distribution": "ggx", "alpha_x": 0.1, '
           '"alpha_y": 0.3, "orientation_deg": 30, "shadowing": "smith-correlated", '
           '"fresnel": {"type": "schlick", "f0": [0.04, 0.04, 0.04]}, "scale": [1, 1, 1]}]}')
RGL = {"satin": "satin_rosaline_rgb", "paper": "paper_white_rgb", "felt": "acrylic_felt_green_rgb"}
TRUTHS = ["ggx-0.05", "ggx-0.3", "brushed", "satin", "paper", "felt"]
GLOSSY = {"ggx-0.05", "brushed", "satin"}

UNIFORM_GRIDS = [(4, 3), (5, 4), (7, 5), (10, 8)]
REFERENCE_GRID = "uniform 7x5"


def plan_runs(family, aniso):
    """(label, acquire arguments, is a curve of batches) of a plan family; none when the family
    has no anisotropic variant."""
    a = ["--anisotropic"] if aniso else []
    if family == "uniform":
        return [("uniform %dx%d" % g, a + ["--n-theta", str(g[0]), "--n-dphi", str(g[1])] +
                 ([] if aniso else ["--adaptive", "0"]), False) for g in UNIFORM_GRIDS]
    if family == "half-diff":
        return [] if aniso else [("half-diff", ["--plan", "half-diff", "--adaptive", "0"], False)]
    if family == "vndf":
        return [("vndf", ["--plan", "vndf"] + a, False)]
    if family == "adaptive":
        return [] if aniso else [
            ("uniform 5x4 + adaptive 30", ["--n-theta", "5", "--n-dphi", "4", "--adaptive", "1"],
             False),
            ("uniform 7x5 + adaptive 30", ["--n-theta", "7", "--n-dphi", "5", "--adaptive", "1"],
             False)]
    if family == "uniform-until":
        return [("uniform 10x8 --until sigma=0.01", a + ["--n-theta", "10", "--n-dphi", "8"] +
                 ([] if aniso else ["--adaptive", "0"]) + ["--until", "sigma=0.01"], False)]
    if family == "fit":
        return [("fit", ["--plan", "fit"] + a, True)]
    if family == "fly":
        mono = ["--rig", MONO_RIG]
        # Fly scans need the arms to keep pace with the camera: a slower virtual rig (the rig
        # time it records does not depend on the scale).
        fly = ["--fly", "--time-scale", "5"]
        runs = []
        plans = ((("fit", ["--plan", "fit", "--anisotropic"]),) if aniso else
                 (("uniform 7x5", ["--n-theta", "7", "--n-dphi", "5", "--adaptive", "0"]),
                  ("uniform 16x2", ["--n-theta", "16", "--n-dphi", "2", "--adaptive", "0"]),
                  ("fit", ["--plan", "fit"])))
        for label, plan in plans:
            runs.append((label + " mono stop-and-go", mono + plan, False))
            runs.append((label + " mono --fly", mono + plan + fly, False))
        return runs
    if family == "fit-until":
        return [("fit --until sigma=0.01", ["--plan", "fit"] + a + ["--until", "sigma=0.01"],
                 False)]
    raise SystemExit("unknown plan family " + family)


FAMILIES = ["uniform", "half-diff", "vndf", "adaptive", "uniform-until", "fit", "fit-until", "fly"]
MONO_RIG = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "data", "rigs",
                        "sim4-mono.json")


def run(cmd):
    # Niced: the campaigns' rig time does not depend on the machine's load, only their wall time.
    r = subprocess.run(["nice", "-n", "10"] + cmd, capture_output=True, text=True)
    if r.returncode != 0:
        raise RuntimeError(" ".join(cmd) + "\n" + r.stdout + r.stderr)
    return r.stdout


def direction_grid(aniso, n=2000, seed=7):
    """Seeded direction pairs, theta uniform in cos over [0, 75 deg]; phi_i = 0 for isotropic
    truths, uniform for anisotropic ones; half of them near the mirror direction."""
    rnd = random.Random(seed)
    cmax = math.cos(math.radians(75))
    rows = []
    for _ in range(n):
        ti = math.acos(1 - rnd.random() * (1 - cmax))
        to = math.acos(1 - rnd.random() * (1 - cmax))
        pi = rnd.uniform(0, 2 * math.pi) if aniso else 0.0
        rows.append((ti, pi, to, pi + rnd.uniform(0, 2 * math.pi)))
    for k in range(n // 2):
        ti, pi = rows[k][0], rows[k][1]
        rows[k] = (ti, pi, min(abs(ti + rnd.gauss(0, 0.05)), math.radians(75)) if ti > 0.05 else ti,
                   pi + math.pi + rnd.gauss(0, 0.05))
    # Azimuths within [-pi, pi] (a dataset's range is [-2 pi, 2 pi]); the same directions.
    return [(ti, wrap(pi), to, wrap(po)) for ti, pi, to, po in rows]


def wrap(phi):
    return math.atan2(math.sin(phi), math.cos(phi))


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


def alpha_of(fit_json):
    with open(fit_json) as f:
        m = json.load(f)
    lobes = m.get("lobes") or [{}]
    return lobes[0].get("alpha", lobes[0].get("alpha_x"))


class Truth:
    """A ground truth on the error grid: its values, the dense fit and its values. grey: as a
    monochrome rig sees it (the mean of R, G and B in every channel)."""

    def __init__(self, gonio, name, path, aniso, work, grey=False):
        self.gonio, self.name, self.path, self.aniso = gonio, name, path, aniso
        # The GGX model (one lobe and a diffuse term), named: `gonio fit` without --model ranks
        # several models, and the benchmark compares plans on one model.
        self.fit_args = ["--model", "ggx"] + (["--anisotropic"] if aniso else [])
        self.grid = direction_grid(aniso)
        self.grid_csv = os.path.join(work, name + "_grid.csv")
        with open(self.grid_csv, "w") as f:
            f.write("theta_i,phi_i,theta_o,phi_o\n")
            for r in self.grid:
                f.write("%.17g,%.17g,%.17g,%.17g\n" % r)
        self.values = evaluate(gonio, path, self.grid_csv)
        if grey:
            self.values = [(sum(v) / len(v),) * len(v) for v in self.values]
        dense = os.path.join(work, name + ("_grey" if grey else "") + "_dense.csv")
        with open(dense, "w") as f:
            f.write("theta_i,phi_i,theta_o,phi_o,r,g,b\n")
            for r, v in zip(self.grid, self.values):
                f.write("%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g\n" % (r + v))
        self.dense_fit = os.path.join(work, name + ("_grey" if grey else "") + "_dense_fit.json")
        run([gonio, "fit", dense, "--out", self.dense_fit] + self.fit_args)
        self.dense_values = evaluate(gonio, self.dense_fit, self.grid_csv)
        self.dense_alpha = alpha_of(self.dense_fit)

    def errors(self, dataset, fit_json):
        """(vs dense fit, vs truth, relative alpha difference) of the fit of `dataset`."""
        try:
            run([self.gonio, "fit", dataset, "--out", fit_json] + self.fit_args)
        except RuntimeError as e:
            if not os.path.exists(fit_json):
                raise e
        vals = evaluate(self.gonio, fit_json, self.grid_csv)
        a = alpha_of(fit_json)
        da = abs(a / self.dense_alpha - 1) if a and self.dense_alpha else float("nan")
        return (cos_weighted_l2(vals, self.dense_values, self.grid),
                cos_weighted_l2(vals, self.values, self.grid), da)


def prefix_dataset(dataset, n, out):
    """The first n measurement rows of a campaign's dataset.csv (drift references kept)."""
    with open(dataset) as f:
        rows = list(csv.reader(f))
    head, body = rows[0], rows[1:]
    flags = head.index("flag") if "flag" in head else None
    kept, count = [], 0
    for r in body:
        reference = flags is not None and int(float(r[flags])) & 4
        if not reference:
            if count == n:
                break
            count += 1
        kept.append(r)
    with open(out, "w", newline="") as f:
        csv.writer(f).writerows([head] + kept)


def campaign(truth, label, args, curve, work):
    """Points (label, measurements, rig seconds, errors, stopped) of one campaign."""
    d = os.path.join(work, (truth.name + "_" + label).replace(" ", "_").replace("=", ""))
    shutil.rmtree(d, ignore_errors=True)
    scale = [] if "--time-scale" in args else ["--time-scale", "1000"]
    run([truth.gonio, "acquire", "--brdf", truth.path, "--out", d] + scale + args)
    meta = json.load(open(os.path.join(d, "metadata.json")))
    dataset = os.path.join(d, "dataset.csv")
    stopped = meta["runs"][-1].get("stopped", "")
    points = []
    if curve:
        batches = sorted(meta.get("fit_plan", {}).get("batches", {}).values(),
                         key=lambda b: b["measured_before"])
        for b in batches:
            n = b["measured_before"]
            part = os.path.join(d, "prefix_%d.csv" % n)
            prefix_dataset(dataset, n, part)
            points.append(("%s (%d)" % (label, n), n, b["rig_time_s"],
                           truth.errors(part, os.path.join(d, "fit_%d.json" % n)), ""))
    points.append((label, meta["measured"], meta["rig_time_s"],
                   truth.errors(dataset, os.path.join(d, "fit.json")), stopped))
    return points


def least_time_within(points, target):
    """The least rig time among (label, n, rig s, errors, stopped) points whose error (vs dense
    fit) is at most target."""
    ok = [p[2] for p in points if p[3][0] <= target]
    return min(ok) if ok else None


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("gonio")
    ap.add_argument("rgl_dir")
    ap.add_argument("--out", default=None)
    ap.add_argument("--truth", default=None, help="comma-separated: " + ", ".join(TRUTHS))
    ap.add_argument("--plan", default=None, help="comma-separated: " + ", ".join(FAMILIES) +
                    " (with --mission: " + ", ".join(MISSION_PLANS) + ")")
    ap.add_argument("--json", default=None, help="write every point here (--plot-only redraws it)")
    ap.add_argument("--plot", default=None, help="draw error against rig time into this PNG "
                    "(matplotlib; with --mission: SVG files PLOT and PLOT's name + _data)")
    ap.add_argument("--mission", action="store_true", help="every plan at a ladder of budgets, "
                    "stop-and-go and fly, on the monochrome rig: rig time to a common error")
    ap.add_argument("--quick", action="store_true", help="with --mission: a smoke run (GGX 0.3, "
                    "the uniform and fit plans, two budgets) unless --truth and --plan say more")
    ap.add_argument("--fly-time-scale", type=float, default=5,
                    help="time scale of the virtual rig in fly scans (the rig time does not depend "
                    "on it; an arm that triggers by polling has to keep pace in wall time)")
    ap.add_argument("--reuse", action="store_true", help="with --mission and --out: take the "
                    "finished campaigns already in DIR as they are (run only the missing ones)")
    a = ap.parse_args()
    work = a.out or tempfile.mkdtemp(prefix="rig_time_bench_")
    os.makedirs(work, exist_ok=True)
    if a.mission:
        a.truth = a.truth or ("ggx-0.3" if a.quick else ",".join(TRUTHS))
        a.plan = a.plan or ("uniform,fit" if a.quick else ",".join(MISSION_PLANS))
        results = mission(a, work)
        for key in ("fit_dense", "data"):
            print("\nRig time to the common level, %s:\n" % key)
            print("\n".join(mission_tables(results, key)))
        if a.plot:
            svg_figure(results, a.plot)
            root, ext = os.path.splitext(a.plot)
            svg_figure(results, root + "_data" + ext, "data", "data alone vs truth")
        return
    a.truth = a.truth or ",".join(TRUTHS)
    a.plan = a.plan or ",".join(FAMILIES)
    families = a.plan.split(",")
    if "uniform" not in families:
        print("(without the uniform family there is no reference error; ratios omitted)")
    print("| truth | plan | measurements | rig time (s) | vs dense fit | vs truth | alpha | stopped |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    sys.stdout.flush()
    results = {}
    for tname in a.truth.split(","):
        aniso = tname == "brushed"
        if tname in RGL:
            path = os.path.join(a.rgl_dir, RGL[tname] + ".bsdf")
        elif tname in ("ggx-0.05", "ggx-0.3", "brushed"):
            path = os.path.join(work, tname + ".json")
            with open(path, "w") as f:
                f.write(BRUSHED if aniso else GGX.format(a=tname.split("-")[1]))
        else:
            raise SystemExit("unknown truth " + tname)
        truth = Truth(a.gonio, tname, path, aniso, work)
        per_family = {}
        for fam in families:
            for label, args, curve in plan_runs(fam, aniso):
                try:
                    pts = campaign(truth, label, args, curve, work)
                except RuntimeError as e:
                    print("| %s | %s | failed: %s | | | | | |" % (
                        tname, label, str(e).strip().splitlines()[-1][:80]))
                    sys.stdout.flush()
                    continue
                per_family.setdefault(fam, []).extend(pts)
                for p in pts:
                    print("| %s | %s | %d | %.0f | %.4f | %.4f | %.4f | %s |" % (
                        tname, p[0], p[1], p[2], p[3][0], p[3][1], p[3][2], p[4]))
                    sys.stdout.flush()
        results[tname] = per_family
        report_ratios(tname, per_family)
    if a.json:
        with open(a.json, "w") as f:
            json.dump(results, f, indent=1)
    if a.plot:
        plot(results, a.plot)


def report_ratios(tname, per_family):
    """Rig time of each family to reach two errors: 1.5 x that of the uniform 7x5 grid (the
    default campaign's, with room for the scatter of the rig's error budget) and 1 %."""
    ref = [p for p in per_family.get("uniform", []) if p[0].startswith(REFERENCE_GRID)]
    targets = ([("1.5 x uniform 7x5", 1.5 * ref[0][3][0])] if ref else []) + [("1 %", 0.01)]
    for what, target in targets:
        t_uniform = least_time_within(per_family.get("uniform", []), target)
        t_vndf = least_time_within(per_family.get("vndf", []), target)
        print("\n%s: rig time to reach %.4f vs dense fit (%s):" % (tname, target, what))
        for fam, pts in per_family.items():
            t = least_time_within(pts, target)
            if t is None:
                best = min(pts, key=lambda p: p[3][0])
                print("  %s: not reached (best %.4f at %.0f s)" % (fam, best[3][0], best[2]))
                continue
            ratios = []
            if t_uniform:
                ratios.append("uniform / this %.2f" % (t_uniform / t))
            if t_vndf:
                ratios.append("vndf / this %.2f" % (t_vndf / t))
            print("  %s: %.0f s (%s)" % (fam, t, ", ".join(ratios)))
    print()
    sys.stdout.flush()


def plot(results, png):
    """Error against rig time, one panel per truth, one line per plan family (matplotlib)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    names = list(results)
    cols = min(3, len(names))
    rows = (len(names) + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 3.4 * rows), squeeze=False)
    styles = {"uniform": "o-", "half-diff": "s", "vndf": "D", "adaptive": "^-",
              "uniform-until": "v", "fit": ".-", "fit-until": "*", "fly": "P"}
    for ax, tname in zip(axes.flat, names):
        for fam, pts in results[tname].items():
            pts = sorted(pts, key=lambda p: p[2])
            ax.plot([p[2] for p in pts], [p[3][0] for p in pts], styles.get(fam, "x-"),
                    label=fam, markersize=8 if fam == "fit-until" else 5)
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_title(tname)
        ax.set_xlabel("rig time (s)")
        ax.set_ylabel("fit vs dense fit (cos-weighted rel. L2)")
        ax.grid(True, which="both", alpha=0.3)
    for ax in list(axes.flat)[len(names):]:
        ax.axis("off")
    axes.flat[0].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(png, dpi=90)



# ---------------------------------------------------------------------------------------------
# The mission's table (--mission): every plan at a ladder of budgets, stop-and-go and fly, on the
# monochrome rig; the rig time each needs to reach a common error.

MISSION_PLANS = ["uniform", "half-diff", "vndf", "adaptive", "fit"]
MODES = ["stop", "fly"]
# The plans of the aim: the fit-driven plan with fly scans against these (stop-and-go).
AIM_BASES = {"uniform": 5.0, "vndf": 2.0}


def mission_ladder(family, aniso, quick):
    """(label, acquire arguments, is a curve of batches) of a plan family's ladder of budgets;
    empty when the family has no anisotropic variant. quick: two budgets (one for vndf)."""
    if family == "uniform":
        grids = [(3, 2), (4, 3), (5, 4), (7, 5)] if not aniso else [(3, 2), (3, 3), (4, 3), (5, 4)]
        if quick:
            grids = grids[:2]
        return [("uniform %dx%d" % g, (["--anisotropic"] if aniso else ["--adaptive", "0"]) +
                 ["--n-theta", str(g[0]), "--n-dphi", str(g[1])], False) for g in grids]
    if family == "half-diff":
        # The command line does not size the half-diff plan (campaign.json does, and a campaign
        # file names its own rig): its default 8 x 8 x 6 grid only.
        return [] if aniso else [("half-diff 8x8x6", ["--plan", "half-diff", "--adaptive", "0"],
                                  False)]
    if family == "vndf":
        # The anisotropic plan's retro-reflection pass alone is about 930 configurations.
        res = [4, 8] if aniso else [6, 10, 16]
        extra = ["--anisotropic", "--vndf-phi-i", "4", "--vndf-theta-i", "4"] if aniso else []
        if quick:
            res = res[:1]
        return [("vndf %d" % r, ["--plan", "vndf", "--vndf-resolution", str(r)] + extra, False)
                for r in res]
    if family == "adaptive":
        grids = [(4, 3), (5, 4), (7, 5)][:2 if quick else 3]
        return [] if aniso else [
            ("uniform %dx%d + adaptive" % g,
             ["--n-theta", str(g[0]), "--n-dphi", str(g[1]), "--adaptive", "1"], False)
            for g in grids]
    if family == "fit":
        return [("fit", ["--plan", "fit"] + (["--anisotropic"] if aniso else []), True)]
    raise SystemExit("unknown plan family " + family)


def grey_values(dataset):
    """(rows of (theta_i, phi_i, theta_o, phi_o), mean of r, g, b) of a dataset's plan samples
    (drift references and saturated values left out)."""
    with open(dataset) as f:
        rows = [r for r in csv.reader(f) if r and not r[0].startswith("#")]
    head = rows[0]
    col = {k: head.index(k) for k in head}
    dirs, vals = [], []
    for r in rows[1:]:
        if "flag" in col and int(float(r[col["flag"]])) & 5:
            continue
        dirs.append(tuple(float(r[col[k]]) for k in ("theta_i", "phi_i", "theta_o", "phi_o")))
        vals.append(sum(float(r[col[k]]) for k in ("r", "g", "b")) / 3)
    return dirs, vals


def embed(dirs, aniso):
    """Points of the 6-D space in which measurements are interpolated (as the vndf benchmark):
    isotropic, (wi, wo) turned to phi_i = 0 with delta_phi folded to [0, pi] and the pair ordered
    theta_i <= theta_o; anisotropic, (wi, wo) as measured."""
    import numpy as np
    d = np.asarray(dirs, dtype=float).reshape(-1, 4)
    ti, pi, to, po = d[:, 0], d[:, 1], d[:, 2], d[:, 3]
    if aniso:
        return np.stack([np.sin(ti) * np.cos(pi), np.sin(ti) * np.sin(pi), np.cos(ti),
                         np.sin(to) * np.cos(po), np.sin(to) * np.sin(po), np.cos(to)], axis=1)
    dphi = np.abs(np.angle(np.exp(1j * (po - pi))))
    a, b = np.minimum(ti, to), np.maximum(ti, to)
    return np.stack([np.sin(a), np.zeros_like(a), np.cos(a), np.sin(b) * np.cos(dphi),
                     np.sin(b) * np.sin(dphi), np.cos(b)], axis=1)


def interpolate_data(dirs, vals, grid, aniso, k=8):
    """The measurements alone on the grid: inverse-distance weighting (1 / d^2, in ln f) of the
    k nearest measured configurations (anisotropic: each also at its reciprocal pair)."""
    import numpy as np
    pts = embed(dirs, aniso)
    logv = np.log(np.maximum(np.asarray(vals, dtype=float), 1e-9))
    if aniso:
        swapped = [(r[2], r[3], r[0], r[1]) for r in dirs]
        pts = np.concatenate([pts, embed(swapped, aniso)])
        logv = np.concatenate([logv, logv])
    q = embed(grid, aniso)
    out = []
    for s in range(0, len(q), 250):
        d2 = ((q[s:s + 250, None, :] - pts[None, :, :]) ** 2).sum(axis=2)
        kn = min(k, pts.shape[0])
        idx = np.argpartition(d2, kn - 1, axis=1)[:, :kn]
        w = 1.0 / np.maximum(np.take_along_axis(d2, idx, axis=1), 1e-12)
        out.extend(np.exp((w * logv[idx]).sum(axis=1) / w.sum(axis=1)))
    return [(v, v, v) for v in out]


def lobe_alphas(fit_json):
    """The first lobe's roughness parameters (alpha, or alpha_x and alpha_y)."""
    with open(fit_json) as f:
        lobe = (json.load(f).get("lobes") or [{}])[0]
    return [lobe[k] for k in ("alpha", "alpha_x", "alpha_y") if k in lobe]


class MissionTruth(Truth):
    """A truth as the monochrome rig sees it, with the errors of the mission's table."""

    def __init__(self, gonio, name, path, aniso, work):
        super().__init__(gonio, name, path, aniso, work, grey=True)
        self.dense_alphas = lobe_alphas(self.dense_fit)

    def fit_errors(self, dataset, fit_json):
        """{"fit_dense", "fit_truth", "alpha"} of the fit of `dataset` (alpha: the largest
        relative difference of the first lobe's alphas from the dense fit's)."""
        dense, truth, _ = self.errors(dataset, fit_json)
        mine = lobe_alphas(fit_json)
        da = max([abs(a / b - 1) for a, b in zip(mine, self.dense_alphas)] or [float("nan")])
        return {"fit_dense": dense, "fit_truth": truth, "alpha": da}

    def data_error(self, dataset, bsdf=None):
        """The campaign's data alone against the truth: its RGL file where it wrote one (the vndf
        plan), else its measurements interpolated (interpolate_data)."""
        if bsdf and os.path.exists(bsdf):
            vals = [(sum(v) / len(v),) * len(v) for v in evaluate(self.gonio, bsdf, self.grid_csv)]
        else:
            dirs, v = grey_values(dataset)
            vals = interpolate_data(dirs, v, self.grid, self.aniso)
        return cos_weighted_l2(vals, self.values, self.grid)


def run_campaign(truth, tag, args, mode, fly_scale, work, reuse=False):
    """Runs one campaign on the monochrome rig; returns (folder, metadata) or raises
    RuntimeError (with the command's exit status as .status). reuse: a finished campaign already
    in its folder is taken as it is."""
    d = os.path.join(work, (truth.name + "_" + mode + "_" + tag).replace(" ", "_")
                     .replace("+", "").replace("=", ""))
    meta_path = os.path.join(d, "metadata.json")
    if reuse and os.path.exists(meta_path):
        with open(meta_path) as f:
            meta = json.load(f)
        if meta.get("runs") and "stopped" in meta["runs"][-1]:
            return d, meta
    shutil.rmtree(d, ignore_errors=True)
    fly = ["--fly", "--time-scale", str(fly_scale)] if mode == "fly" else ["--time-scale", "1000"]
    cmd = [truth.gonio, "acquire", "--brdf", truth.path, "--rig", MONO_RIG, "--out", d] + fly + args
    r = subprocess.run(["nice", "-n", "10"] + cmd, capture_output=True, text=True)
    if r.returncode != 0:
        e = RuntimeError(" ".join(cmd) + "\n" + r.stdout + r.stderr)
        e.status = r.returncode
        raise e
    with open(meta_path) as f:
        return d, json.load(f)


def mission_points(truth, label, args, curve, mode, a, work):
    """The points of one campaign: one, or one per batch of the fit plan (the fit of the
    measurements before the batch, at the rig time then) and its end."""
    d, meta = run_campaign(truth, label, args, mode, a.fly_time_scale, work, a.reuse)
    dataset = os.path.join(d, "dataset.csv")
    run = meta["runs"][-1]
    parts = []
    if curve:
        for b in sorted(meta.get("fit_plan", {}).get("batches", {}).values(),
                        key=lambda b: b["measured_before"]):
            n = b["measured_before"]
            part = os.path.join(d, "prefix_%d.csv" % n)
            prefix_dataset(dataset, n, part)
            parts.append(("%s (%d)" % (label, n), n, b["rig_time_s"], part, None))
    parts.append((label, meta["measured"], meta["rig_time_s"], dataset,
                  os.path.join(d, "dataset.bsdf")))
    points = []
    for name, n, rig_s, data, bsdf in parts:
        p = {"label": name, "n": n, "rig_s": rig_s}
        p.update(truth.fit_errors(data, data[:-4] + "_fit.json"))
        p["data"] = truth.data_error(data, bsdf)
        points.append(p)
    points[-1]["stopped"] = run.get("stopped", "")
    points[-1]["fly"] = run.get("fly")
    points[-1]["rig_time"] = run.get("rig_time")
    return points


def time_to_reach(points, target, key="fit_dense"):
    """(rig seconds, how) at which a ladder first reaches `target`: interpolated, linearly in log
    time and log error, between the point that last lowered the best error (a later point that
    did not lower it is the scatter of the rig) and the first at or below the target; how is
    "interpolated", "first" (its smallest budget is already there: at most that time) or None
    (not reached)."""
    prev = None
    for p in sorted(points, key=lambda p: p["rig_s"]):
        t, e = p["rig_s"], p[key]
        if e <= target:
            if prev is None:
                return t, "first"
            t0, e0 = prev
            f = (math.log(e0) - math.log(target)) / (math.log(e0) - math.log(e))
            return math.exp(math.log(t0) + f * (math.log(t) - math.log(t0))), "interpolated"
        if prev is None or e < prev[1]:
            prev = (t, e)
    return None, None


def best_error(points, key="fit_dense"):
    return min(p[key] for p in points) if points else float("nan")


def aim_plan(curves):
    """The fit-driven curve of the aim: with fly scans where they ran, else stop-and-go."""
    return ("fit", "fly") if curves.get(("fit", "fly")) else ("fit", "stop")


def common_level(curves, key="fit_dense"):
    """The error level a truth's plans are compared at: 1.1 x the larger of the best errors of
    the uniform plan (stop-and-go) and of the fit-driven plan of the aim, the tightest level
    both reach (within the scatter of their ladders)."""
    ends = [best_error(curves.get(c, []), key) for c in (("uniform", "stop"), aim_plan(curves))]
    ends = [e for e in ends if not math.isnan(e)]
    return 1.1 * max(ends) if ends else float("nan")


def mission_summary(tname, curves, key="fit_dense"):
    """{(family, mode): (seconds, how)} at the common level, and the level."""
    level = common_level(curves, key)
    return level, {c: time_to_reach(pts, level, key) for c, pts in curves.items() if pts}


def format_time(t, how, pts):
    if how is None:
        return "not reached (%.0f s)" % max(p["rig_s"] for p in pts)
    return ("<= %.0f" if how == "first" else "%.0f") % t


def curves_of(saved):
    """{(family, mode): points} of one truth's saved results."""
    return {tuple(c.rsplit(" ", 1)): pts for c, pts in saved.items()}


def mission_tables(results, key="fit_dense"):
    """Markdown: per truth, the rig time each plan and mode needs to reach the common level and
    its ratio to the aim's fit-driven plan; then the aim, truth by truth."""
    rows = ["| truth | error level | plan | stop-and-go (s) | fly (s) | / fit-driven (stop, fly) "
            "| best error (stop, fly) |", "| --- | --- | --- | --- | --- | --- | --- |"]
    aims = ["| truth | fit-driven plan | its rig time (s) | uniform / it | >= 5x | vndf / it "
            "| >= 2x (glossy) |", "| --- | --- | --- | --- | --- | --- | --- |"]
    for tname, saved in results.items():
        curves = curves_of(saved)
        level, times = mission_summary(tname, curves, key)
        fit = aim_plan(curves)
        for fam in MISSION_PLANS:
            cells, ratios, bests = [], [], []
            for mode in MODES:
                pts = curves.get((fam, mode)) or []
                t, how = times.get((fam, mode), (None, None))
                cells.append(format_time(t, how, pts) if pts else "-")
                ratios.append(ratio_text(t, how, pts, times.get(fit, (None, None))))
                best = min(pts, key=lambda p: p[key]) if pts else None
                bests.append("%.4f at %.0f s" % (best[key], best["rig_s"]) if best else "-")
            if cells != ["-", "-"]:
                rows.append("| %s | %.4f | %s | %s | %s | %s | %s |" % (
                    tname, level, fam, cells[0], cells[1], ", ".join(ratios), ", ".join(bests)))
        u = times.get(("uniform", "stop"), (None, None))
        v = times.get(("vndf", "stop"), (None, None))
        ru = ratio_text(u[0], u[1], curves.get(("uniform", "stop")) or [], times.get(fit))
        rv = ratio_text(v[0], v[1], curves.get(("vndf", "stop")) or [], times.get(fit))
        aims.append("| %s | fit, %s | %s | %s | %s | %s | %s |" % (
            tname, "fly" if fit[1] == "fly" else "stop-and-go",
            format_time(*times.get(fit, (None, None)), curves.get(fit) or [{"rig_s": 0}]),
            ru, met(ru, 5), rv, met(rv, 2) if tname in GLOSSY else "(not glossy)"))
    return rows + [""] + aims


def ratio_text(t, how, pts, fit_time):
    """A plan's time over the fit-driven plan's (fit_time: (seconds, how)), with its sense where a
    time is only bounded: "> r" (the plan did not reach the level in its longest campaign),
    "<= r" (the plan reached it at its smallest budget), ">= r" (the fit-driven plan did), "~ r"
    (both did: neither bound holds)."""
    t_fit, how_fit = fit_time
    if not pts or not t_fit:
        return "-"
    if t is None:
        return "> %.2f" % (max(p["rig_s"] for p in pts) / t_fit)
    sense = {(False, False): "", (True, False): "<= ", (False, True): ">= ", (True, True): "~ "}
    return "%s%.2f" % (sense[(how == "first", how_fit == "first")], t / t_fit)


def met(ratio, aim):
    """Whether a ratio (ratio_text) meets the aim: yes, no or open (a bound on the wrong side)."""
    if ratio == "-":
        return "-"
    value = float(ratio.split()[-1])
    if ratio.startswith(">"):
        return "yes" if value >= aim else "open (bound below the aim)"
    if ratio.startswith("<="):
        return "no" if value < aim else "open (bound above the aim)"
    if ratio.startswith("~"):
        return "open (both at their smallest budget)"
    return "yes" if value >= aim else "no"


def mission(a, work):
    """Runs the mission's table; returns {truth: {"family mode": [points]}}."""
    results = {}
    print("| truth | plan | mode | measurements | rig time (s) | fit vs dense fit | fit vs truth "
          "| alpha | data alone | fly swept/standing/missed |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    sys.stdout.flush()
    for tname in a.truth.split(","):
        truth = MissionTruth(a.gonio, tname, truth_path(tname, a.rgl_dir, work), tname == "brushed",
                             work)
        curves = {}
        for fam in a.plan.split(","):
            for mode in MODES:
                curves[(fam, mode)] = mission_family(truth, fam, mode, a, work)
        results[tname] = {"%s %s" % c: pts for c, pts in curves.items()}
        print()
        print("\n".join(mission_tables({tname: results[tname]})))
        print()
        if a.json:
            with open(a.json, "w") as f:
                json.dump(results, f, indent=1)
    return results


def mission_family(truth, fam, mode, a, work):
    """The points of one plan family's ladder in one mode (failed or refused campaigns are
    printed and left out)."""
    pts = []
    for label, args, curve in mission_ladder(fam, truth.aniso, a.quick):
        try:
            new = mission_points(truth, label, args, curve, mode, a, work)
        except RuntimeError as e:
            why = str(e).strip().splitlines()[-1][:100]
            print("| %s | %s | %s | %s: %s | | | | | | |" % (
                truth.name, label, mode, "refused" if getattr(e, "status", 0) == 2 else "failed",
                why))
            sys.stdout.flush()
            continue
        for p in new:
            fly = p.get("fly") or {}
            print("| %s | %s | %s | %d | %.0f | %.4f | %.4f | %.4f | %.4f | %s |" % (
                truth.name, p["label"], mode, p["n"], p["rig_s"], p["fit_dense"], p["fit_truth"],
                p["alpha"], p["data"], "%s/%s/%s" % (fly.get("swept"), fly.get("standing"),
                                                     fly.get("missed_triggers")) if fly else ""))
            sys.stdout.flush()
        pts.extend(new)
    return pts


def truth_path(tname, rgl_dir, work):
    if tname in RGL:
        return os.path.join(rgl_dir, RGL[tname] + ".bsdf")
    if tname not in ("ggx-0.05", "ggx-0.3", "brushed"):
        raise SystemExit("unknown truth " + tname)
    path = os.path.join(work, tname + ".json")
    with open(path, "w") as f:
        f.write(BRUSHED if tname == "brushed" else GGX.format(a=tname.split("-")[1]))
    return path


# ---------------------------------------------------------------------------------------------
# Figure: error against rig time, one panel per truth (SVG, no plotting library needed).

COLOURS = {"uniform": "#1f77b4", "half-diff": "#9467bd", "vndf": "#d62728", "adaptive": "#2ca02c",
           "fit": "#000000"}


def svg_figure(results, path, key="fit_dense", ylabel="fit vs dense fit"):
    """Log-log panels of error against rig time: one per truth, a line per plan and mode
    (stop-and-go solid, fly dashed), the common level dotted."""
    names = list(results)
    cols, pw, ph = min(3, len(names)), 330, 250
    rows = (len(names) + cols - 1) // cols
    out = ['<svg xmlns="http://www.w3.org/2000/svg" width="%d" height="%d" '
           'font-family="sans-serif" font-size="10">' % (max(cols * pw, 900), rows * ph + 40),
           '<rect width="100%" height="100%" fill="white"/>']
    for k, tname in enumerate(names):
        curves = {tuple(c.rsplit(" ", 1)): pts for c, pts in results[tname].items() if pts}
        out += svg_panel(tname, curves, key, ylabel, (k % cols) * pw, (k // cols) * ph, pw, ph)
    x = 10
    for fam, colour in COLOURS.items():
        out.append('<line x1="%d" y1="%d" x2="%d" y2="%d" stroke="%s" stroke-width="2"/>' % (
            x, rows * ph + 20, x + 20, rows * ph + 20, colour))
        out.append('<text x="%d" y="%d">%s</text>' % (x + 24, rows * ph + 24, fam))
        x += 90
    out.append('<text x="%d" y="%d">solid: stop-and-go, dashed: fly scans; dotted: the common '
               'error level</text>' % (x, rows * ph + 24))
    out.append("</svg>")
    with open(path, "w") as f:
        f.write("\n".join(out) + "\n")


def svg_panel(tname, curves, key, ylabel, ox, oy, pw, ph):
    """The SVG elements of one truth's panel."""
    l, r, t, b = ox + 55, ox + pw - 20, oy + 20, oy + ph - 35
    xs = [p["rig_s"] for pts in curves.values() for p in pts]
    ys = [p[key] for pts in curves.values() for p in pts if p[key] > 0]
    x0, x1 = 10 ** math.floor(math.log10(min(xs))), 10 ** math.ceil(math.log10(max(xs)))
    y0, y1 = 10 ** math.floor(math.log10(min(ys))), 10 ** math.ceil(math.log10(max(ys)))

    def px(x):
        return l + (r - l) * (math.log10(x) - math.log10(x0)) / (math.log10(x1) - math.log10(x0))

    def py(y):
        return b - (b - t) * (math.log10(y) - math.log10(y0)) / (math.log10(y1) - math.log10(y0))

    el = ['<rect x="%d" y="%d" width="%d" height="%d" fill="none" stroke="#888"/>' % (
        l, t, r - l, b - t), '<text x="%d" y="%d" font-weight="bold">%s</text>' % (l, t - 6, tname)]
    for e in range(int(round(math.log10(x0))), int(round(math.log10(x1))) + 1):
        el.append('<text x="%.0f" y="%d" text-anchor="middle">%g</text>' % (px(10 ** e), b + 12,
                                                                              10 ** e))
    for e in range(int(round(math.log10(y0))), int(round(math.log10(y1))) + 1):
        el.append('<line x1="%d" y1="%.0f" x2="%d" y2="%.0f" stroke="#ddd"/>' % (
            l, py(10 ** e), r, py(10 ** e)))
        el.append('<text x="%d" y="%.0f" text-anchor="end">%g</text>' % (l - 3, py(10 ** e) + 3,
                                                                          10 ** e))
    el.append('<text x="%d" y="%d" text-anchor="middle">rig time (s)</text>' % ((l + r) / 2, b + 26))
    el.append('<text transform="translate(%d,%d) rotate(-90)" text-anchor="middle">%s</text>' % (
        ox + 14, (t + b) / 2, ylabel))
    level = common_level(curves, key)
    if not math.isnan(level) and y0 <= level <= y1:
        el.append('<line x1="%d" y1="%.1f" x2="%d" y2="%.1f" stroke="#555" '
                  'stroke-dasharray="1,3"/>' % (l, py(level), r, py(level)))
    for (fam, mode), pts in sorted(curves.items()):
        pts = sorted((p for p in pts if p[key] > 0), key=lambda p: p["rig_s"])
        xy = " ".join("%.1f,%.1f" % (px(p["rig_s"]), py(p[key])) for p in pts)
        dash = ' stroke-dasharray="5,3"' if mode == "fly" else ""
        colour = COLOURS.get(fam, "#888")
        el.append('<polyline points="%s" fill="none" stroke="%s" stroke-width="1.5"%s/>' % (
            xy, colour, dash))
        for p in pts:
            el.append('<circle cx="%.1f" cy="%.1f" r="2.2" fill="%s"/>' % (
                px(p["rig_s"]), py(p[key]), colour))
    return el

if __name__ == "__main__":
    if len(sys.argv) == 4 and sys.argv[1] == "--plot-only":
        # bench/rig_time_bench.py --plot-only RESULTS.json OUT.png|OUT.svg: redraw from saved
        # points (an SVG from the mission's points, with OUT_data.svg beside it).
        with open(sys.argv[2]) as f:
            saved = json.load(f)
        if sys.argv[3] == "--tables":
            for key in ("fit_dense", "data"):
                print("\nRig time to the common level, %s:\n" % key)
                print("\n".join(mission_tables(saved, key)))
        elif sys.argv[3].endswith(".svg"):
            svg_figure(saved, sys.argv[3])
            svg_figure(saved, sys.argv[3][:-4] + "_data.svg", "data", "data alone vs truth")
        else:
            plot(saved, sys.argv[3])
        sys.exit(0)
    main()
