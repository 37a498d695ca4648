"""Running a sweep: chunks of batch simulations, in-process or on a Dask cluster.

Each chunk is one batch call of :func:`mckibben.plant.simulate` and is written as one Parquet file
``chunk-NNNNN.parquet`` atomically (a temporary file, fsync, rename), so a result file is either
complete or absent. A rerun skips chunks already written for the same sweep file (its hash is
in every file's metadata), so an interrupted sweep resumes. Every random draw is made up front
from the sweep's seed (:func:`mckibben.sweep.spec.load_sweep`) and every simulation is
deterministic, so the numbers do not depend on how many workers ran them.
"""

from __future__ import annotations

import itertools
import json
import os
import threading
import time
import warnings
from collections import deque
from concurrent.futures import ThreadPoolExecutor
from dataclasses import fields
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

import mckibben
from mckibben.control import registry as R
from mckibben.errors import ArgumentTypeError, InputError, check_callable, check_instance, check_int
from mckibben.sweep.spec import Sweep
from mckibben.datasets import get_muscle
from mckibben.plant import PlantParams
from mckibben.plant.packing import _FIELDS
from mckibben.control.core import CoreParams, core_spec
from mckibben.control.metrics import step_metrics_batch, tracking_metrics_batch
from mckibben.plant import simulate
from mckibben.atomic import TMP_TAG
from mckibben.atomic import as_path, check_output_dir, clean_stale
from mckibben.atomic import atomic_file
from mckibben.limits import SECONDS_PER_SAMPLE, check_budget


def chunk_path(out: Path, k: int) -> Path:
    """Where chunk k is written.

    Parameters
    ----------
    out : Path
        The results folder.
    k : int
        Chunk index. [-]
    """
    return out / f"chunk-{k:05d}.parquet"


def _plants(rows: pd.DataFrame):
    """One PlantParams with array fields for the chunk (muscles may differ between rows)."""

    n = len(rows)
    if "plant.muscle" in rows:
        names, which = np.unique(rows["plant.muscle"].to_numpy(dtype=str), return_inverse=True)
    else:
        names, which = np.array(["mpam97"]), np.zeros(n, dtype=np.intp)
    bases = [PlantParams.for_muscle(get_muscle(str(name))) for name in names]
    values = {f: np.array([float(np.asarray(getattr(b, f))) for b in bases])[which] for f in _FIELDS}
    for col in rows.columns:
        if col.startswith("plant.") and col != "plant.muscle":
            values[col[6:]] = rows[col].to_numpy(dtype=float)
    values["seed"] = rows["noise_seed"].to_numpy(dtype=float)
    return PlantParams(**values, muscle_name="")


def _controllers(rows: pd.DataFrame, kind: str):
    """The chunk's controller spec, packed column by column (:func:`mckibben.control.core.pack_batch`)."""

    names = {f.name for f in fields(CoreParams)}
    cols = {c[11:]: rows[c].to_numpy(dtype=float) for c in rows.columns
            if c.startswith("controller.") and c[11:] in names}
    cols["mode"] = np.full(len(rows), float(R.get(kind).mode))
    return core_spec(cols)


def _reference(scenario: dict, n_steps: int) -> np.ndarray:
    t = np.arange(n_steps) * 1e-3
    if scenario["kind"] == "step":
        ref = np.full(n_steps, scenario["target"])
        ref[: int(0.01 / 1e-3)] = scenario["start"]  # the step comes at 10 ms
        return ref
    return scenario["mean"] + scenario["amplitude"] * np.sin(2 * np.pi * scenario["frequency"] * t)


def run_chunk(meta: dict, rows: pd.DataFrame, k: int, out: str) -> dict:
    """Simulate one chunk and write its Parquet file atomically.

    Parameters
    ----------
    meta : dict
        The sweep's scenario, controller kind, metrics and provenance.
    rows : pandas.DataFrame
        The chunk's design rows.
    k : int
        Chunk index. [-]
    out : str
        Results folder.

    Returns
    -------
    dict
        ``chunk``, ``runs``, ``seconds``, ``path``.
    """

    t0 = time.perf_counter()
    scenario = meta["scenario"]
    n_steps = int(round(scenario["duration"] / 1e-3))
    ref = _reference(scenario, n_steps)
    # only what the metrics read: the other eight series would be written for nothing
    plants, controllers = _plants(rows), _controllers(rows, meta["controller"])
    with _SIMULATING:  # one chunk on the cores at a time; the other chunk in flight does its Python
        res = simulate(plants, n_steps * 1e-3, controller=controllers, reference=ref, n=len(rows),
                       record=("pressure", "inlet", "bleed"))
    # every run of the chunk at once; rows the simulator left non-finite get NaN
    if scenario["kind"] == "step":
        m = step_metrics_batch(res.t, res.pressure, ref, res.command, t_step=0.01)
    else:
        m = tracking_metrics_batch(res.t, res.pressure, ref, res.command)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a run that is NaN throughout
        m["max_pressure_Pa"] = np.nanmax(res.pressure, axis=1)
    nan = np.full(len(rows), np.nan)
    table = rows.reset_index(drop=True)
    table = table.assign(**{name: m.get(name, nan) for name in meta["metrics"]})
    table["chunk"] = k
    table["sim_flags"] = res.flags
    arrow = pa.Table.from_pandas(table, preserve_index=False)
    arrow = arrow.replace_schema_metadata({**(arrow.schema.metadata or {}), b"mckibben": json.dumps(meta["provenance"]).encode()})
    path = chunk_path(Path(out), k)

    # not atomic_file: workers on other hosts write here too, so no stale-temporary sweep per chunk
    tmp = path.with_name(f".{path.name}{TMP_TAG}{os.getpid()}-{k:x}")
    try:
        with open(tmp, "wb") as fh:
            pq.write_table(arrow, fh)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    return {"chunk": k, "runs": len(rows), "seconds": time.perf_counter() - t0, "path": str(path)}


