#!/usr/bin/python3
"""The cost of `gonio fit --model auto` against one GGX fit (`--model ggx`), whole commands.

    /usr/bin/python3 bench/auto_vs_ggx.py build/tools/gonio [--runs N] DATA...

Each DATA (a dataset CSV, a table or an RGL .bsdf file) is fitted N times (default 7) with each
model, alternating; the median wall time and the median CPU time (user + system of the child, from
getrusage) of each are printed with their ratio, then auto's choice and the log RMSE (channel mean,
on all valid samples) of each model as `gonio fit` prints them. Every run's exit status is checked
(0, or 1 for a fit that does not converge, which is reported). Nothing is written.
"""

import argparse
import os
import re
import resource
import statistics
import subprocess
import sys
import time


def timed(args):
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    run = subprocess.run(args, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    if run.returncode not in (0, 1):
        sys.exit(f"{' '.join(args)}: exit {run.returncode}\n{run.stderr}")
    return wall, cpu, run.stdout


def log_rmse(out):
    m = re.search(r"^\s*log_rmse\s+(\S+)\s+(\S+)\s+(\S+)", out, re.M)
    return sum(float(x) for x in m.groups()) / 3 if m else float("nan")


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("gonio")
    p.add_argument("data", nargs="+")
    p.add_argument("--runs", type=int, default=7)
    a = p.parse_args()
    print(f"load average at start: {os.getloadavg()[0]:.1f}")
    print("| data | ggx wall / CPU | auto wall / CPU | ratio wall / CPU | auto's choice | "
          "log RMSE ggx | log RMSE auto |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for data in a.data:
        runs = {"ggx": [], "auto": []}
        out = {}
        for _ in range(a.runs):
            for model in ("ggx", "auto"):
                wall, cpu, text = timed([a.gonio, "fit", data, "--model", model])
                runs[model].append((wall, cpu))
                out[model] = text
        med = {m: (statistics.median(w for w, _ in r), statistics.median(c for _, c in r))
               for m, r in runs.items()}
        chosen = re.search(r"^chosen: (.*)$", out["auto"], re.M)
        g, t = med["ggx"], med["auto"]
        print(f"| {os.path.basename(data)} | {g[0]:.3f} s / {g[1]:.3f} s | "
              f"{t[0]:.3f} s / {t[1]:.3f} s | {t[0] / g[0]:.1f}x / {t[1] / max(g[1], 1e-3):.1f}x | "
              f"{chosen.group(1) if chosen else '?'} | {log_rmse(out['ggx']):.4g} | "
              f"{log_rmse(out['auto']):.4g} |")


if __name__ == "__main__":
    main()
