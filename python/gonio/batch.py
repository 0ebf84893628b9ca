"""Fit every entry of a manifest, one Dask task per entry (docs/scale-out.md).

    python3 -m gonio.batch MANIFEST --out DIR [--scheduler tcp://HOST:8786]

The manifest is a CSV with the columns ``input,model,options[,id]`` (the same file that
``gonio fit --manifest M --shard K/N`` reads). Without ``--scheduler`` a LocalCluster of
``--workers`` processes is started on 127.0.0.1 (no dashboard); with it, the tasks go to an
existing cluster (``dask-scheduler`` plus ``dask-worker`` on other machines, each able to
``import gonio`` and to read the input paths).

Each entry writes ``DIR/ID.json`` (fitted model) and ``DIR/ID.report.json`` (full report), or
``DIR/ID.error.txt``; a failed entry does not stop the others. Entries whose model and report
already exist are skipped, so a rerun resumes. ``DIR/summary.csv`` lists every entry in
manifest order. Exit status: 0 all fitted (or already; a misfit, whose model is written with
its verdict, counts as fitted unless ``--strict``), 1 some entry failed or did not converge (or
is a misfit under ``--strict``), 2 unreadable manifest or bad arguments.
"""

import argparse
import os
import sys
import time

import gonio

__all__ = ["run_batch", "main"]

# A misfit (converged; the model, its verdict and the report written) is a finding, not a
# failure, unless --strict.
_OK = ("fitted", "skipped", "misfit")
_OK_STRICT = ("fitted", "skipped")


def _fit_task(entry_id, input_path, options, out_dir):
    """One manifest entry on a worker (the C++ run of `gonio fit --manifest`, GIL released)."""
    import gonio as g  # imported on the worker

    outcome = g.run_entry(entry_id, input_path, options, out_dir)
    outcome["pid"] = os.getpid()  # the process that fitted it: a worker's on a cluster
    return outcome


def _finished(out_dir, entry_id):
    return os.path.isfile(os.path.join(out_dir, entry_id + ".json")) and os.path.isfile(
        os.path.join(out_dir, entry_id + ".report.json")
    )


class _Progress:
    """A one-line progress bar on a terminal, one line per entry otherwise."""

    def __init__(self, total, stream, enabled=True):
        self.total = total
        self.done = 0
        self.failed = 0
        self.stream = stream
        self.enabled = enabled
        self.tty = hasattr(stream, "isatty") and stream.isatty()
        self.start = time.monotonic()

    def update(self, outcome):
        self.done += 1
        if outcome["status"] not in _OK:
            self.failed += 1
        if not self.enabled:
            return
        width = 30
        filled = int(width * self.done / max(self.total, 1))
        elapsed = time.monotonic() - self.start
        eta = elapsed / self.done * (self.total - self.done) if self.done else 0.0
        bar = "#" * filled + "." * (width - filled)
        line = (
            f"[{bar}] {self.done}/{self.total} failed {self.failed} "
            f"elapsed {elapsed:.0f}s eta {eta:.0f}s  {outcome['id']}: {outcome['status']}"
        )
        if outcome["status"] not in _OK:
            line += f" ({outcome['message']})"
        if self.tty:
            self.stream.write("\r\x1b[2K" + line)
            if self.done == self.total:
                self.stream.write("\n")
        else:
            self.stream.write(line + "\n")
        self.stream.flush()


def _failed_outcome(entry, message):
    return {
        "id": entry["id"],
        "input": entry["input"],
        "status": "failed",
        "message": message,
        "log_rmse": 0.0,
        "rel_rmse": 0.0,
        "iterations": 0,
        "wall_time_s": 0.0,
        "samples_used": 0,
        "pid": None,
        "row": ",".join(
            [entry["id"], entry["input"].replace(",", ";"), "failed", "0", "0", "0", "0", "0",
             message.replace(",", ";").replace("\n", " ")]
        ),
    }


