"""Batch fitting of the shipped material database: serial against a 2-worker Dask LocalCluster.

    PYTHONPATH=build/python /usr/bin/python3 bench/batch_bench.py --work /tmp/gonio-batch-bench

Synthesises the 86 materials of data/materials/ngan2005.json as full MERL tables (90 x 90 x 180,
35 MB each, tabulated by gonio.save), writes a manifest fitting the default model (GGX + Lambert +
Schlick RGB, log residual) with a stratified reduction to --max-samples samples, then runs it
(1) serially in this process and (2) with gonio.batch on a LocalCluster of --workers processes
(one thread each, 127.0.0.1), into separate folders. Prints wall times, the speed-up, per-material
fit times and the fit error against the table (log_rmse over all valid samples, from the report),
as Markdown.
"""

import argparse
import csv
import os
import shutil
import statistics
import time

import gonio
import gonio.batch


def synthesise(work, names):
    tables = os.path.join(work, "tables")
    os.makedirs(tables, exist_ok=True)
    t0 = time.monotonic()
    for name in names:
        path = os.path.join(tables, name + ".binary")
        if not os.path.exists(path):
            gonio.save(path, "material:" + name)
    return time.monotonic() - t0


def write_manifest(work, names, max_samples):
    path = os.path.join(work, "manifest.csv")
    with open(path, "w") as f:
        f.write("input,model,options,id\n")
        for name in names:
            f.write(f"tables/{name}.binary,ggx,max_samples={max_samples},{name}\n")
    return path


def run(manifest, out, **kw):
    shutil.rmtree(out, ignore_errors=True)
    t0 = time.monotonic()
    outcomes = gonio.batch.run_batch(manifest, out, progress=False, **kw)
    return time.monotonic() - t0, outcomes


def describe(label, wall, outcomes):
    times = [o["wall_time_s"] for o in outcomes if o["status"] == "fitted"]
    errs = [o["log_rmse"] for o in outcomes if o["status"] == "fitted"]
    failed = [o["id"] + " (" + o["status"] + ")" for o in outcomes if o["status"] != "fitted"]
    return {
        "label": label,
        "wall": wall,
        "fitted": len(times),
        "failed": failed,
        "median": statistics.median(times) if times else float("nan"),
        "min": min(times) if times else float("nan"),
        "max": max(times) if times else float("nan"),
        "sum": sum(times),
        "err_median": statistics.median(errs) if errs else float("nan"),
        "err_max": max(errs) if errs else float("nan"),
    }


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--work", required=True, help="folder for the tables and results")
    p.add_argument("--max-samples", type=int, default=20000)
    p.add_argument("--workers", type=int, default=2)
    p.add_argument("--limit", type=int, default=0, help="only the first N materials (0 = all)")
    a = p.parse_args()
    names = gonio.materials()
    if a.limit:
        names = names[: a.limit]
    os.makedirs(a.work, exist_ok=True)
    synth = synthesise(a.work, names)
    manifest = write_manifest(a.work, names, a.max_samples)
    load = os.getloadavg()
    serial = describe("serial (1 process)", *run(manifest, os.path.join(a.work, "serial"), serial=True))
    cluster = describe(
        f"LocalCluster ({a.workers} workers x 1 thread)",
        *run(manifest, os.path.join(a.work, "dask"), workers=a.workers),
    )
    load_after = os.getloadavg()
    print(f"{len(names)} materials, tables synthesised in {synth:.1f} s, max_samples={a.max_samples}, "
          f"{os.cpu_count()} cores, load average before {load[0]:.1f}, after {load_after[0]:.1f}")
    print()
    print("| run | wall time | fitted | fit time per material: median (min-max) | sum of fit times | "
          "materials per machine-hour | log_rmse median (max) |")
    print("| --- | --- | --- | --- | --- | --- | --- |")
    for r in (serial, cluster):
        print(f"| {r['label']} | {r['wall']:.1f} s | {r['fitted']}/{len(names)} | "
              f"{r['median']:.2f} s ({r['min']:.2f}-{r['max']:.2f}) | {r['sum']:.1f} s | "
              f"{3600 * len(names) / r['wall']:.0f} | {r['err_median']:.3g} ({r['err_max']:.3g}) |")
    print()
    print(f"speed-up: {serial['wall'] / cluster['wall']:.2f}x")
    for r in (serial, cluster):
        if r["failed"]:
            print(f"{r['label']}: not fitted: {', '.join(r['failed'])}")
    with open(os.path.join(a.work, "serial", "summary.csv")) as f:
        rows = list(csv.DictReader(f))
    slow = sorted(rows, key=lambda r: -float(r["wall_time_s"]))[:5]
    print("slowest (serial): " + ", ".join(f"{r['id']} {float(r['wall_time_s']):.2f} s" for r in slow))


if __name__ == "__main__":
    main()
