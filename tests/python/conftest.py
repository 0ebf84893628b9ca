"""Shared helpers of the Python tests: the gonio binary, a ground-truth model, angle grids."""

import os
import pathlib
import subprocess

import numpy as np
import pytest

GONIO_EXE = os.environ.get("GONIO_EXE", "gonio")

# GGX + Lambert + Schlick RGB with height-correlated Smith: the structure of a fit with
# fresnel="schlick-rgb" (f0 per channel, lobe scale fixed at 1).
TRUTH = {
    "diffuse": [0.25, 0.12, 0.05],
    "lobes": [
        {
            "distribution": "ggx",
            "alpha": 0.18,
            "shadowing": "smith-correlated",
            "fresnel": {"type": "schlick", "f0": [0.9, 0.55, 0.3]},
            "scale": [1, 1, 1],
        }
    ],
}


@pytest.fixture
def workdir(tmp_path, request):
    """A fresh folder per test (under the build tree when ctest runs the test)."""
    base = os.environ.get("GONIO_TEST_TMP")
    if not base:
        return tmp_path
    d = pathlib.Path(base) / request.node.name
    if d.exists():
        for p in sorted(d.rglob("*"), reverse=True):
            p.unlink() if p.is_file() or p.is_symlink() else p.rmdir()
    d.mkdir(parents=True, exist_ok=True)
    return d


def run_gonio(*args, stdin=None, timeout=300):
    return subprocess.run(
        [GONIO_EXE, *map(str, args)],
        input=stdin,
        capture_output=True,
        text=True,
        timeout=timeout,
    )


def angle_grid(n_theta=9, n_phi=12, max_deg=80.0):
    """Every (theta_i, theta_o, phi_o) of a grid, phi_i = 0: arrays of radians."""
    t = np.radians(np.linspace(0.0, max_deg, n_theta))
    p = np.radians(np.linspace(0.0, 180.0, n_phi))
    ti, to, po = np.meshgrid(t, t, p, indexing="ij")
    ti, to, po = ti.ravel(), to.ravel(), po.ravel()
    return ti, np.zeros_like(ti), to, po


def synthetic_samples(model, n_theta=9, n_phi=12, noise=0.0, seed=1):
    """A samples dict of `model` on angle_grid (values from gonio.eval, optional relative noise)."""
    import gonio

    ti, pi_, to, po = angle_grid(n_theta, n_phi)
    v = gonio.eval(model, ti, pi_, to, po)
    if noise > 0:
        rng = np.random.default_rng(seed)
        v = v * (1.0 + noise * rng.standard_normal(v.shape))
    return {"theta_i": ti, "phi_i": pi_, "theta_o": to, "phi_o": po, "value": v}
