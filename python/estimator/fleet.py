"""Fleets: many logs or seeds at once on a Dask cluster, one table back.

>>> table = estimator.fleet([estimator.Job("navego", "data/navego/kf-gins-ADIS16488.yaml",
...                                          truth="data/navego/truth.nav.zst", skip=60)])

Each job is one :func:`estimator.navigate` run (its options in ``Job.options``) or any
function of your own (``Job.run``, e.g. a simulated seed of a campaign) returning a
dict of figures. The jobs go to a Dask cluster — a local one with ``workers`` processes
when no ``client`` or ``address`` is given — and come back as a pandas DataFrame, one
row per job in the order given: the errors against the truth where one is given, the
consistency verdict and its warning, the share of measurements refused, the wall time,
and, for a job that failed, ``ok = False`` and the error's message. One bad log never
stops the fleet. Dask is needed only here (``pip install "estimator[fleet]"``).
"""

from __future__ import annotations

import os
import sys
import time
from dataclasses import dataclass, field
from typing import Any, Callable, Iterable, Mapping, Optional, Union

import pandas as pd

__all__ = ["Job", "fleet", "run_job"]


@dataclass
class Job:
    """One run of a fleet.

    Attributes:
        name: the row's name.
        config: a configuration file (TOML, KF-GINS YAML) or a dict of our TOML's tables.
        truth: a truth file to evaluate against (optional).
        skip: seconds left out at the start of the evaluation.
        options: keyword arguments of :func:`estimator.navigate` (``strategy``,
            ``smooth``, ``states``, ``nhc`` …). ``accept_inconsistent`` is always on: the
            verdict is a column, not an exception.
        run: instead of a navigation, a function ``run(**options)`` returning a dict of
            figures (a row of your own), e.g. one seed of a simulated campaign.
    """

    name: str
    config: Union[str, os.PathLike, Mapping[str, Any], None] = None
    truth: Union[str, os.PathLike, None] = None
    skip: float = 0.0
    options: Mapping[str, Any] = field(default_factory=dict)
    run: Optional[Callable[..., Mapping[str, Any]]] = None


def run_job(job: Job) -> dict:
    """One job, on whatever process calls it: its row of the table (never raises)."""
    from . import navigate  # (on a worker: the package is imported there)

    row: dict = {"name": job.name, "ok": True, "error": None}
    t0 = time.perf_counter()
    try:
        if job.run is not None:
            row.update(job.run(**dict(job.options)))
        else:
            options = dict(job.options)
            options["accept_inconsistent"] = True
            nav = navigate(job.config, **options)
            s = nav.summary
            used = s["accepted"] + s["inflated"] + s["deflated"] + s["rejected"]
            row.update({
                "verdict": "trusted" if s.get("warning") is None else "flagged",
                "warning": s.get("warning"),
                "consistent": s.get("consistent"),
                "mean_nis": s.get("mean_nis"),
                "refused_share": s["rejected"] / used if used else float("nan"),
                "imu_epochs": s["imu_epochs"],
                "gnss_epochs": s["gnss_epochs"],
            })
            if job.truth is not None:
                smoothed = bool(options.get("smooth"))
                ev = nav.evaluate(job.truth, job.skip, smoothed=smoothed)["overall"]
                row.update({
                    "horizontal_rms": ev["horizontal"]["rms"],
                    "horizontal_max": ev["horizontal"]["max"],
                    "down_rms": ev["down"]["rms"],
                    "position_3d_rms": ev["position_3d"]["rms"],
                    "velocity_rms": ev["velocity_3d"]["rms"],
                })
    except Exception as e:  # a bad log is a row of the table, not the end of the fleet
        row.update({"ok": False, "error": f"{type(e).__name__}: {e}"})
    row["time_s"] = time.perf_counter() - t0
    return row


def _progress(done: int, total: int, failed: int, stream) -> None:
    width = 30
    filled = int(width * done / max(total, 1))
    stream.write(f"\rfleet [{'#' * filled}{'.' * (width - filled)}] {done}/{total}"
                 f"{f' ({failed} failed)' if failed else ''}")
    stream.flush()


def fleet(
    jobs: Iterable[Job],
    *,
    client: Any = None,
    address: Optional[str] = None,
    workers: int = 2,
    progress: bool = True,
) -> pd.DataFrame:
    """Run ``jobs`` on a Dask cluster and return one row per job, in order.

    Args:
        jobs: :class:`Job` objects (a path or a dict is taken as ``Job(name, config)``).
        client: a ``dask.distributed.Client`` to run on.
        address: a scheduler's address (``"tcp://host:8786"``) to connect to instead.
        workers: without either, a local cluster of this many single-threaded worker
            processes is started and closed again (the default: one per core here).
        progress: a progress bar on stderr as the jobs finish.
    """
    from dask.distributed import Client, LocalCluster, as_completed

    jobs = [j if isinstance(j, Job) else Job(name=str(j) if not isinstance(j, Mapping)
                                             else f"job {k}", config=j)
            for k, j in enumerate(jobs)]
    own = []
    if client is None:
        if address is not None:
            client = Client(address)
            own.append(client)
        else:
            cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                   dashboard_address=None)
            client = Client(cluster)
            own += [client, cluster]
    try:
        futures = client.map(run_job, jobs, pure=False)
        done = failed = 0
        for fut in as_completed(futures):
            done += 1
            failed += 0 if fut.result()["ok"] else 1
            if progress:
                _progress(done, len(futures), failed, sys.stderr)
        if progress:
            sys.stderr.write("\n")
        rows = client.gather(futures)
    finally:
        for o in own:
            o.close()
    return pd.DataFrame(rows)
