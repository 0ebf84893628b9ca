"""`gonio fit --manifest M --shard K/N`: the shards partition the manifest, each entry's results
match a direct `gonio fit`, and reruns skip finished entries."""

import csv
import json

import gonio
from conftest import TRUTH, run_gonio, synthetic_samples


def make(workdir, n):
    rows = ["# six small synthetic datasets", "input,model,options"]
    for k in range(n):
        m = json.loads(json.dumps(TRUTH))
        m["lobes"][0]["alpha"] = 0.1 + 0.05 * k
        gonio.save(workdir / f"d{k}.csv", synthetic_samples(m, n_theta=7, n_phi=9))
        rows.append(f"d{k}.csv,ggx,fresnel=schlick-rgb;starts=3;threads=1")
    (workdir / "m.csv").write_text("\n".join(rows) + "\n")
    return workdir / "m.csv"


def test_shards_partition_the_manifest(workdir):
    manifest = make(workdir, 6)
    out = workdir / "out"
    seen = []
    for k in range(3):
        threads = ["--threads", "1"] if k == 0 else []  # replaces the entries' own option
        r = run_gonio("fit", "--manifest", manifest, "--shard", f"{k}/3", *threads, "--out", out)
        assert r.returncode == 0, r.stdout + r.stderr
        with open(out / f"summary.shard-{k}-of-3.csv", newline="") as f:
            rows = list(csv.DictReader(f))
        # Round robin: entry i goes to shard i mod 3.
        assert [row["id"] for row in rows] == [f"d{i}" for i in range(6) if i % 3 == k]
        assert all(row["status"] == "fitted" for row in rows)
        seen += [row["id"] for row in rows]
    assert sorted(seen) == [f"d{i}" for i in range(6)]
    for i in range(6):
        fitted = json.loads((out / f"d{i}.json").read_text())
        assert abs(fitted["lobes"][0]["alpha"] - (0.1 + 0.05 * i)) < 1e-4
        report = json.loads((out / f"d{i}.report.json").read_text())
        assert report["solver"]["usable"]
    # The same entry fitted directly gives the same model.
    direct = workdir / "direct.json"
    r = run_gonio(
        "fit", workdir / "d4.csv", "--fresnel", "schlick-rgb", "--starts", "3", "--threads", "1",
        "--out", direct,
    )
    assert r.returncode == 0, r.stderr
    # The verdict names its own report file (direct.report.json against d4.report.json); the rest
    # of the fit, the verdict included, is the same.
    direct_fit, manifest_fit = json.loads(direct.read_text()), json.loads((out / "d4.json").read_text())
    assert direct_fit["fit"].pop("report") == "direct.report.json"
    assert manifest_fit["fit"].pop("report") == "d4.report.json"
    assert direct_fit == manifest_fit
    # Rerun: nothing fitted again.
    r = run_gonio("fit", "--manifest", manifest, "--shard", "1/3", "--out", out)
    assert r.returncode == 0 and r.stdout.count(": skipped") == 2


def test_bad_shard_and_manifest_errors(workdir):
    manifest = make(workdir, 1)
    r = run_gonio("fit", "--manifest", manifest, "--shard", "3/3", "--out", workdir / "o")
    assert r.returncode == 2 and "0 <= K < N" in r.stderr
    (workdir / "bad.csv").write_text("input,model,options\nd0.csv,ggx,residual=squared\n")
    r = run_gonio("fit", "--manifest", workdir / "bad.csv", "--out", workdir / "o")
    assert r.returncode == 2 and "bad.csv:2:" in r.stderr and "residual" in r.stderr
    (workdir / "dup.csv").write_text("input,model,options\nd0.csv,ggx,\nd0.csv,beckmann,\n")
    r = run_gonio("fit", "--manifest", workdir / "dup.csv", "--out", workdir / "o")
    assert r.returncode == 2 and "already used on line 2" in r.stderr
    r = run_gonio("fit", "--manifest", manifest)
    assert r.returncode == 2 and "--out" in r.stderr


def test_entry_without_options_fits_as_gonio_fit_does(workdir):
    # The defaults of a manifest entry are the fitting library's (GGX), like those of
    # `gonio fit DATA --model ggx` (`gonio fit`'s own default model is auto).
    gonio.save(workdir / "plain.csv", synthetic_samples(TRUTH, n_theta=7, n_phi=9))
    (workdir / "m.csv").write_text("input,model,options\nplain.csv,,\n")
    r = run_gonio("fit", "--manifest", workdir / "m.csv", "--out", workdir / "out")
    assert r.returncode in (0, 1), r.stderr
    r2 = run_gonio(
        "fit", workdir / "plain.csv", "--model", "ggx", "--out", workdir / "direct.json"
    )
    assert r2.returncode == r.returncode, r2.stdout + r2.stderr
    a = json.loads((workdir / "out" / "plain.report.json").read_text())
    b = json.loads((workdir / "direct.report.json").read_text())
    assert a["model"] == b["model"]
    assert [p["name"] for p in a["parameters"]] == [p["name"] for p in b["parameters"]]
