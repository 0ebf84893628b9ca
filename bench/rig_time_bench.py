#!/usr/bin/python3
"""Rig time against error: point campaigns of several plans on the virtual rig with the reference
error budget (docs/error-budget.md), each fitted with the default model, on analytic and measured
truths served as the rig's ground truth.

    /usr/bin/python3 bench/rig_time_bench.py build/tools/gonio RGL_DIR [--out DIR]
        [--truth NAME[,NAME...]] [--plan NAME[,NAME...]] [--json FILE] [--plot PNG]
    /usr/bin/python3 bench/rig_time_bench.py --plot-only RESULTS.json OUT.png

RGL_DIR holds the RGL files (acrylic_felt_green_rgb.bsdf, paper_white_rgb.bsdf,
satin_rosaline_rgb.bsdf); they are read from there. Truths: ggx-0.05, ggx-0.3, brushed (anisotropic
GGX, alpha 0.1 x 0.3, turned 30 deg), satin, paper, felt. Plans (families): uniform (grids 4x3, 5x4,
7x5, 10x8: a curve), half-diff, vndf, adaptive (uniform 5x4 and 7x5 with one neighbour-adaptive
pass of 30), uniform-until (10x8 --until sigma=0.01), fit (--plan fit to its budget of 120: a
curve, one point per batch, each the fit of the measurements before it) and fit-until (--plan fit
--until sigma=0.01), and fly (stop-and-go against `--fly` on the same plan, on the monochrome
rig data/rigs/sim4-mono.json: uniform 7x5, uniform 16x2 (in-plane), and the fit plan, which
--fly refuses). The brushed truth runs the anisotropic variants (uniform: --anisotropic;
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
        if aniso:
            return []
        mono = ["--rig", MONO_RIG]
        # Fly scans need the arms to keep pace with the camera: a slower virtual rig (the rig
        # time it records does not depend on the scale).
        fly = ["--fly", "--time-scale", "5"]
        runs = []
        for label, plan in (("uniform 7x5", ["--n-theta", "7", "--n-dphi", "5", "--adaptive", "0"]),
                            ("uniform 16x2", ["--n-theta", "16", "--n-dphi", "2", "--adaptive",
                                              "0"]),
                            ("fit", ["--plan", "fit"])):
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
    r = subprocess.run(cmd, capture_output=True, text=True)
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
        rows[k] = (ti, pi, min(ti + rnd.gauss(0, 0.05), math.radians(75)) if ti > 0.05 else ti,
                   pi + math.pi + rnd.gauss(0, 0.05))
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


def alpha_of(fit_json):
    with open(fit_json) as f:
        m = json.load(f)
    lobes = m.get("lobes") or [{}]
    return lobes[0].get("alpha", lobes[0].get("alpha_x"))


class Truth:
    def __init__(self, gonio, name, path, aniso, work):
        self.gonio, self.name, self.path, self.aniso = gonio, name, path, aniso
        self.fit_args = ["--anisotropic"] if aniso else []
        self.grid = direction_grid(aniso)
        self.grid_csv = os.path.join(work, name + "_grid.csv")
        with open(self.grid_csv, "w") as f:
            f.write("theta_i,phi_i,theta_o,phi_o\n")
            for r in self.grid:
                f.write("%.17g,%.17g,%.17g,%.17g\n" % r)
        self.values = evaluate(gonio, path, self.grid_csv)
        dense = os.path.join(work, name + "_dense.csv")
        with open(dense, "w") as f:
            f.write("theta_i,phi_i,theta_o,phi_o,r,g,b\n")
            for r, v in zip(self.grid, self.values):
                f.write("%.17g,%.17g,%.17g,%.17g,%.17g,%.17g,%.17g\n" % (r + v))
        self.dense_fit = os.path.join(work, name + "_dense_fit.json")
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


def time_to_reach(points, target):
    """The least rig time among points whose error (vs dense fit) is at most target."""
    ok = [p[2] for p in points if p[3][0] <= target]
    return min(ok) if ok else None


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("gonio")
    ap.add_argument("rgl_dir")
    ap.add_argument("--out", default=None)
    ap.add_argument("--truth", default=",".join(TRUTHS), help="comma-separated: " + ", ".join(TRUTHS))
    ap.add_argument("--plan", default=",".join(FAMILIES), help="comma-separated: " + ", ".join(FAMILIES))
    ap.add_argument("--json", default=None, help="write every point here (--plot-only redraws it)")
    ap.add_argument("--plot", default=None, help="draw error against rig time into this PNG")
    a = ap.parse_args()
    work = a.out or tempfile.mkdtemp(prefix="rig_time_bench_")
    os.makedirs(work, exist_ok=True)
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
        t_uniform = time_to_reach(per_family.get("uniform", []), target)
        t_vndf = time_to_reach(per_family.get("vndf", []), target)
        print("\n%s: rig time to reach %.4f vs dense fit (%s):" % (tname, target, what))
        for fam, pts in per_family.items():
            t = time_to_reach(pts, target)
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


if __name__ == "__main__":
    if len(sys.argv) == 4 and sys.argv[1] == "--plot-only":
        # bench/rig_time_bench.py --plot-only RESULTS.json OUT.png: redraw from saved points.
        with open(sys.argv[2]) as f:
            plot(json.load(f), sys.argv[3])
        sys.exit(0)
    main()