def run_batch(
    manifest,
    out_dir,
    scheduler=None,
    workers=2,
    fit_threads=1,
    serial=False,
    progress=True,
    stream=None,
):
    """Fit every entry of `manifest` into `out_dir`; returns the outcomes in manifest order.

    scheduler: address of an existing Dask scheduler ("tcp://HOST:8786"); None starts a
        LocalCluster of `workers` processes on 127.0.0.1 without dashboard.
    fit_threads: Ceres threads per fit (the option ``threads`` of every entry), 1 by default so
        that the workers, not the solver, use the cores.
    serial: run the entries one after the other in this process (no Dask), for comparison.
    Each outcome is a dict: id, input, status (fitted, misfit, not-converged, failed, skipped),
    message, log_rmse, rel_rmse, iterations, wall_time_s, samples_used, row (its CSV line), pid
    (the process that ran the entry: this one when serial or skipped, a worker's on a cluster;
    None when the task itself failed).
    """
    stream = sys.stderr if stream is None else stream
    entries = gonio.read_manifest(os.fspath(manifest))
    out_dir = os.fspath(out_dir)
    os.makedirs(out_dir, exist_ok=True)
    outcomes = [None] * len(entries)
    todo = []
    for i, e in enumerate(entries):
        options = e["options"] + f";threads={int(fit_threads)}"
        if _finished(out_dir, e["id"]):
            # Reads the metrics back from the report; nothing is fitted again.
            outcomes[i] = gonio.run_entry(e["id"], e["input"], options, out_dir)
            outcomes[i]["pid"] = os.getpid()
        else:
            todo.append((i, e, options))
    bar = _Progress(len(todo), stream, progress)
    if progress:
        stream.write(
            f"{len(entries)} entries: {len(entries) - len(todo)} already fitted, "
            f"{len(todo)} to fit\n"
        )
    if serial or not todo:
        for i, e, options in todo:
            outcomes[i] = _fit_task(e["id"], e["input"], options, out_dir)
            bar.update(outcomes[i])
    else:
        from distributed import Client, LocalCluster, as_completed

        cluster = None
        if scheduler:
            client = Client(scheduler)
        else:
            cluster = LocalCluster(
                n_workers=int(workers),
                threads_per_worker=1,
                processes=True,
                host="127.0.0.1",
                dashboard_address=None,
            )
            client = Client(cluster)
        try:
            futures = {}
            submitted = []
            for i, e, options in todo:
                f = client.submit(
                    _fit_task,
                    e["id"],
                    os.path.abspath(e["input"]),
                    options,
                    os.path.abspath(out_dir),
                    key=f"gonio-fit-{e['id']}-{time.time_ns()}",
                    pure=False,
                )
                futures[f.key] = (i, e)
                submitted.append(f)
            for f in as_completed(submitted):
                i, e = futures[f.key]
                try:
                    outcomes[i] = f.result()
                except Exception as exc:  # a worker died or the task raised
                    outcomes[i] = _failed_outcome(e, f"task failed: {type(exc).__name__}: {exc}")
                bar.update(outcomes[i])
        finally:
            client.close()
            if cluster is not None:
                cluster.close()
    text = gonio._gonio.summary_header() + "\n" + "".join(o["row"] + "\n" for o in outcomes)
    gonio._gonio.write_text_atomically(os.path.join(out_dir, "summary.csv"), text)
    return outcomes


def main(argv=None):
    p = argparse.ArgumentParser(
        prog="python3 -m gonio.batch",
        description="Fit every entry of a manifest CSV (input,model,options[,id]) as one Dask "
        "task each; results DIR/ID.json + DIR/ID.report.json, DIR/summary.csv. Reruns skip "
        "finished entries.",
    )
    p.add_argument("manifest", help="manifest CSV (docs/scale-out.md)")
    p.add_argument("--out", required=True, help="results folder")
    p.add_argument("--scheduler", help="existing Dask scheduler, e.g. tcp://HOST:8786")
    p.add_argument("--workers", type=int, default=2, help="LocalCluster worker processes")
    p.add_argument("--fit-threads", type=int, default=1, help="Ceres threads per fit")
    p.add_argument("--serial", action="store_true", help="no Dask: fit one entry after another")
    p.add_argument("--quiet", action="store_true", help="no progress output")
    p.add_argument(
        "--strict",
        action="store_true",
        help="an entry whose model does not represent its data (misfit) counts as failed",
    )
    a = p.parse_args(argv)
    if a.workers < 1 or a.fit_threads < 0:
        p.error("--workers must be >= 1 and --fit-threads >= 0")
    try:
        outcomes = run_batch(
            a.manifest,
            a.out,
            scheduler=a.scheduler,
            workers=a.workers,
            fit_threads=a.fit_threads,
            serial=a.serial,
            progress=not a.quiet,
        )
    except gonio.Error as e:
        print(f"gonio.batch: {e}", file=sys.stderr)
        return 2
    ok = _OK_STRICT if a.strict else _OK
    bad = [o for o in outcomes if o["status"] not in ok]
    for o in outcomes:
        if o["status"] == "misfit" and not a.strict:
            print(f"gonio.batch: warning: {o['id']}: misfit: {o['message']}", file=sys.stderr)
    for o in bad:
        print(f"gonio.batch: {o['id']}: {o['status']}: {o['message']}", file=sys.stderr)
    print(
        f"{len(outcomes) - len(bad)} of {len(outcomes)} entries fitted; "
        f"summary in {os.path.join(a.out, 'summary.csv')}"
    )
    return 0 if not bad else 1


if __name__ == "__main__":
    sys.exit(main())
