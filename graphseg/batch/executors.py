"""Executors of batch tasks: local worker processes (default) and Ray.

Both run the same :func:`graphseg.batch.worker.run_task` and hand every record
to a callback as soon as it arrives, so the caller can show progress.

* :class:`LocalExecutor` keeps ``jobs`` worker processes (started once, so
  imports are paid once). A worker that dies (killed, out of memory) is
  reported as a ``failed`` record naming the signal and is replaced; the other
  tasks go on.
* :class:`RayExecutor` submits one Ray task per batch task with per-task
  resources (CPUs; GPUs for model backends) and ``max_retries``, so a killed
  worker's task is retried by Ray.

Ctrl-C stops the workers, removes the temporary folders of the interrupted
tasks and re-raises :class:`KeyboardInterrupt`; finished outputs are untouched.
"""

from __future__ import annotations

import os
import signal
import sys
from collections import deque
from collections.abc import Callable, Sequence
from typing import Any

from .worker import run_task

__all__ = ["LocalExecutor", "RayExecutor", "MODEL_BACKENDS", "failed_record"]

Record = dict[str, Any]
Callback = Callable[[Record], None]

#: Backends that run a neural network (a Ray task using one asks for a GPU when the cluster has one).
MODEL_BACKENDS = frozenset({"sam2", "sam-onnx", "loftr", "roma", "dust3r", "da3", "dinov2"})


def failed_record(task: dict[str, Any], error: str) -> Record:
    """A ``failed`` record for ``task`` that never produced its own."""
    rec = {k: task[k] for k in ("key", "scene", "scene_label", "split", "method", "label", "num_views", "out")}
    rec.update(status="failed", error=error, seconds=None)
    return rec


def remove_partial(task: dict[str, Any]) -> None:
    """Remove the temporary siblings an interrupted task left next to its output folder."""
    from ..output import clean_stale

    clean_stale(task["out"])


def _worker_main(conn: Any) -> None:  # pragma: no cover - runs in the child process
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent handles Ctrl-C
    while True:
        try:
            task = conn.recv()
        except EOFError:
            return
        if task is None:
            return
        conn.send(run_task(task))


def _death(exitcode: int | None) -> str:
    if exitcode is not None and exitcode < 0:
        try:
            return f"worker killed by {signal.Signals(-exitcode).name}"
        except ValueError:
            pass
    return f"worker exited with code {exitcode}"


class _Worker:
    def __init__(self, ctx: Any) -> None:
        self.conn, child = ctx.Pipe()
        self.proc = ctx.Process(target=_worker_main, args=(child,), daemon=True)
        self.proc.start()
        child.close()
        self.task: dict[str, Any] | None = None

    def stop(self, force: bool = False) -> None:
        if force:
            self.proc.terminate()
        else:
            try:
                self.conn.send(None)
            except OSError:
                pass
        self.proc.join(5)
        if self.proc.is_alive():  # pragma: no cover
            self.proc.kill()
            self.proc.join()
        self.conn.close()


class LocalExecutor:
    """Run tasks in ``jobs`` local worker processes (started with ``spawn``).

    Examples
    --------
    >>> LocalExecutor(jobs=2).jobs
    2
    """

    name = "local"

    def __init__(self, jobs: int = 1) -> None:
        if jobs < 1:
            raise ValueError(f"expected jobs >= 1 (got {jobs})")
        self.jobs = int(jobs)

    def execute(self, tasks: Sequence[dict[str, Any]], on_record: Callback) -> None:
        """Run every task; ``on_record(record)`` is called once per task, in completion order."""
        import multiprocessing as mp
        from multiprocessing.connection import wait

        if not tasks:
            return
        ctx = mp.get_context("spawn")
        pending = deque(tasks)
        workers = [_Worker(ctx) for _ in range(min(self.jobs, len(tasks)))]
        try:
            while pending or any(w.task is not None for w in workers):
                for w in workers:
                    if w.task is None and pending:
                        w.task = pending.popleft()
                        w.conn.send(w.task)
                busy = [w for w in workers if w.task is not None]
                ready = wait([w.conn for w in busy] + [w.proc.sentinel for w in busy])
                for i, w in enumerate(workers):
                    if w.task is None or not (w.conn in ready or w.proc.sentinel in ready):
                        continue
                    rec = None
                    try:
                        if w.conn.poll():
                            rec = w.conn.recv()
                    except (EOFError, OSError):
                        rec = None
                    if rec is not None:
                        w.task = None
                        on_record(rec)
                        continue
                    if w.proc.is_alive():
                        continue
                    task, w.task = w.task, None
                    remove_partial(task)
                    on_record(failed_record(task, _death(w.proc.exitcode)))
                    w.stop(force=True)
                    workers[i] = _Worker(ctx)
        except BaseException:
            for w in workers:
                w.stop(force=True)
                if w.task is not None:
                    remove_partial(w.task)
            raise
        for w in workers:
            w.stop()


