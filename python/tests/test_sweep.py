"""Sweeps: one row per run with the run's keys and its metrics; the same DataFrame locally and
on a 2-worker Dask LocalCluster."""

import math
import os

import numpy as np
import pandas as pd
import pytest

import throng
from throng._sweep import TIME_METRICS

WEIGHT = "groups.boids.steering.behaviours.alignment.weight"
RUNS = [
    {"scenario": "flock", "agents": 400, "seed": seed, "steps": 25, WEIGHT: w}
    for seed in (1, 2)
    for w in (0.25, 1.0, 2.0, 4.0)
]


def without_times(df):
    return df[[c for c in df.columns if not c.startswith("time_")]]


@pytest.fixture(scope="module")
def local():
    return throng.sweep(RUNS)


def test_one_row_per_run_with_inputs_then_metrics(local):
    assert len(local) == 8
    assert list(local.columns) == [
        "scenario", "agents", "seed", "steps", WEIGHT, *throng.METRICS, *throng.STUDY_METRICS
    ]
    # A flock has no exits: nobody leaves, and there is no evacuation time.
    assert (local["remaining"] == 400).all() and (local["exited"] == 0).all()
    assert local["evacuation_time"].isna().all()
    assert list(local["seed"]) == [1, 1, 1, 1, 2, 2, 2, 2]
    assert (local["n_agents"] == 400).all() and (local["frame"] == 25).all()
    assert local["polarisation"].between(0, 1).all()
    # Stronger alignment orders the flock more.
    for _, g in local.groupby("seed"):
        assert g.sort_values(WEIGHT)["polarisation"].is_monotonic_increasing


def test_metrics_are_those_of_the_world(local):
    w = throng.World.from_scenario("flock", agents=400, seed=2, **{WEIGHT: 2.0})
    w.step(n=25)
    v = w.velocities().astype(np.float64)
    speed = np.hypot(v[:, 0], v[:, 1])
    row = local.iloc[6]
    assert row["mean_speed"] == pytest.approx(speed.mean(), rel=1e-12)
    unit = v[speed > 0] / speed[speed > 0, None]
    assert row["polarisation"] == pytest.approx(np.hypot(*unit.sum(axis=0)) / len(v), rel=1e-12)
    assert row["mean_speed"] == w.mean_speed() and row["polarisation"] == w.polarisation()


def test_a_local_cluster_gives_exactly_the_local_frame(local):
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(
        n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None
    ) as cluster, distributed.Client(cluster) as client:
        remote = throng.sweep(RUNS, client=client, timings=True)
    pd.testing.assert_frame_equal(without_times(remote), local, check_exact=True)
    # Two one-thread workers on this host share its cores.
    share = throng.threads_per_task(len(os.sched_getaffinity(0)), 2)
    assert (remote["time_threads"] == share).all()
    assert (remote["time_run_s"] > 0).all()


def test_timings_only_on_request(local):
    timed = throng.sweep(RUNS[:2], timings=True, threads=1)
    assert [c for c in timed.columns if c.startswith("time_")] == list(TIME_METRICS)
    assert (timed["time_threads"] == 1).all()
    pd.testing.assert_frame_equal(without_times(timed), local.iloc[:2], check_exact=True)


def test_field_worlds_report_arrivals():
    df = throng.sweep([{"scenario": "fields", "agents": 200, "seed": 1, "steps": 60}])
    row = df.iloc[0]
    assert 0 <= row["arrived"] <= 200
    assert row["arrived_fraction"] == row["arrived"] / 200
    assert math.isnan(row["evacuated_at"]) or 0 <= row["evacuated_at"] <= row["t"]


def evacuation(scenario, steps, **keys):
    """The world of a sweep run stepped one step at a time: its count, the time of the last
    step in which somebody left, and the count of those who left."""
    w = throng.World.from_scenario(scenario, **keys)
    last, exited = math.nan, 0
    for _ in range(steps):
        before = len(w)
        w.step()
        if len(w) < before:
            last, exited = w.time, exited + before - len(w)
    return w, last, exited


def test_an_exit_stage_evacuation_reports_its_time_agents_and_flows():
    df = throng.sweep([
        {"scenario": "concourse", "steps": 4000},
        {"scenario": "concourse", "steps": 1000},
    ])
    done, partial = df.iloc[0], df.iloc[1]
    w, last, exited = evacuation("concourse", 4000)
    assert len(w) == 0 and done["remaining"] == 0 and done["exited"] == exited == 200
    # The time of the last removal, exactly.
    assert done["evacuation_time"] == last and done["t"] > last
    # Cut short, agents remain: no evacuation time, and the counts add up.
    w, _, exited = evacuation("concourse", 1000)
    assert partial["remaining"] == len(w) > 0 and partial["exited"] == exited
    assert partial["remaining"] + partial["exited"] == 200
    assert math.isnan(partial["evacuation_time"])
    # The lines' net crossings and flows, as the world's own measurements report them.
    lines = {l["name"]: l for l in throng.World.from_scenario("concourse").measurements()["lines"]}
    assert set(lines) == {"between_pillars", "north_exit", "south_exit"}
    w, _, _ = evacuation("concourse", 4000)
    for line in w.measurements()["lines"]:
        assert done[f"net_{line['name']}"] == line["net"]
        assert done[f"flow_{line['name']}"] == line["flow"]
    assert done["net_between_pillars"] == 200


