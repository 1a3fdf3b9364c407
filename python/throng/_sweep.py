"""Parameter sweeps: many worlds, one row of summary metrics each, locally or on Dask.

A run is a dict naming a built-in scenario (``"scenario"``) or a scenario file or TOML text
(``"toml"``), and optionally ``"agents"``, ``"seed"`` and ``"steps"`` (default: the scenario's
own); every other key is an override, as the keywords of ``World.from_scenario`` (dotted paths
into the scenario's TOML: ``"groups.boids.steering.behaviours.alignment.weight"``).

Each row holds the run's own keys, then the metrics of the final state (``METRICS``), then
what an evacuation study measures (``STUDY_METRICS``): the time at which the last agent left
through an exit or an exit stage (``evacuation_time``, NaN while agents remain or when nobody
left), the agents still in the world (``remaining``) and those that left through an exit
(``exited``); then, per counting line of the scenario's ``[measurements]``, its net crossings
(``net_<line>``, positive minus negative) and its flow J in 1/s (``flow_<line>``, NaN with
fewer than two crossings), as ``throng run`` reports them; then, for worlds with grid fields,
the arrivals.

A run with ``"validate"`` (a case of ``throng validate``) instead runs that case, with
``"quick"``, ``"model"`` and ``"seed_offset"`` as ``throng.validate`` takes them and every key
that starts with ``"pedestrian."`` set in every pedestrian group (``"pedestrian.cfsm.time_gap"``);
its row holds ``VALIDATE_METRICS``: whether the case passed, its checks passed of all, and
over the bins compared with an experiment the count, the mean and the largest absolute relative
error. A calibration is a sweep of such runs over parameter values. Metrics come from Rust in float64 over the agents
in storage order and the simulation is bit-identical on any number of threads, so a sweep
gives the same DataFrame wherever it runs; only the ``time_`` columns (``timings=True``)
differ.
"""

from __future__ import annotations

import math
import os
import time
from collections.abc import Iterable, Mapping
from typing import Any, Optional
from urllib.parse import urlparse

from ._throng import ThrongError, World

#: The metric columns of every row.
METRICS = ("n_agents", "frame", "t", "mean_speed", "polarisation", "mean_neighbours")
#: The columns of what an evacuation study measures, in every row.
STUDY_METRICS = ("evacuation_time", "remaining", "exited")
#: The prefixes of the columns of each counting line: net crossings and flow J (1/s).
LINE_PREFIXES = ("net_", "flow_")
#: The extra columns of a world with grid fields.
FIELD_METRICS = ("arrived", "arrived_fraction", "evacuated_at")
#: The columns of ``timings=True`` (wall-clock, so they differ between runs).
TIME_METRICS = ("time_build_s", "time_run_s", "time_ms_per_step", "time_threads")

#: The columns of a ``"validate"`` run.
VALIDATE_METRICS = (
    "pass",
    "checks_passed",
    "checks",
    "bins_judged",
    "mean_abs_error",
    "max_abs_error",
)

_RESERVED = frozenset(METRICS + STUDY_METRICS + FIELD_METRICS + VALIDATE_METRICS)


def _bad_run(where: str, reason: str) -> ThrongError:
    err = ThrongError(f"invalid {where}: {reason}")
    err.parameter = where
    return err


def _check_spec(where: str, spec: Any) -> None:
    """A run is a dict whose keys are names (they become the row's columns)."""
    if not isinstance(spec, Mapping):
        raise _bad_run(where, f"expected a dict, got {type(spec).__name__}")
    for key in spec:
        if not isinstance(key, str):
            raise _bad_run(f"{where} key {key!r}", f"expected a name (str), got {type(key).__name__}")


