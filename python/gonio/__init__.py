"""gonio: gonioreflectometer data and BRDF fits from Python.

The functions are bindings of gonio's C++ libraries (no reimplementation): evaluate a BRDF
model or table on numpy arrays (``eval``), read and write datasets, tables and models
(``load``, ``save``, ``tabulate``), fit analytic models with Ceres (``fit``), run the property
checks (``check``) and read a campaign folder (``load_campaign``). Batch fitting over Dask:
``python3 -m gonio.batch`` (docs/scale-out.md).

Errors raise ``gonio.Error`` (a ``ValueError``) with the same message the command line prints.
"""

import json as _json
import os as _os
import warnings as _warnings

from ._gonio import (  # noqa: F401  (re-exported)
    Error,
    __version__,
    check,
    eval,
    load,
    material,
    materials,
    read_manifest,
    run_entry,
    save,
    tabulate,
)
from . import _gonio

__all__ = [
    "__version__",
    "Error",
    "check",
    "eval",
    "fit",
    "load",
    "load_campaign",
    "material",
    "materials",
    "read_manifest",
    "run_entry",
    "save",
    "tabulate",
]


def fit(
    samples, model="ggx", residual=None, max_samples=None, truth=None, strict=False, **options
):
    """Fit an analytic BRDF model to measured samples with Ceres.

    samples: a path (dataset CSV, or a table *.binary/*.merl/*.gtab), a samples dict or a
        table dict from ``gonio.load()``.
    model: "ggx", "beckmann", "blinn-phong" or "student-t" (structure further set by the options
        fresnel, shadowing, diffuse, anisotropic, lobes, roughness), "auto" (candidates ranked
        by BIC, the winner polished, as ``gonio fit --model auto``; the ranking is in
        ``report["auto"]``), a fit-template path (*.json) or a fit-template dict
        ``{"model": {...}, "free": [...], "fixed": [...], "shared": [...], "bounds": {...}}``
        (docs/fitting-guide.md). With "auto" or a template the structure options are refused
        (gonio.Error naming both).
    residual: "absolute", "relative", "log", "cosine" or "cbrt" (None: the default of
        ``gonio fit``, "log").
    max_samples: stratified reduction to about this many samples for the solve (0 = all;
        None: the default of ``gonio fit``); the metrics are always over all valid samples.
    truth: optional ground-truth model (dict or path), copied into the report.
    options: fresnel ("schlick", "schlick-rgb", "dielectric", "conductor", "none"),
        shadowing ("smith-correlated", "smith-separable", "v-groove", "none"), diffuse (bool),
        anisotropic (bool), lobes (0-4), roughness ("shared" or "rgb": one alpha per channel),
        loss ("none", "huber", "cauchy"), loss_scale, starts, seed, max_iterations, threads
        (0 = all cores).

    Returns ``(model, report)``: the fitted model as a dict in the model schema and the full
    fit report as ``gonio fit --out`` writes it (parameters with one-sigma uncertainties,
    not_identifiable, at_bounds, vanished_lobes, metrics, sample counts, solver summary).
    Check ``report["solver"]["usable"]``: a solve that ran but did not converge is returned,
    not raised. ``report["goodness"]["verdict"]`` is the headline's state: "represents",
    "visible-misfit" (usable, the misfit named in ``headline``) or "does-not-represent" (a
    misfit). Both misfit states are returned with a ``UserWarning`` carrying the headline and the
    suggestion; with ``strict=True`` a fit that does not represent the data raises gonio.Error
    instead (as ``gonio fit --strict`` exits 1). The GIL is released while Ceres runs, so other Python threads go on.

    Raises gonio.Error for unreadable input, no valid sample or an inconsistent spec.
    """
    fitted, report = _gonio._fit(samples, model, residual, max_samples, truth, options)
    goodness = report.get("goodness", {})
    verdict = goodness.get("verdict", "represents")
    if report.get("solver", {}).get("converged") and verdict != "represents":
        # The headline of the report (the same words as `gonio fit` and the HTML report).
        message = goodness.get("headline", verdict)
        if goodness.get("suggestion"):
            message += "; " + goodness["suggestion"]
        if strict and verdict == "does-not-represent":
            raise Error(message)
        _warnings.warn(message, UserWarning, stacklevel=2)
    return fitted, report


def load_campaign(folder):
    """Read a campaign folder (``gonio acquire`` output).

    Returns a dict: ``dataset`` (samples dict of ``dataset.csv`` as ``gonio.load`` gives it,
    or None when the folder has none yet), and every top-level JSON file parsed into a dict
    under its name without extension (``metadata``, ``campaign``, ``rig``, ``fit``...), plus
    ``path``. A JSON file whose name without extension is already a key (``dataset.json`` of an
    image-mode campaign, beside ``dataset``) is kept under its full file name
    (``"dataset.json"``). Raises gonio.Error when the folder does not exist.
    """
    folder = _os.fspath(folder)
    if not _os.path.isdir(folder):
        raise Error(f"{folder}: not a campaign folder (no such directory)")
    out = {"path": folder}
    csv = _os.path.join(folder, "dataset.csv")
    out["dataset"] = load(csv) if _os.path.isfile(csv) else None
    for name in sorted(_os.listdir(folder)):
        full = _os.path.join(folder, name)
        if name.endswith(".json") and _os.path.isfile(full):
            with open(full, encoding="utf-8") as f:
                stem = name[: -len(".json")]
                key = name if stem in out else stem
                try:
                    out[key] = _json.load(f)
                except ValueError as e:
                    raise Error(f"{full}: not valid JSON: {e}") from None
    return out