def test_a_field_evacuation_reports_when_the_last_agent_left():
    df = throng.sweep([{"scenario": "evacuation", "agents": 200, "seed": 1, "steps": 3000}])
    row = df.iloc[0]
    w, last, exited = evacuation("evacuation", 3000, agents=200, seed=1)
    assert len(w) == 0 and row["remaining"] == 0 and row["exited"] == exited == 200
    assert row["evacuation_time"] == last
    assert row["evacuated_at"] == last


def test_toml_runs_and_defaults(tmp_path):
    path = tmp_path / "tiny.toml"
    path.write_text(TINY)
    df = throng.sweep([{"toml": str(path)}, {"toml": TINY, "steps": 3, "seed": 9}])
    assert list(df["frame"]) == [7, 3]


TINY = """
name = "tiny"
steps = 7
[world]
kind = "torus"
size = [20, 20]
[[groups]]
count = 30
max_speed = 2
steering = { behaviours = [{ kind = "wander" }] }
"""


@pytest.mark.parametrize("runs,match", [
    ([{"agents": 10}], "scenario"),
    ([{"scenario": "flock", "toml": TINY}], "scenario"),
    ([["flock"]], r"runs\[0\]"),
    ([{"scenario": "flock", "polarisation": 1}], "polarisation"),
    ([{"scenario": "concourse", "remaining": 1}], "remaining"),
    ([{"scenario": "concourse", "net_between_pillars": 1}], "net_between_pillars"),
    ([{"scenario": "flock", "steps": -1}], "steps"),
    # A key that is not a name raised AttributeError (int has no startswith).
    ([{"scenario": "flock", "steps": 1, 3: 4}], r"runs\[0\] key 3"),
    ([{"scenario": "flock", "steps": 1}, {"scenario": "flock", ("a",): 1}], r"runs\[1\] key \('a',\)"),
])
def test_bad_runs_raise(runs, match):
    with pytest.raises(throng.ThrongError, match=match):
        throng.sweep(runs)


def test_threads_per_task():
    assert throng.threads_per_task(2, 2) == 1
    assert throng.threads_per_task(16, 4) == 4
    assert throng.threads_per_task(2, 8) == 1
    assert throng.threads_per_task(8, 0) == 8


def test_validate_runs_report_the_case_and_its_errors_per_bin():
    # The bottleneck against the experiments per width, with and without the speed model's
    # pressure from behind: the rows say by how much each width misses.
    gap = {"cfsm.time_gap": 1.0, "cfsm.pressed_time_gap": 0.4}
    report = throng.validate("exp-bottleneck-width", quick=True, params=gap)
    assert report["id"] == "exp-bottleneck-width"
    errors = report["errors"]
    assert [e["lo"] for e in errors] == [1.0, 1.6]
    for e in errors:
        assert e["relative_error"] == pytest.approx((e["measured"] - e["reference"]) / e["reference"])
    df = throng.sweep(
        [
            {
                "validate": "exp-bottleneck-width",
                "quick": True,
                "pedestrian.cfsm.time_gap": 1.0,
                "pedestrian.cfsm.pressed_time_gap": g,
            }
            for g in (0.4, 1.0)
        ]
    )
    assert list(df.columns[-6:]) == list(throng.VALIDATE_METRICS)
    assert list(df["bins_judged"]) == [2, 2]
    assert df["mean_abs_error"].iloc[0] == pytest.approx(
        sum(abs(e["relative_error"]) for e in errors) / 2
    )
    # Without the pressure from behind the flow falls well below the experiments'.
    assert df["mean_abs_error"].iloc[1] > df["mean_abs_error"].iloc[0]


@pytest.mark.parametrize(
    "run, match",
    [
        ({"validate": "nope"}, "no case"),
        ({"validate": "exp-bottleneck-width", "quick": True, "pedestrian.cfsm.time_gap": -1}, "time_gap"),
        ({"validate": "exp-bottleneck-width", "agents": 3}, "agents"),
    ],
)
def test_bad_validate_runs_raise(run, match):
    with pytest.raises(throng.ThrongError, match=match):
        throng.run(run)


def test_a_run_key_that_is_not_a_name_raises():
    with pytest.raises(throng.ThrongError, match="run key 7"):
        throng.run({"validate": "exp-bottleneck-width", 7: 1})
