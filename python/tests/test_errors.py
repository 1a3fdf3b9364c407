"""Bad arguments raise ThrongError (a ValueError) whose message, from the Rust library, names
the parameter; nothing panics and a failed call changes nothing."""

import numpy as np
import pytest

import throng
from throng import ThrongError, World


@pytest.fixture
def world():
    return World.from_scenario("flock", agents=100, seed=1)


def test_throng_error_is_a_value_error():
    assert issubclass(ThrongError, ValueError)
    assert ThrongError("made in Python").parameter is None
    assert ThrongError.__module__ == "throng"


CASES = {
    "dt": lambda w: w.step(dt=-1.0),
    "dt ": lambda w: w.step(dt=float("nan")),
    "n": lambda w: w.step(n=0),
    "n ": lambda w: w.step(n=-4),
    "agents": lambda w: World.from_scenario("flock", agents=0),
    "agents ": lambda w: World.from_scenario("flock", agents=-1),
    "seed": lambda w: World.from_scenario("flock", seed=-1),
    "threads": lambda w: World.from_scenario("flock", threads=0),
    "position": lambda w: w.add_agents([[np.nan, 1.0]]),
    "velocity": lambda w: w.add_agents([[1.0, 1.0]], velocities=[[np.inf, 0.0]]),
    "positions": lambda w: w.add_agents([[1.0, 2.0, 3.0]]),
    "velocities": lambda w: w.add_agents([[1.0, 1.0], [2.0, 2.0]], velocities=[[0.0, 0.0]]),
    "group": lambda w: w.add_agents([[1.0, 1.0]], group=3),
    "max_speed": lambda w: w.add_agents([[1.0, 1.0]], max_speed=-2.0),
    "radius": lambda w: w.add_agents([[1.0, 1.0]], radius=[1.0, 2.0]),
    "ids": lambda w: w.remove_agents([100000]),
    "ids ": lambda w: w.remove_agents([1, 1]),
    "ids  ": lambda w: w.remove_agents([-1]),
    "ids   ": lambda w: w.remove_agents(["a"]),
    "targets[0]": lambda w: w.set_targets([0], [[np.nan, 0.0]]),
    "positions[1]": lambda w: w.set_positions([0, 1], [[1.0, 1.0], [np.nan, 0.0]]),
    "index": lambda w: setattr(w, "index", "octree"),
    "every": lambda w: w.trajectories(10, every=0),
    "steps": lambda w: throng.bench("flock", agents=100, steps=0),
    "groups.boids.max_sped": lambda w: World.from_scenario("flock", **{"groups.boids.max_sped": 1}),
    "groups.nobody.max_speed": lambda w: World.from_scenario("flock", **{"groups.nobody.max_speed": 1}),
    "max_speed  ": lambda w: World.from_scenario("flock", groups__boids__max_speed=-5),
    "gravity.radius": lambda w: w.add_gravity_point((1.0, 1.0), 5.0, -1.0),
    "motion": lambda w: w.add_gravity_point((1.0, 1.0), 5.0, 2.0, motion={"kind": "spin"}),
    "params": lambda w: w.set_group_params(0, {"max_speeed": 2}),
    "group  ": lambda w: w.group_params(7),
    "center": lambda w: w.add_circle((1.0,), 2.0),
    "flock": lambda w: World.from_scenario("flock", agents=100, **{"groups.boids.spawn": {"kind": "rect", "min": [0, 0], "max": [-1, -1]}}),
    "nope": lambda w: World.from_scenario("nope"),
    "<string>": lambda w: World.from_toml("this is = not toml ["),
    "missing.toml": lambda w: World.from_toml("missing.toml"),
}


@pytest.mark.parametrize("name", list(CASES))
def test_bad_arguments_raise_throng_error_naming_the_parameter(world, name):
    with pytest.raises(ThrongError) as e:
        CASES[name](world)
    assert name.strip() in str(e.value)


@pytest.mark.parametrize("call,parameter", [
    (lambda w: w.step(dt=0.0), "dt"),
    (lambda w: w.add_agents([[np.nan, 0.0]]), "position"),
    (lambda w: w.positions(out=np.zeros(3)), "out"),
    (lambda w: World.from_scenario("flock", agents=0), "agents"),
    (lambda w: World.from_scenario("nope"), None),
])
def test_the_parameter_attribute(world, call, parameter):
    with pytest.raises(ThrongError) as e:
        call(world)
    assert e.value.parameter == parameter


def test_a_failed_add_or_move_changes_nothing(world):
    before = (world.ids().copy(), world.positions().copy())
    with pytest.raises(ThrongError, match="row 2"):
        world.add_agents([[1.0, 1.0], [2.0, 2.0], [np.nan, 3.0]])
    with pytest.raises(ThrongError, match=r"positions\[1\]"):
        world.set_positions([0, 1], [[1.0, 1.0], [np.nan, 0.0]])
    with pytest.raises(ThrongError):
        world.set_velocities([0, 99999], [[1.0, 1.0], [1.0, 0.0]])
    np.testing.assert_array_equal(world.ids(), before[0])
    np.testing.assert_array_equal(world.positions(), before[1])
    with pytest.raises(ThrongError):
        world.step(dt=-1.0)
    assert world.frame == 0


def test_wrong_types_are_type_errors_that_name_the_argument(world):
    with pytest.raises(TypeError, match="dt"):
        world.step(dt="fast")


def test_a_scenario_file_beyond_the_ceiling_is_refused_unread(tmp_path):
    # A sparse 17 MiB file: refused by its size, before it is read.
    path = tmp_path / "huge.toml"
    with open(path, "wb") as f:
        f.truncate(17 << 20)
    with pytest.raises(ThrongError, match="scenario files"):
        World.from_toml(path)