def chunk_done(path: Path, sha256: str) -> bool:
    """Whether a chunk file exists, reads, and belongs to the sweep with this hash.

    Parameters
    ----------
    path : Path
        The chunk file.
    sha256 : str
        The sweep file's hash.
    """
    if not path.exists():
        return False
    try:
        meta = pq.read_schema(path).metadata or {}
        prov = json.loads(meta.get(b"mckibben", b"{}"))
    except Exception:  # a foreign or damaged file: redo the chunk
        return False
    return prov.get("sweep_sha256") == sha256


def prepare_output(out: str | Path, sweep: Sweep) -> Path:
    """Create (or check) the results folder; refuse one that holds another sweep's results.

    Parameters
    ----------
    out : str or Path
        Results folder.
    sweep : Sweep
        The sweep.
    """

    out = check_output_dir(out, "out")
    try:
        out.mkdir(parents=True, exist_ok=True)
        probe = out / f".probe-{os.getpid()}"
        probe.write_bytes(b"")
        probe.unlink()
    except OSError as exc:
        raise InputError(f"out: cannot write to {str(out)!r} ({exc.strerror})") from None
    clean_stale(out)
    manifest = out / "sweep.json"
    old: dict = {}
    info = {"sweep_sha256": sweep.sha256, "sweep_file": sweep.path, "seed": sweep.seed, "runs": sweep.n_runs,
            "chunks": sweep.n_chunks, "chunk_size": sweep.chunk_size}
    if manifest.exists():
        try:
            old = json.loads(manifest.read_text()) if manifest.is_file() else {}
        except (OSError, ValueError):
            old = {}
        other = old.get("sweep_sha256")
        if other != sweep.sha256 and any(chunk_done(f, other) for f in out.glob("chunk-*.parquet")):
            raise InputError(f"out: {str(out)!r} holds the results of another sweep; choose another folder")
    if not manifest.exists() or old.get("sweep_sha256") != sweep.sha256:
        # a folder without another sweep's results (e.g. left by a failed run) is reused

        with atomic_file(manifest, "out") as tmp:
            tmp.write_text(json.dumps(info, indent=2))
    return out


#: Most local Dask worker processes :func:`run_sweep` starts (the command line's ``--workers`` bound). [-]
MAX_WORKERS = 256


def run_sweep(sweep: Sweep, out: str | Path, *, workers: int | None = None, scheduler: str | None = None,
              progress=None) -> dict:
    """Run every chunk not yet written: in-process, on a local cluster, or on a scheduler.

    Parameters
    ----------
    sweep : Sweep
        The validated sweep.
    out : str or Path
        Results folder (a Parquet dataset, one file per chunk).
    workers : int, optional
        Start a local Dask cluster with this many single-threaded worker processes, 1 to
        :data:`MAX_WORKERS`.
    scheduler : str, optional
        Address of an existing Dask scheduler, ``tcp://HOST:PORT``.
    progress : callable, optional
        ``progress(done_runs, total_runs)`` after each chunk.

    Returns
    -------
    dict
        ``runs``, ``chunks``, ``skipped`` (chunks already written), ``computed`` (chunks),
        ``computed_runs``, ``seconds``, ``sims_per_second``.
    """

    # every argument checked before a worker starts or a file is written
    check_instance(sweep, "sweep", Sweep, "a Sweep (load_sweep)")
    if not isinstance(out, (str, os.PathLike)) or not str(out):
        raise ArgumentTypeError(f"out = {out!r}: not a folder path (str or os.PathLike)")
    if workers is not None:
        workers = check_int(workers, "workers", lo=1, hi=MAX_WORKERS)
    if scheduler is not None and not isinstance(scheduler, str):
        raise ArgumentTypeError(f"scheduler = {scheduler!r}: not an address (str), e.g. tcp://HOST:PORT")
    if workers is not None and scheduler is not None:
        raise InputError("workers and scheduler: give one, not both")
    check_callable(progress, "progress")
    # the documented limits (lifted by mckibben.limits.lifted(), the CLI's --force): memory, one
    # chunk per worker at a time; time, the wall time shared by the workers
    steps = round(sweep.scenario["duration"] / 1e-3)
    check_budget("sweep (samples x grid x duration, chunk_size)", sweep.n_runs * steps,
                 memory_samples=min(sweep.chunk_size, sweep.n_runs) * steps * (workers or IN_FLIGHT),
                 seconds_per_sample=SECONDS_PER_SAMPLE / (workers or 1))
    out = prepare_output(out, sweep)
    meta = {
        "scenario": sweep.scenario, "controller": sweep.controller_kind, "metrics": list(sweep.metrics),
        "provenance": {"package_version": mckibben.__version__, "sweep_sha256": sweep.sha256,
                       "sweep_file": sweep.path, "seed": sweep.seed},
    }
    todo = [k for k in range(sweep.n_chunks) if not chunk_done(chunk_path(out, k), sweep.sha256)]
    skipped = sweep.n_chunks - len(todo)
    done_runs = sum(len(sweep.chunk(k)) for k in range(sweep.n_chunks) if k not in set(todo))
    t0 = time.perf_counter()
    if progress:
        progress(done_runs, sweep.n_runs)
    if scheduler is None and not workers:
        _run_local(sweep, meta, todo, out, progress, done_runs)
    else:
        _run_dask(sweep, meta, todo, out, workers, scheduler, progress, done_runs)
    seconds = time.perf_counter() - t0
    computed_runs = sum(len(sweep.chunk(k)) for k in todo)
    return {"runs": sweep.n_runs, "chunks": sweep.n_chunks, "skipped": skipped, "computed": len(todo),
            "computed_runs": computed_runs, "seconds": seconds,
            "sims_per_second": computed_runs / seconds if computed_runs and seconds > 0 else None}


