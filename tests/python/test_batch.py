"""python3 -m gonio.batch on a 2-worker LocalCluster (127.0.0.1, no dashboard): 8 synthetic
materials fitted, a broken entry reported without stopping the others, a rerun skipping the
finished entries."""

import copy
import csv
import os
import subprocess
import sys

import numpy as np

import gonio
from conftest import TRUTH, synthetic_samples

ALPHAS = [0.08, 0.12, 0.16, 0.2, 0.25, 0.3, 0.35, 0.4]


def make_manifest(workdir):
    rows = ["input,model,options,id"]
    for k, alpha in enumerate(ALPHAS):
        m = copy.deepcopy(TRUTH)
        m["lobes"][0]["alpha"] = alpha
        m["diffuse"] = [0.05 + 0.03 * k, 0.1, 0.2 - 0.02 * k]
        gonio.save(workdir / f"mat{k}.csv", synthetic_samples(m, n_theta=8, n_phi=10))
        rows.append(f"mat{k}.csv,ggx,fresnel=schlick-rgb;residual=log;starts=4,mat{k}")
    (workdir / "broken.csv").write_text("theta_i,phi_i,theta_o,r,g,b\n0.1,0,0.2,1,1,1\n")
    rows.append("broken.csv,ggx,,broken")
    (workdir / "manifest.csv").write_text("\n".join(rows) + "\n")
    return workdir / "manifest.csv"


def run_batch_cli(manifest, out):
    return subprocess.run(
        [sys.executable, "-m", "gonio.batch", str(manifest), "--out", str(out), "--workers", "2"],
        capture_output=True,
        text=True,
        timeout=500,
        env=dict(os.environ),
    )


def read_summary(out):
    with open(out / "summary.csv", newline="") as f:
        return {r["id"]: r for r in csv.DictReader(f)}


def test_batch_local_cluster_fits_reports_failure_and_resumes(workdir):
    manifest = make_manifest(workdir)
    out = workdir / "out"
    r = run_batch_cli(manifest, out)
    assert r.returncode == 1, r.stdout + r.stderr  # one entry is broken
    assert "8 of 9 entries fitted" in r.stdout
    summary = read_summary(out)
    assert list(summary) == [f"mat{k}" for k in range(8)] + ["broken"]
    for k, alpha in enumerate(ALPHAS):
        assert summary[f"mat{k}"]["status"] == "fitted"
        fitted = gonio.load_campaign(out)[f"mat{k}"]  # every JSON in the folder, parsed
        assert abs(fitted["lobes"][0]["alpha"] - alpha) < 1e-3 * alpha
    assert summary["broken"]["status"] == "failed"
    assert "phi_o" in summary["broken"]["message"]
    assert (out / "broken.error.txt").exists()
    assert "broken: failed" in r.stderr

    stamps = {k: os.stat(out / f"mat{k}.report.json").st_mtime_ns for k in range(8)}
    r2 = run_batch_cli(manifest, out)
    assert r2.returncode == 1
    assert "8 already fitted, 1 to fit" in r2.stderr
    summary2 = read_summary(out)
    for k in range(8):
        assert summary2[f"mat{k}"]["status"] == "skipped"
        assert os.stat(out / f"mat{k}.report.json").st_mtime_ns == stamps[k]
        # The skipped rows carry the metrics read back from the reports.
        assert float(summary2[f"mat{k}"]["log_rmse"]) == float(summary[f"mat{k}"]["log_rmse"])
    assert summary2["broken"]["status"] == "failed"


def test_serial_and_cluster_give_the_same_fits(workdir):
    # The same manifest once in this process and once on a 2-worker Dask LocalCluster (started by
    # run_batch on 127.0.0.1): the same outcomes and the same fitted models, to the last digit.
    manifest = make_manifest(workdir)
    serial = gonio.batch.run_batch(manifest, workdir / "serial", serial=True, progress=False)
    cluster = gonio.batch.run_batch(manifest, workdir / "cluster", workers=2, progress=False)
    assert [o["status"] for o in serial] == ["fitted"] * 8 + ["failed"]
    assert [o["status"] for o in cluster] == [o["status"] for o in serial]
    assert [o["iterations"] for o in cluster] == [o["iterations"] for o in serial]
    # The serial run fitted here; the cluster's fits ran in its worker processes (at most 2).
    assert {o["pid"] for o in serial} == {os.getpid()}
    workers = {o["pid"] for o in cluster}
    assert os.getpid() not in workers and None not in workers, workers
    assert 1 <= len(workers) <= 2, workers
    for k in range(8):
        a = gonio.load_campaign(workdir / "serial")[f"mat{k}"]
        b = gonio.load_campaign(workdir / "cluster")[f"mat{k}"]
        assert a == b, (a, b)
        assert np.isclose(a["lobes"][0]["alpha"], ALPHAS[k], rtol=1e-3), a


def test_existing_scheduler_by_address(workdir):
    # --scheduler: the tasks go to a cluster started elsewhere (here one more LocalCluster on
    # 127.0.0.1, addressed only by its tcp:// address).
    from distributed import LocalCluster

    manifest = make_manifest(workdir)
    with LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None
    ) as cluster:
        address = cluster.scheduler_address
        assert address.startswith("tcp://127.0.0.1:")
        outcomes = gonio.batch.run_batch(manifest, workdir / "remote", scheduler=address, progress=False)
        # The batch closed its client only: the cluster still serves.
        assert len(cluster.scheduler.workers) == 2
    assert [o["status"] for o in outcomes] == ["fitted"] * 8 + ["failed"]


import gonio.batch  # noqa: E402  (the submodule, after the helpers above)
