"""The bindings step worlds exactly as the CLI does: trajectories, positions and the bench
object agree with the `throng` binary for the same scenario and seed, bit for bit."""

import json
import subprocess

import numpy as np
import pandas as pd
import pytest

import throng

FLOAT_COLUMNS = ["x", "y", "vx", "vy", "heading"]


def cli(throng_bin, *args):
    done = subprocess.run([str(throng_bin), *map(str, args)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    return done.stdout


def cli_trajectories(throng_bin, tmp_path, scenario, agents, steps, every, seed):
    csv = tmp_path / f"{scenario}.csv"
    cli(
        throng_bin, "demo", scenario, "--agents", agents, "--steps", steps, "--every", every,
        "--seed", seed, "--threads", 2, "--trajectories", csv, "--quiet",
    )
    # The CSV holds each float32 in its shortest decimal form: float64 parsing, then the
    # conversion to float32, recovers the exact bits.
    return pd.read_csv(csv, dtype={c: np.float64 for c in ["t"] + FLOAT_COLUMNS})


def bits(column):
    return np.asarray(column, dtype=np.float32).view(np.uint32)


def assert_same_trajectories(ours, theirs):
    assert list(ours.columns) == list(theirs.columns) == [
        "frame", "t", "id", "x", "y", "vx", "vy", "heading", "group",
    ]
    assert len(ours) == len(theirs)
    np.testing.assert_array_equal(ours["frame"].to_numpy(), theirs["frame"].to_numpy())
    np.testing.assert_array_equal(ours["id"].to_numpy(), theirs["id"].to_numpy())
    np.testing.assert_array_equal(ours["group"].to_numpy(), theirs["group"].to_numpy())
    # The CSV rounds t to 6 decimals.
    np.testing.assert_allclose(ours["t"].to_numpy(), theirs["t"].to_numpy(), atol=5e-7, rtol=0)
    for c in FLOAT_COLUMNS:
        assert ours[c].dtype == np.float32
        np.testing.assert_array_equal(bits(ours[c]), bits(theirs[c]), err_msg=c)


@pytest.mark.parametrize("scenario", list(throng.scenarios()))
def test_trajectories_match_the_cli_csv_bit_for_bit(throng_bin, tmp_path, scenario):
    theirs = cli_trajectories(throng_bin, tmp_path, scenario, 300, 24, 8, 5)
    world = throng.World.from_scenario(scenario, agents=300, seed=5)
    ours = world.trajectories(24, every=8)
    assert_same_trajectories(ours, theirs)
    assert world.frame == 24


def test_positions_after_n_steps_equal_the_cli_last_frame(throng_bin, tmp_path):
    theirs = cli_trajectories(throng_bin, tmp_path, "flock", 2000, 60, 60, 11)
    last = theirs[theirs["frame"] == 60]
    world = throng.World.from_scenario("flock", agents=2000, seed=11, threads=1)
    stats = world.step(n=60)
    assert stats["frame"] == 60 and stats["agents"] == 2000
    np.testing.assert_array_equal(world.ids(), last["id"].to_numpy())
    np.testing.assert_array_equal(
        world.positions().view(np.uint32), bits(last[["x", "y"]].to_numpy())
    )
    np.testing.assert_array_equal(
        world.velocities().view(np.uint32), bits(last[["vx", "vy"]].to_numpy())
    )
    np.testing.assert_array_equal(world.orientations().view(np.uint32), bits(last["heading"]))


def keys(d):
    return {k: keys(v) if isinstance(v, dict) else None for k, v in d.items()}


def test_bench_returns_the_cli_bench_json_keys_and_values(throng_bin):
    args = dict(agents=1500, steps=4, warmup=2, threads=1, seed=3)
    flags = [str(x) for k, v in args.items() for x in ("--" + k, v)]
    theirs = json.loads(cli(throng_bin, "bench", "flock", *flags, "--json"))
    ours = throng.bench("flock", **args)
    assert keys(ours) == keys(theirs)
    # No goals in a flock: nobody arrives, and the step at which all did is null in both.
    assert ours["arrived"] == theirs["arrived"] == 0
    assert ours["all_arrived_step"] is None and theirs["all_arrived_step"] is None
    # No exits and no measurements: a null evacuation time and empty lists in both.
    assert ours["evacuation_time"] is None and theirs["evacuation_time"] is None
    assert ours["measurements"] == theirs["measurements"] == {"lines": [], "areas": [], "left": 0}
    for k in ("scenario", "agents", "threads", "index", "steps", "mean_neighbours"):
        assert ours[k] == theirs[k], k
    assert set(ours["phases_ms"]) == {
        "index", "steer", "integrate", "bounds", "fields", "formations", "measure",
    }
    assert 0.0 <= ours["polarisation"] <= 1.0
    ms = ours["ms_per_step"]
    assert 0 < ms["min"] <= ms["median"] <= ms["max"]
    assert ours["agent_steps_per_sec"] > 0 and ours["peak_rss_mb"] > 0


@pytest.mark.parametrize("steps, every, frames", [
    (7, 3, [0, 3, 6, 7]), (6, 3, [0, 3, 6]), (1, 5, [0, 1]), (0, 4, [0]),
])
def test_trajectories_end_with_the_last_frame(steps, every, frames):
    world = throng.World.from_scenario("flock", agents=20, seed=3)
    df = world.trajectories(steps, every=every)
    assert sorted(set(df["frame"])) == frames
    assert world.frame == steps


def test_trajectories_with_a_step_count_not_a_multiple_of_every_match_the_cli(
    throng_bin, tmp_path
):
    theirs = cli_trajectories(throng_bin, tmp_path, "flock", 200, 7, 3, 5)
    ours = throng.World.from_scenario("flock", agents=200, seed=5).trajectories(7, every=3)
    assert_same_trajectories(ours, theirs)
