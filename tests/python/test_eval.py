"""gonio.eval against the command line `gonio eval` and against closed forms written here."""

import json

import numpy as np
import pytest

import gonio
from conftest import TRUTH, angle_grid, run_gonio


def cli_eval(brdf, ti, pi_, to, po):
    rows = "\n".join(f"{a!r},{b!r},{c!r},{d!r}" for a, b, c, d in zip(ti, pi_, to, po))
    r = run_gonio("eval", brdf, stdin="theta_i,phi_i,theta_o,phi_o\n" + rows + "\n")
    assert r.returncode == 0, r.stderr
    lines = r.stdout.strip().splitlines()
    assert lines[0] == "r,g,b"
    return np.array([[float(x) for x in line.split(",")] for line in lines[1:]])


def random_angles(n, seed):
    rng = np.random.default_rng(seed)
    return (
        rng.uniform(0, np.radians(89), n),
        rng.uniform(-np.pi, np.pi, n),
        rng.uniform(0, np.radians(89), n),
        rng.uniform(-np.pi, np.pi, n),
    )


def to_dirs(theta, phi):
    return np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta)], 1)


@pytest.mark.parametrize("source", ["dict", "material", "table"])
def test_eval_matches_cli(source, workdir):
    ti, pi_, to, po = random_angles(300, seed=7)
    if source == "dict":
        path = workdir / "truth.json"
        path.write_text(json.dumps(TRUTH))
        model, brdf = TRUTH, str(path)
    elif source == "material":
        model = brdf = "material:gold-metallic-paint"
    else:
        table = gonio.tabulate(TRUTH, grid=(16, 16, 32))
        brdf = str(workdir / "truth.gtab")
        gonio.save(brdf, table)
        model = table
    ours = gonio.eval(model, ti, pi_, to, po)
    cli = cli_eval(brdf, ti, pi_, to, po)
    assert ours.shape == (300, 3)
    assert np.all(ours >= 0) and np.mean(ours > 0) > 0.9
    np.testing.assert_allclose(ours, cli, rtol=1e-12, atol=0)


def test_direction_form_equals_angle_form():
    ti, pi_, to, po = random_angles(500, seed=3)
    by_angles = gonio.eval(TRUTH, ti, pi_, to, po)
    by_dirs = gonio.eval(TRUTH, to_dirs(ti, pi_), to_dirs(to, po))
    np.testing.assert_allclose(by_dirs, by_angles, rtol=1e-12)


def ggx_closed_form(model, wi, wo):
    """Walter et al. 2007: GGX D (eq. 33), height-correlated Smith G (Heitz 2014 eq. 99),
    Schlick F, plus Lambert rho / pi; written from the papers, independently of brdf/."""
    lobe = model["lobes"][0]
    a = lobe["alpha"]
    f0 = np.array(lobe["fresnel"]["f0"])
    rho = np.array(model["diffuse"])
    h = wi + wo
    h /= np.linalg.norm(h, axis=1, keepdims=True)
    cos_h = h[:, 2]
    tan2_h = (1 - cos_h**2) / cos_h**2
    D = a**2 / (np.pi * cos_h**4 * (a**2 + tan2_h) ** 2)

    def lam(w):
        c = w[:, 2]
        tan2 = (1 - c**2) / c**2
        return (-1 + np.sqrt(1 + a**2 * tan2)) / 2

    G = 1 / (1 + lam(wi) + lam(wo))
    c_d = np.sum(wi * h, axis=1)
    F = f0[None, :] + (1 - f0[None, :]) * (1 - c_d[:, None]) ** 5
    spec = F * (D * G / (4 * wi[:, 2] * wo[:, 2]))[:, None]
    return rho[None, :] / np.pi + spec


def test_eval_matches_closed_form_ggx():
    ti, pi_, to, po = random_angles(2000, seed=11)
    wi, wo = to_dirs(ti, pi_), to_dirs(to, po)
    np.testing.assert_allclose(gonio.eval(TRUTH, wi, wo), ggx_closed_form(TRUTH, wi, wo), rtol=1e-10)


