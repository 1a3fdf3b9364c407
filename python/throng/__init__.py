"""throng: data-parallel crowd and flock simulation, from Python.

A Rust simulator (Reynolds steering, flocking, potential and flow fields, group movement)
behind a numpy-native interface:

- ``Simulation(geometry=WKT, model="cfsm", dt=0.01)`` builds a pedestrian study without
  scenario files: stages (waypoints, exits, queues, waiting sets, direct steering), journeys
  with transitions, agents with their own parameters, ``iterate()``;
- ``World.from_scenario(name, ...)`` / ``World.from_toml(path_or_text, ...)`` build a world;
- ``world.step(n=...)`` runs steps with the GIL released (rayon threads inside);
- ``positions()``, ``velocities()``, ``orientations()``, ``ids()``, ``groups()`` return fresh
  numpy arrays or fill ``out=``;
- ``world.trajectories(steps, every=K)`` returns a pandas DataFrame like the CLI's CSV;
- ``bench(...)`` times a scenario as ``throng bench --json`` does;
- ``sweep(runs, client=None)`` runs many worlds, locally or on a Dask cluster, one row of
  summary metrics each.

Every bad argument raises ``ThrongError`` (a ``ValueError``) with the Rust library's message.

>>> import throng
>>> world = throng.World.from_scenario("flock", agents=500, seed=1)
>>> stats = world.step(n=10)
>>> world.positions().shape
(500, 2)
"""

from ._throng import (
    Journey,
    QueueStage,
    Simulation,
    ThrongError,
    Transition,
    WaitingSetStage,
    World,
    __version__,
    bench,
    scenarios,
    validate,
)
from ._sweep import METRICS, STUDY_METRICS, VALIDATE_METRICS, run, sweep, threads_per_task

__all__ = [
    "Journey",
    "METRICS",
    "QueueStage",
    "STUDY_METRICS",
    "Simulation",
    "ThrongError",
    "Transition",
    "WaitingSetStage",
    "World",
    "__version__",
    "bench",
    "run",
    "scenarios",
    "sweep",
    "threads_per_task",
    "VALIDATE_METRICS",
    "validate",
]