class RayExecutor:
    """Run tasks as Ray tasks (``pip install "graphseg[ray]"``).

    Parameters
    ----------
    address : str, optional
        ``None`` starts (or reuses) a local Ray; ``"auto"`` or ``"ray://host:port"``
        connects to an existing cluster.
    num_cpus : int, optional
        CPUs of a local Ray started here.
    cpus_per_task : float
    gpus_per_task : float or "auto"
        ``"auto"``: 1 for tasks that use a model backend when the cluster has
        GPUs, else 0.
    max_retries : int
        Times Ray re-runs a task whose worker died.
    """

    name = "ray"

    def __init__(
        self,
        address: str | None = None,
        *,
        num_cpus: int | None = None,
        cpus_per_task: float = 1.0,
        gpus_per_task: float | str = "auto",
        max_retries: int = 2,
    ) -> None:
        self.address = address
        self.num_cpus = num_cpus
        self.cpus_per_task = cpus_per_task
        self.gpus_per_task = gpus_per_task
        self.max_retries = max_retries

    def _runtime_env(self) -> dict[str, Any] | None:
        # On a cluster on this machine, workers import graphseg (and plugins) from the driver's paths.
        if self.address is not None and self.address.startswith("ray://"):
            return None
        paths = [p for p in sys.path if p and os.path.isdir(p)]
        return {"env_vars": {"PYTHONPATH": os.pathsep.join(paths)}}

    def execute(self, tasks: Sequence[dict[str, Any]], on_record: Callback) -> None:
        """Run every task on Ray; ``on_record(record)`` once per task, in completion order."""
        from ..registry import require

        ray = require("ray", "ray")
        if not tasks:
            return
        started = False
        if not ray.is_initialized():
            kwargs: dict[str, Any] = {"include_dashboard": False, "log_to_driver": False, "logging_level": "WARNING"}
            if self.address is None:
                ray.init(num_cpus=self.num_cpus, **kwargs)
            else:
                ray.init(address=self.address, **kwargs)
            started = True
        try:
            has_gpu = float(ray.cluster_resources().get("GPU", 0)) > 0
            fn = ray.remote(run_task)
            refs: dict[Any, dict[str, Any]] = {}
            env = self._runtime_env()
            for t in tasks:
                gpus = self.gpus_per_task
                if gpus == "auto":
                    uses_model = any(b in MODEL_BACKENDS for b in (t.get("backends") or {}).values() if b)
                    gpus = 1.0 if (uses_model and has_gpu) else 0.0
                opts: dict[str, Any] = {"num_cpus": self.cpus_per_task, "num_gpus": float(gpus), "max_retries": self.max_retries}
                if env:
                    opts["runtime_env"] = env
                refs[fn.options(**opts).remote(t)] = t
            try:
                while refs:
                    done, _ = ray.wait(list(refs), num_returns=1)
                    for r in done:
                        t = refs.pop(r)
                        try:
                            rec = ray.get(r)
                        except ray.exceptions.RayError as err:
                            remove_partial(t)
                            rec = failed_record(t, f"Ray task failed after {self.max_retries} retries: {type(err).__name__}")
                        on_record(rec)
            except BaseException:
                for r, t in refs.items():
                    ray.cancel(r, force=True)
                    remove_partial(t)
                raise
        finally:
            if started:
                ray.shutdown()