def test_lambert_is_rho_over_pi_and_zero_below_horizon():
    model = {"diffuse": [0.5, 0.25, 0.125], "lobes": []}
    ti, pi_, to, po = angle_grid(5, 4)
    v = gonio.eval(model, ti, pi_, to, po)
    np.testing.assert_allclose(v, np.tile([0.5 / np.pi, 0.25 / np.pi, 0.125 / np.pi], (len(ti), 1)), rtol=1e-15)
    below = gonio.eval(model, np.array([0.3]), np.array([0.0]), np.array([2.0]), np.array([0.0]))
    assert np.all(below == 0)


def test_eval_takes_lists_and_any_float_dtype():
    v32 = gonio.eval(TRUTH, np.float32([0.3]), [0.0], [0.4], [3.0])
    v64 = gonio.eval(TRUTH, np.array([np.float32(0.3)], dtype=np.float64), [0.0], [0.4], [3.0])
    assert v32.dtype == np.float64
    np.testing.assert_array_equal(v32, v64)


def test_refused_rows_keep_their_place_as_the_cli_writes_them():
    # Rows 1 (theta_o in degrees) and 3 (phi_i not finite) cannot be evaluated: NaN rows in their
    # places, a warning naming each, and the other rows the values they have alone.
    ti = np.array([0.3, 0.2, 0.5, 0.4, 0.1])
    pi_ = np.array([0.0, 0.1, 1.0, np.nan, -2.0])
    to = np.array([0.4, 45.0, 0.2, 0.3, 0.6])
    po = np.array([3.0, 0.0, 0.5, 1.0, 2.0])
    with pytest.warns(UserWarning) as caught:
        ours = gonio.eval(TRUTH, ti, pi_, to, po)
    messages = [str(w.message) for w in caught]
    assert messages == [
        "gonio.eval: row 1: theta_o[1] = 45: outside [0, pi] (NaN row written)",
        "gonio.eval: row 3: phi_i[3] = nan: must be finite (NaN row written)",
    ]
    assert ours.shape == (5, 3)
    assert np.all(np.isnan(ours[[1, 3]]))
    good = [0, 2, 4]
    alone = gonio.eval(TRUTH, ti[good], pi_[good], to[good], po[good])
    np.testing.assert_array_equal(ours[good], alone)
    assert np.all(ours[good] > 0)
    # The command line writes the same rows (NaN where it refuses a line).
    r = run_gonio(
        "eval",
        "material:gold-metallic-paint",
        stdin="theta_i,phi_i,theta_o,phi_o\n"
        + "\n".join(f"{a!r},{b!r},{c!r},{d!r}" for a, b, c, d in zip(ti, pi_, to, po))
        + "\n",
    )
    assert r.returncode == 0, r.stderr
    cli = np.array([[float(x) for x in line.split(",")] for line in r.stdout.strip().splitlines()[1:]])
    with pytest.warns(UserWarning):
        gold = gonio.eval("material:gold-metallic-paint", ti, pi_, to, po)
    np.testing.assert_allclose(gold, cli, rtol=1e-12, atol=0)
    assert np.array_equal(np.isnan(gold), np.isnan(cli))


def test_refused_direction_rows_keep_their_place():
    wi = np.array([[0, 0, 1.0], [0, 0, 2.0], [0.6, 0, 0.8]])
    wo = np.array([[0, 0.6, 0.8], [0, 0, 1.0], [0, 0, np.inf]])
    with pytest.warns(UserWarning) as caught:
        v = gonio.eval(TRUTH, wi, wo)
    assert [str(w.message) for w in caught] == [
        "gonio.eval: row 1: wi[1] = (0, 0, 2): must be a finite unit vector (|norm - 1| <= 1e-6)"
        " (NaN row written)",
        "gonio.eval: row 2: wo[2] = (0, 0, inf): must be a finite unit vector (|norm - 1| <= 1e-6)"
        " (NaN row written)",
    ]
    assert np.all(np.isnan(v[1:]))
    np.testing.assert_array_equal(v[0], gonio.eval(TRUTH, wi[:1], wo[:1])[0])


def test_no_usable_row_raises_naming_the_first():
    with pytest.raises(gonio.Error, match=r"none of the 2 rows can be evaluated \(row 0: theta_i\[0\] = -1"):
        gonio.eval(TRUTH, [-1.0, 0.2], [0, 0], [0.1, 4.0], [0, 0])
    assert gonio.eval(TRUTH, [], [], [], []).shape == (0, 3)