#: Chunks in flight in-process. A chunk's simulation runs compiled on every core without the GIL,
#: but its Python (design rows, metrics, Parquet, fsync) holds one core; with a second chunk in
#: flight that Python runs while the other chunk simulates, instead of idling the other cores.
#: The simulations themselves take turns (:data:`_SIMULATING`), so the cores are not shared between
#: two chunks' working sets. The results do not depend on it: each chunk is computed and written
#: on its own.
IN_FLIGHT = 2
_SIMULATING = threading.Lock()


def _run_local(sweep, meta, todo, out, progress, done_runs):
    """The chunks of ``todo`` in this process, :data:`IN_FLIGHT` at a time; progress in chunk order."""
    pool = ThreadPoolExecutor(IN_FLIGHT, thread_name_prefix="mckibben-sweep")
    try:
        pending: deque = deque()
        chunks = iter(todo)
        for k in itertools.islice(chunks, IN_FLIGHT):
            pending.append(pool.submit(run_chunk, meta, sweep.chunk(k), k, str(out)))
        while pending:
            r = pending.popleft().result()
            k = next(chunks, None)
            if k is not None:
                pending.append(pool.submit(run_chunk, meta, sweep.chunk(k), k, str(out)))
            done_runs += r["runs"]
            if progress:
                progress(done_runs, sweep.n_runs)
    finally:  # an error or an interrupt: chunks not started are dropped, the running ones end written
        pool.shutdown(wait=True, cancel_futures=True)


def _run_dask(sweep, meta, todo, out, workers, scheduler, progress, done_runs):
    from distributed import Client, LocalCluster, as_completed  # deferred on purpose: Dask

    cluster = None
    try:
        if scheduler is not None:
            try:
                client = Client(scheduler, timeout="3s")
            except (OSError, TimeoutError) as exc:
                raise InputError(f"scheduler: cannot reach {scheduler} ({exc})") from None
        else:
            cluster = LocalCluster(n_workers=int(workers), threads_per_worker=1, processes=True,
                                   dashboard_address=None, silence_logs=40)
            client = Client(cluster)
        with client:
            futures = [client.submit(run_chunk, meta, sweep.chunk(k), k, str(out), key=f"chunk-{sweep.sha256[:12]}-{k}",
                                     retries=3, pure=False) for k in todo]
            for fut in as_completed(futures):
                r = fut.result()
                done_runs += r["runs"]
                if progress:
                    progress(done_runs, sweep.n_runs)
    finally:
        if cluster is not None:
            cluster.close()


def read_results(out: str | Path) -> pd.DataFrame:
    """All chunk files of a results folder as one table, in run order.

    Parameters
    ----------
    out : str or Path
        Results folder.
    """
    out = as_path(out, "out", "results folder")
    files = sorted(f for f in out.glob("chunk-*.parquet") if f.is_file())  # never open a FIFO
    if not out.is_dir() or not files:
        raise InputError(f"{str(out)!r}: no sweep results (chunk-*.parquet) there")
    try:
        table = pd.concat([pd.read_parquet(f) for f in files], ignore_index=True)
    except Exception as exc:
        raise InputError(f"{str(out)!r}: cannot read the results ({exc})") from None
    return table.sort_values("run_id").reset_index(drop=True)
