"""Bad input raises gonio.Error (a ValueError) with the message the command line prints."""

import json

import numpy as np
import pytest

import gonio
from conftest import TRUTH, run_gonio


def cli_message(*args):
    r = run_gonio(*args, stdin="theta_i,phi_i,theta_o,phi_o\n0.1,0,0.1,0\n")
    assert r.returncode != 0
    line = r.stderr.strip().splitlines()[0]
    prefix = f"gonio {args[0]}: "
    assert line.startswith(prefix), line
    return line[len(prefix):]


def test_bad_model_file_same_message_as_cli(workdir):
    bad = dict(TRUTH, lobes=[dict(TRUTH["lobes"][0], alpha=-0.1)])
    path = workdir / "bad.json"
    path.write_text(json.dumps(bad))
    with pytest.raises(gonio.Error) as e:
        gonio.eval(str(path), [0.1], [0.0], [0.1], [0.0])
    assert str(e.value) == cli_message("eval", path)
    assert "lobes[0].alpha" in str(e.value)


def test_missing_table_same_message_as_cli(workdir):
    path = workdir / "missing.binary"
    with pytest.raises(gonio.Error) as e:
        gonio.load(path)
    # Both name the file and say it is missing; the command line refuses it before any work, after
    # the argument it was given as (exit 2: an input named on the command line cannot be read).
    assert str(path) in str(e.value)
    cli = cli_message("check", path)
    assert cli.startswith("brdf: " + str(path) + ": cannot open"), cli


def test_unknown_material_same_message_as_cli():
    with pytest.raises(gonio.Error) as e:
        gonio.check("material:no-such-paint")
    assert str(e.value) == cli_message("check", "material:no-such-paint")


def test_bad_dict_key_names_the_key():
    with pytest.raises(ValueError, match="alhpa"):
        gonio.eval({"lobes": [{"distribution": "ggx", "alhpa": 0.2}]}, [0.1], [0], [0.1], [0])


def test_angle_outside_range_names_row_and_rule():
    with pytest.warns(UserWarning, match=r"row 1: theta_o\[1\] = 4: outside \[0, pi\]"):
        gonio.eval(TRUTH, [0.1, 0.2], [0, 0], [0.1, 4.0], [0, 0])
    with pytest.raises(gonio.Error, match=r"phi_i\[0\] = nan: must be finite"):
        gonio.eval(TRUTH, [0.1], [np.nan], [0.1], [0])


def test_direction_arrays_are_checked():
    with pytest.warns(UserWarning, match=r"wi\[1\].*unit vector"):
        gonio.eval(TRUTH, np.array([[0, 0, 1.0], [0, 0, 2.0]]), np.array([[0, 0, 1.0]] * 2))
    with pytest.raises(gonio.Error, match="N x 3"):
        gonio.eval(TRUTH, np.zeros((2, 2)), np.zeros((2, 2)))
    with pytest.raises(gonio.Error, match="rows"):
        gonio.eval(TRUTH, np.array([[0, 0, 1.0]]), np.array([[0, 0, 1.0]] * 2))


def test_fit_rejects_bad_options_and_empty_data():
    data = {"theta_i": [1.7], "phi_i": [0.0], "theta_o": [0.2], "phi_o": [0.0], "value": [[0.1, 0.1, 0.1]]}
    with pytest.raises(gonio.Error, match="residual"):
        gonio.fit(data, residual="squared")
    with pytest.raises(gonio.Error, match="unknown option \"colour\""):
        gonio.fit(data, colour="red")
    with pytest.raises(gonio.Error, match="valid"):
        gonio.fit(data)


def test_bad_table_dict_raises_instead_of_aborting():
    t = gonio.tabulate(TRUTH, grid=(4, 4, 8))
    bad = dict(t, raw=np.full(10, 1.0))
    with pytest.raises(gonio.Error, match="raw must hold"):
        gonio.eval(bad, [0.1], [0], [0.1], [0])
    bad = dict(t, raw=np.where(np.isfinite(t["raw"]), np.nan, 0))
    with pytest.raises(gonio.Error, match="not finite"):
        gonio.save("x.gtab", bad)


def test_save_unknown_extension(workdir):
    with pytest.raises(gonio.Error, match="unknown file type"):
        gonio.save(workdir / "x.txt", TRUTH)


def test_fit_in_degrees_says_angles_are_radians():
    # The same four samples in degrees: every one is refused, and the reason says why.
    deg = {
        "theta_i": [30.0, 30.0, 45.0, 45.0],
        "phi_i": [0.0, 0.0, 0.0, 0.0],
        "theta_o": [20.0, 40.0, 20.0, 40.0],
        "phi_o": [180.0, 180.0, 180.0, 180.0],
        "value": [[0.1, 0.1, 0.1]] * 4,
    }
    with pytest.raises(gonio.Error, match=r"no valid sample to fit \(4 rejected.*theta_i = 30 "
                       r"at or below the horizon.*looks like degrees: angles are radians"):
        gonio.fit(deg)
    # Azimuths alone in degrees say so too.
    az = dict(deg, theta_i=[0.5] * 4, theta_o=[0.3, 0.6, 0.3, 0.6])
    with pytest.raises(gonio.Error, match=r"phi_o = 180 outside \[-2 pi, 2 pi\]; it looks like "
                       r"degrees"):
        gonio.fit(az)
