#!/usr/bin/python3
"""Reference fit with scipy.optimize.least_squares for the fitting benchmark.

Fits gonio's default model to a dataset CSV (theta_i,phi_i,theta_o,phi_o,r,g,b; radians, 1/sr):

    f_c = rho_c / pi + scale_c F D G / (4 cos_i cos_o)

with GGX D, height-correlated Smith G, scalar Schlick F = f0 + (1 - f0)(1 - wi.h)^5 (Walter et al.
2007; Heitz 2014; Schlick 1994), 8 parameters (rho rgb, alpha, f0, scale rgb), log residual
log(1 + f cos_i) - log(1 + d cos_i) as gonio's default, trust-region reflective solver with
bounds and a 2-point finite-difference Jacobian (the scipy default). Prints one JSON line:
{"read_s", "fit_s", "total_s", "nfev", "log_rmse", "x"}.

    /usr/bin/python3 bench/scipy_fit.py data.csv
"""

import json
import sys
import time

import numpy as np
from scipy.optimize import least_squares


def directions(theta, phi):
    s = np.sin(theta)
    return np.stack([s * np.cos(phi), s * np.sin(phi), np.cos(theta)], axis=1)


def main():
    t0 = time.perf_counter()
    data = np.loadtxt(sys.argv[1], delimiter=",", skiprows=1, usecols=range(7))
    t1 = time.perf_counter()
    wi = directions(data[:, 0], data[:, 1])
    wo = directions(data[:, 2], data[:, 3])
    d = data[:, 4:7]
    h = wi + wo
    h /= np.linalg.norm(h, axis=1)[:, None]
    cos_i = wi[:, 2]
    cos_o = wo[:, 2]
    cos_h2 = h[:, 2] ** 2
    sin_h2 = 1 - cos_h2
    x5 = np.clip(1 - np.sum(wi * h, axis=1), 0, 1) ** 5
    tan2_i = (1 - cos_i**2) / cos_i**2
    tan2_o = (1 - cos_o**2) / cos_o**2
    inv4cc = 1 / (4 * cos_i * cos_o)
    target = np.log1p(d * cos_i[:, None])

    def model(x):
        rho, alpha, f0, scale = x[0:3], x[3], x[4], x[5:8]
        a2 = alpha * alpha
        s = sin_h2 / a2 + cos_h2
        dist = 1 / (np.pi * a2 * s * s)
        li = (np.sqrt(1 + a2 * tan2_i) - 1) / 2
        lo = (np.sqrt(1 + a2 * tan2_o) - 1) / 2
        g = 1 / (1 + li + lo)
        fres = f0 + (1 - f0) * x5
        lobe = dist * g * fres * inv4cc
        return rho[None, :] / np.pi + scale[None, :] * lobe[:, None]

    def residual(x):
        return (np.log1p(model(x) * cos_i[:, None]) - target).ravel()

    x0 = np.array([0.2, 0.2, 0.2, 0.2, 0.04, 1.0, 1.0, 1.0])
    lo = np.array([0, 0, 0, 1e-4, 0, 0, 0, 0])
    hi = np.array([10, 10, 10, 1.5, 1, 1e4, 1e4, 1e4])
    res = least_squares(residual, x0, bounds=(lo, hi), method="trf", x_scale="jac")
    t2 = time.perf_counter()
    r = res.fun.reshape(-1, 3)
    print(
        json.dumps(
            {
                "read_s": t1 - t0,
                "fit_s": t2 - t1,
                "total_s": t2 - t0,
                "nfev": int(res.nfev),
                "log_rmse": float(np.mean(np.sqrt(np.mean(r * r, axis=0)))),
                "x": [float(v) for v in res.x],
            }
        )
    )


if __name__ == "__main__":
    main()
