"""gonio.check: the property checks of `gonio check`, against closed-form albedos."""

import numpy as np

import gonio
from conftest import TRUTH


def test_physical_model_passes():
    plastic = {
        "diffuse": [0.1, 0.1, 0.1],
        "lobes": [
            {
                "distribution": "ggx",
                "alpha": 0.3,
                "shadowing": "smith-correlated",
                "fresnel": {"type": "schlick", "f0": [0.04, 0.04, 0.04]},
            }
        ],
    }
    r = gonio.check(plastic, pairs=2000)
    assert r["passed"]
    assert [c["name"] for c in r["checks"]] == ["non-negativity", "reciprocity", "isotropy", "energy"]


def test_lambert_plus_bright_lobe_exceeds_one_at_grazing():
    # TRUTH adds a Lambert term to a lobe whose Fresnel tends to 1 at grazing incidence: the sum
    # of the two albedos exceeds 1 there, which the energy check must catch.
    r = gonio.check(TRUTH, pairs=500)
    energy = next(c for c in r["checks"] if c["name"] == "energy")
    assert not energy["passed"] and energy["violation"] > 0.05


def test_lambert_above_one_violates_energy_by_its_albedo():
    # A Lambertian BRDF rho/pi has directional albedo rho at every incidence (closed form).
    r = gonio.check({"diffuse": [1.5, 0.5, 0.5], "lobes": []}, pairs=500)
    energy = next(c for c in r["checks"] if c["name"] == "energy")
    assert not r["passed"] and not energy["passed"]
    assert abs(energy["violation"] - 0.5) < 2e-3


def test_check_matches_cli_verdict():
    from conftest import run_gonio

    r = run_gonio("check", "material:red-plastic", "--pairs", "500")
    ours = gonio.check("material:red-plastic", pairs=500)
    assert (r.returncode == 0) == ours["passed"]
    assert ours["table"].splitlines()[0] in r.stdout
    assert np.isfinite([c["violation"] for c in ours["checks"]]).all()