def run(spec: Mapping[str, Any], *, timings: bool = False, threads: Optional[int] = None) -> dict:
    """Runs one sweep entry and returns its row (a dict): the entry's keys, then the metrics.

    ``threads`` limits this run's rayon workers (default: all cores). Worlds with grid fields
    are stepped one step at a time so that ``evacuated_at`` (the simulated time at which every
    agent had arrived or left through an exit, NaN if that never happened) is exact.
    """
    _check_spec("run", spec)
    if "validate" in spec:
        return _validate_run(spec, timings=timings, threads=threads)
    params = dict(spec)
    scenario = params.pop("scenario", None)
    toml = params.pop("toml", None)
    if (scenario is None) == (toml is None):
        raise _bad_run("run", 'name exactly one of "scenario" (a built-in) or "toml" (a file or text)')
    agents = params.pop("agents", None)
    seed = params.pop("seed", None)
    steps = params.pop("steps", None)
    for key in params:
        if key in _RESERVED or key.startswith(("time_",) + LINE_PREFIXES):
            raise _bad_run(key, "the name of a result column cannot be an override")

    start = time.perf_counter()
    if scenario is not None:
        world = World.from_scenario(scenario, agents=agents, seed=seed, threads=threads, **params)
    else:
        world = World.from_toml(toml, agents=agents, seed=seed, threads=threads, **params)
    steps = world.steps if steps is None else steps
    if not isinstance(steps, int) or isinstance(steps, bool) or steps < 0:
        raise _bad_run("steps", f"expected a whole number >= 0, got {steps!r}")
    built = time.perf_counter()

    stats = None
    fields = world.field_count > 0
    evacuated = math.nan
    if fields:
        if len(world) and world.arrived_count() == len(world):
            evacuated = world.time
        for _ in range(steps):
            stats = world.step()
            if math.isnan(evacuated) and world.arrived_count() == len(world):
                evacuated = world.time
        if math.isnan(evacuated) and world.evacuation_time is not None:
            evacuated = world.evacuation_time
    elif steps > 0:
        stats = world.step(n=steps)
    end = time.perf_counter()

    row = dict(spec)
    row.update(
        n_agents=len(world),
        frame=world.frame,
        t=world.time,
        mean_speed=world.mean_speed(),
        polarisation=world.polarisation(),
        mean_neighbours=stats["mean_neighbours"] if stats else math.nan,
    )
    measured = world.measurements()
    evacuation = world.evacuation_time
    row.update(
        evacuation_time=math.nan if evacuation is None else evacuation,
        remaining=len(world),
        exited=measured["left"],
    )
    for line in measured["lines"]:
        flow = line["flow"]
        row[f"net_{line['name']}"] = line["net"]
        row[f"flow_{line['name']}"] = math.nan if flow is None else flow
    if fields:
        arrived = world.arrived_count()
        row.update(
            arrived=arrived,
            arrived_fraction=arrived / len(world) if len(world) else math.nan,
            evacuated_at=evacuated,
        )
    if timings:
        row.update(
            time_build_s=built - start,
            time_run_s=end - built,
            time_ms_per_step=(end - built) * 1e3 / steps if steps else math.nan,
            time_threads=world.threads,
        )
    return row


def _validate_run(spec: Mapping[str, Any], *, timings: bool, threads: Optional[int]) -> dict:
    """The row of a ``"validate"`` run (see the module docs)."""
    from ._throng import validate

    rest = dict(spec)
    case = rest.pop("validate")
    options = {k: rest.pop(k) for k in ("quick", "model", "seed_offset") if k in rest}
    params = {}
    for key in list(rest):
        if key.startswith("pedestrian."):
            params[key[len("pedestrian."):]] = rest.pop(key)
    if rest:
        raise _bad_run(next(iter(rest)), 'a "validate" run takes quick, model, seed_offset and pedestrian.* keys')
    start = time.perf_counter()
    report = validate(case, threads=threads, params=params, **options)
    end = time.perf_counter()
    errors = [abs(e["relative_error"]) for e in report.get("errors", []) if "relative_error" in e]
    row = dict(spec)
    row.update(
        {
            "pass": report["pass"],
            "checks_passed": sum(1 for c in report["checks"] if c["pass"]),
            "checks": len(report["checks"]),
            "bins_judged": len(errors),
            "mean_abs_error": sum(errors) / len(errors) if errors else math.nan,
            "max_abs_error": max(errors) if errors else math.nan,
        }
    )
    if timings:
        row.update(time_build_s=0.0, time_run_s=end - start, time_ms_per_step=math.nan, time_threads=threads)
    return row


def threads_per_task(cores: int, task_slots: int) -> int:
    """rayon workers for one task: the host's cores shared among the tasks that can run on it
    at once (at least one)."""
    return max(1, cores // max(1, task_slots))


def _cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def _run_on_worker(spec, timings, threads, host_slots):
    """A sweep entry on a Dask worker, with rayon limited to the task's share of the host."""
    if threads is None:
        from distributed import get_worker

        worker = get_worker()
        host = urlparse(worker.address).hostname
        slots = host_slots.get(host) or worker.nthreads
        threads = threads_per_task(_cores(), slots)
    return run(spec, timings=timings, threads=threads)


def _host_slots(client) -> dict:
    """Task threads per host over the cluster's workers."""
    slots: dict = {}
    for address, n in client.nthreads().items():
        host = urlparse(address).hostname
        slots[host] = slots.get(host, 0) + n
    return slots


def sweep(
    runs: Iterable[Mapping[str, Any]],
    *,
    client=None,
    timings: bool = False,
    threads: Optional[int] = None,
):
    """Runs every entry of ``runs`` and returns a pandas DataFrame, one row per run in order.

    Without ``client`` the runs go one after another in this process, each on all cores (or
    ``threads``). With a ``dask.distributed.Client`` they are mapped over the cluster's
    workers; each run limits rayon to its share of its host's cores (the host's cores divided
    by the task threads of the workers on it) unless ``threads`` is given. The result is the
    same DataFrame either way, apart from the ``time_`` columns that ``timings=True`` adds.
    The workers need ``throng`` installed.

    >>> import throng
    >>> df = throng.sweep([{"scenario": "flock", "agents": 200, "seed": s, "steps": 5} for s in (1, 2)])
    >>> list(df["seed"])
    [1, 2]
    """
    import pandas as pd

    runs = list(runs)
    for k, spec in enumerate(runs):
        _check_spec(f"runs[{k}]", spec)
    if client is None:
        rows = [run(spec, timings=timings, threads=threads) for spec in runs]
    else:
        slots = _host_slots(client)
        futures = client.map(
            _run_on_worker,
            runs,
            timings=timings,
            threads=threads,
            host_slots=slots,
            pure=False,
        )
        rows = client.gather(futures)
    return pd.DataFrame(rows)
