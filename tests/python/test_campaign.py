"""A campaign measured by `gonio acquire` on the embedded virtual rig, read with
gonio.load_campaign: the dataset as numpy, the metadata and descriptions as dicts, and the values
against the sample's ground truth evaluated by gonio.eval."""

import numpy as np

import gonio
from conftest import GONIO_EXE

import subprocess


def test_acquired_campaign_reads_as_numpy_and_dicts(workdir):
    out = workdir / "campaign"
    # The embedded rig serves its camera over GigE Vision on a free loopback address.
    r = subprocess.run(
        [GONIO_EXE, "acquire", "--out", str(out), "--n-theta", "4",
         "--n-dphi", "3", "--adaptive", "0", "--time-scale", "500"],
        capture_output=True, text=True, timeout=400,
    )
    assert r.returncode == 0, r.stdout + r.stderr
    c = gonio.load_campaign(out)
    assert {"dataset", "metadata", "campaign", "rig"} <= set(c)
    d = c["dataset"]
    brdf_rows = (d["flags"] & 4) == 0  # bit 2: drift-reference re-measurements
    assert brdf_rows.sum() == c["metadata"]["measured"] == c["metadata"]["plan"]["configurations"]
    assert d["has_sigma"] and np.all(d["sigma"][brdf_rows] > 0)
    truth = gonio.eval(
        "material:" + c["campaign"]["sample"],
        d["theta_i"][brdf_rows], d["phi_i"][brdf_rows], d["theta_o"][brdf_rows], d["phi_o"][brdf_rows],
    )
    # Calibrated measurements of the simulated sample, on a rig with a real rig's error budget
    # (docs/error-budget.md): at least 95 % within 3 stated sigma of its model, every value within
    # 5 sigma, and the sigmas those of a calibrated rig (below 5 % of the brightest channel's value).
    error = np.abs(d["value"][brdf_rows] - truth)
    sigma = d["sigma"][brdf_rows]
    within = error <= 3 * sigma
    assert within.mean() >= 0.95, within.mean()
    assert np.all(error <= 5 * sigma), np.max(error / sigma)
    assert np.all(sigma[:, 0] < 0.05 * truth[:, 0]), np.max(sigma[:, 0] / truth[:, 0])


def test_image_folder_keeps_dataset_json(workdir):
    # An image-mode folder holds dataset.csv and dataset.json: both are returned.
    out = workdir / "image"
    out.mkdir(parents=True, exist_ok=True)
    (out / "dataset.csv").write_text(
        "theta_i,phi_i,theta_o,phi_o,r,g,b\n0.5,0,0.5,3.14159,0.1,0.2,0.3\n")
    (out / "dataset.json").write_text('{"mode": "image", "coverage": {"achieved": 0.93}}')
    c = gonio.load_campaign(out)
    assert c["dataset"]["value"].shape == (1, 3)
    assert c["dataset.json"]["mode"] == "image"
    assert c["dataset.json"]["coverage"]["achieved"] == 0.93


def test_missing_folder_raises():
    try:
        gonio.load_campaign("/nonexistent/campaign")
    except gonio.Error as e:
        assert "not a campaign folder" in str(e)
    else:
        raise AssertionError("no error")
