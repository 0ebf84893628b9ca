"""Uses the installed gonio module: samples a shipped material (material:red-plastic) over the
hemisphere, fits a Beckmann model with V-groove shadowing (the structure of that material) to those
samples and prints both side by side in the plane of incidence.

    /usr/bin/python3 fit_material.py [MATERIAL]
"""
import sys

import numpy as np

import gonio

material = "material:" + (sys.argv[1] if len(sys.argv) > 1 else "red-plastic")
rng = np.random.default_rng(1)
n = 2000
theta_i = rng.uniform(0.0, 1.3, n)
theta_o = rng.uniform(0.0, 1.3, n)
phi_o = rng.uniform(-np.pi, np.pi, n)
zeros = np.zeros(n)
value = gonio.eval(material, theta_i, zeros, theta_o, phi_o)
samples = {"theta_i": theta_i, "phi_i": zeros, "theta_o": theta_o, "phi_o": phi_o, "value": value}
model, report = gonio.fit(samples, model="beckmann", shadowing="v-groove")
if not report["solver"]["usable"]:
    sys.exit("fit_material: the model does not represent these samples")

angles = np.radians(np.arange(-60.0, 61.0, 15.0))
t_i = np.full(angles.size, np.radians(30.0))
p_o = np.where(angles > 0, np.pi, 0.0)  # positive: the mirror side, as in the C++ example
truth = gonio.eval(material, t_i, np.zeros(angles.size), np.abs(angles), p_o)
fitted = gonio.eval(model, t_i, np.zeros(angles.size), np.abs(angles), p_o)
print("theta_o truth_r truth_g truth_b fit_r fit_g fit_b")
for a, t, f in zip(np.degrees(angles), truth, fitted):
    print(f"{a:.0f} " + " ".join(f"{x:.6g}" for x in (*t, *f)))
