"""The World API: building, stepping, agents, groups, obstacles, gravity points and fields."""

import pathlib
import sys

import numpy as np
import pytest

import throng
from throng import World

REPO = pathlib.Path(__file__).resolve().parents[2]

TINY = """
name = "tiny"
seed = 3
dt = 0.05
steps = 40
[world]
kind = "torus"
size = [30, 30]
[[groups]]
name = "walkers"
count = 50
initial_speed = 1
max_speed = 2
steering = { behaviours = [{ kind = "wander" }] }
"""


def test_step_returns_the_frame_line_keys():
    w = World.from_scenario("flock", agents=300)
    stats = w.step(n=3)
    assert list(stats) == [
        "frame", "step", "index", "steer", "integrate", "bounds", "fields", "formations",
        "measure", "agents", "mean_neighbours",
    ]
    assert stats["frame"] == 3 and stats["agents"] == 300 and stats["step"] > 0
    assert w.frame == 3 and w.time == pytest.approx(3 * w.dt)


def test_many_calls_equal_one_call_on_any_thread_count():
    one = World.from_scenario("wander", agents=500, seed=2)
    many = World.from_scenario("wander", agents=500, seed=2, threads=1)
    one.step(n=30)
    for _ in range(30):
        many.step()
    assert many.threads == 1
    np.testing.assert_array_equal(one.positions().view(np.uint32), many.positions().view(np.uint32))


def test_from_toml_takes_text_paths_and_path_objects(tmp_path):
    path = tmp_path / "tiny.toml"
    path.write_text(TINY)
    worlds = [World.from_toml(TINY), World.from_toml(str(path)), World.from_toml(path)]
    for w in worlds:
        assert (w.name, len(w), w.seed, w.steps, w.dt) in [
            ("tiny", 50, 3, 40, 0.05), ("<string>", 50, 3, 40, 0.05),
        ] or (w.name, len(w)) == ("tiny", 50)
        w.step(n=5)
    np.testing.assert_array_equal(worlds[0].positions(), worlds[2].positions())
    w = World.from_toml(REPO / "scenarios" / "flock.toml", agents=200, seed=4)
    ref = World.from_scenario("flock", agents=200, seed=4)
    np.testing.assert_array_equal(w.positions(), ref.positions())


def test_overrides_change_the_scenario():
    w = World.from_scenario(
        "flock", agents=200, dt=0.05, steps=12, index="kdtree", reorder_every=0,
        **{"groups.boids.max_speed": 2.5, "groups.*.steering.behaviours.alignment.weight": 3.0},
    )
    assert (w.dt, w.steps, w.index, w.reorder_every) == (0.05, 12, "kdtree", 0)
    p = w.group_params(0)
    assert p["max_speed"] == 2.5
    assert [b["weight"] for b in p["steering"]["behaviours"]] == [1.5, 3.0, 0.8]
    w = World.from_scenario("flock", agents=200, groups__boids__max_speed=1.5)
    assert w.group_params(0)["max_speed"] == 1.5


def test_seed_and_agents():
    a = World.from_scenario("flock", agents=300, seed=1)
    b = World.from_scenario("flock", agents=300, seed=2)
    assert len(a) == 300 and a.seed == 1 and b.seed == 2
    assert not np.array_equal(a.positions(), b.positions())


def test_add_and_remove_agents():
    w = World.from_toml(TINY)
    ids = w.add_agents(
        [[1.0, 1.0], [2.0, 2.0], [3.0, 3.0]],
        velocities=np.array([[0.5, 0.0], [0.0, 0.5], [0.0, 0.0]]),
        orientations=[0.0, 1.0, 2.0],
        max_speed=3.0,
    )
    assert ids.dtype == np.uint32 and list(ids) == [50, 51, 52] and len(w) == 53
    rows = w.positions(order="id")[50:]
    np.testing.assert_array_equal(rows, [[1, 1], [2, 2], [3, 3]])
    np.testing.assert_array_equal(w.velocities(order="id")[50:], [[0.5, 0], [0, 0.5], [0, 0]])
    np.testing.assert_allclose(w.orientations(order="id")[50:], [0, 1, 2])
    w.remove_agents(np.array([0, 51]))
    assert len(w) == 51 and 0 not in w.ids() and 51 not in w.ids() and 52 in w.ids()
    w.remove_agents(52)
    assert len(w) == 50
    w.step(n=3)
    assert list(w.add_agents([5.0, 5.0])) == [53]  # ids are never reused


def test_set_positions_velocities_targets_and_speeds():
    w = World.from_toml(TINY)
    w.set_positions([3, 4], [[10.0, 11.0], [12.0, 13.0]])
    np.testing.assert_array_equal(w.positions(order="id")[3:5], [[10, 11], [12, 13]])
    w.set_velocities([3], [[100.0, 0.0]])
    assert w.velocities(order="id")[3, 0] == 2.0  # clamped to the maximum speed
    w.set_max_speeds([3, 4], 5.0)
    w.set_velocities([3], [[100.0, 0.0]])
    assert w.velocities(order="id")[3, 0] == 5.0
    w.set_targets([3, 4], [[1.0, 1.0], [2.0, 2.0]])


def test_seek_own_targets():
    w = World.from_toml(TINY.replace('{ kind = "wander" }', '{ kind = "arrive", target = "own" }'))
    w.set_targets(w.ids(), np.tile([15.0, 15.0], (50, 1)))
    w.step(n=600)
    d = np.hypot(*(w.positions() - 15.0).T)
    assert d.max() < 1.0


def test_group_params_round_trip_and_new_groups():
    w = World.from_toml(TINY)
    p = w.group_params(0)
    assert p["name"] == "walkers" and p["max_speed"] == 2.0
    p["max_speed"] = 4.0
    w.set_group_params(0, p)
    assert w.group_params(0)["max_speed"] == 4.0
    g = w.add_group({"name": "seekers", "model": "kinematic", "max_speed": 1.0,
                     "steering": {"behaviours": [{"kind": "seek", "target": {"point": [5, 5]}}]}})
    assert g == 1 and w.group_names == ["walkers", "seekers"]
    w.add_agents([[20.0, 20.0]], group=1)
    assert list(np.bincount(w.groups())) == [50, 1]
    w.step(n=10)


def test_obstacles_and_gravity_points():
    w = World.from_toml(TINY)
    w.add_wall((0.0, 0.0), (0.0, 5.0))
    w.add_polygon([[20, 20], [22, 20], [22, 22]])
    k = w.add_gravity_point((15.0, 15.0), 10.0, 8.0)
    j = w.add_gravity_point((5.0, 5.0), -4.0, 5.0, exponent=1.0,
                            motion={"kind": "linear", "velocity": [1.0, 0.0]})
    assert (k, j) == (0, 1)
    w.step(n=20)
    g = w.gravity_positions()
    assert g.shape == (2, 2) and g[0].tolist() == [15.0, 15.0] and g[1, 0] == pytest.approx(6.0)
    w.set_gravity_position(0, (1.0, 2.0))
    assert w.gravity_positions()[0].tolist() == [1.0, 2.0]
    far = World.from_toml(TINY)
    far.set_positions(far.ids(), np.tile([1.0, 1.0], (50, 1)))
    far.add_circle((20.0, 20.0), 2.0)
    with pytest.raises(throng.ThrongError, match="circle"):
        w.add_circle(w.positions()[0], 1.0)


ROOM = r"""
name = "room"
steps = 300
[world]
kind = "bounded"
size = [20, 10]
[field]
map = { ascii = "####################\n#.......#..........#\n#.......#..........#\n#.......#..........#\n#.......#..........#\n#.......#..........#\n#.......#..........#\n#................G.#\n#..................#\n####################\n" }
[[groups]]
count = 40
spawn = { kind = "rect", min = [1.5, 1.5], max = [6.5, 8.5] }
model = "kinematic"
max_speed = 4
steering = { behaviours = [{ kind = "follow_field" }, { kind = "separation", radius = 0.5, weight = 0.2 }] }
"""


def test_field_goals_and_arrivals():
    w = World.from_toml(ROOM)
    assert w.field_count == 1 and w.arrived_count() == 0
    w.step(n=250)
    assert w.arrived_count() == w.arrived().sum() == 40
    w.set_field_goals(0, 0, [[1, y] for y in range(1, 9)])
    w.step()
    assert w.arrived_count() < 40  # the flags reset when the channel is rebuilt
    w.step(n=300)
    assert w.arrived_count() == 40
    assert (w.positions()[:, 0] < 4).all()
    w.randomize_field_goals(0, 0, 3, 7)
    w.shuffle_field_goals_every(0, 50, 2)
    w.set_field_blocked(0, 15, 5)
    w.step(n=2)
    with pytest.raises(throng.ThrongError, match="field"):
        w.set_field_goals(5, 0, [[1, 1]])
    with pytest.raises(throng.ThrongError, match="wall"):
        w.set_field_goals(0, 0, [[8, 3]])  # a wall cell
    with pytest.raises(throng.ThrongError, match="goals"):
        w.set_field_goals(0, 0, [[1, 1, 1]])


def test_a_sweep_of_a_field_world_reports_the_evacuation_time():
    df = throng.sweep([{"toml": ROOM, "seed": s} for s in (1, 2)])
    assert (df["arrived"] == 40).all() and (df["arrived_fraction"] == 1.0).all()
    assert ((df["evacuated_at"] > 1.0) & (df["evacuated_at"] < 10.0)).all()


def test_trajectories_from_a_stepped_world_count_from_its_frame():
    w = World.from_scenario("wander", agents=100, seed=1)
    w.step(n=5)
    df = w.trajectories(6, every=3)
    assert sorted(df["frame"].unique()) == [5, 8, 11]
    assert len(df) == 300 and w.frame == 11


def test_help_and_repr_are_useful():
    doc = World.__doc__
    assert "from_scenario" in doc and "order" in doc
    assert "GIL" in World.step.__doc__
    assert "flock" in repr(World.from_scenario("flock", agents=100))
    assert "wander" in throng.scenarios()
    assert throng.__version__


def test_bounds_and_properties():
    w = World.from_toml(TINY)
    assert w.bounds == {"kind": "torus", "size": (30.0, 30.0)}
    w.dt = 0.1
    assert w.dt == pytest.approx(0.1)
    w.step()
    assert w.time == pytest.approx(0.1)
    with pytest.raises(throng.ThrongError, match="dt"):
        w.dt = 0.0


@pytest.mark.skipif(sys.version_info < (3, 11), reason="tomllib")
def test_the_bindings_lock_the_same_versions_as_the_cli():
    """Bit-for-bit parity with the CLI needs the same versions of the shared crates."""
    import tomllib

    def versions(lock):
        with open(lock, "rb") as f:
            return {(p["name"], p.get("source")): p["version"] for p in tomllib.load(f)["package"]}

    root, ours = versions(REPO / "Cargo.lock"), versions(REPO / "python" / "Cargo.lock")
    shared = root.keys() & ours.keys()
    assert ("glam", "registry+https://github.com/rust-lang/crates.io-index") in shared
    assert {k: ours[k] for k in shared} == {k: root[k] for k in shared}


def test_the_type_stubs_match_the_module(tmp_path):
    """`mypy.stubtest` checks every name and signature of `_throng.pyi` against the module."""
    pytest.importorskip("mypy")
    import subprocess

    done = subprocess.run(
        [sys.executable, "-m", "mypy.stubtest", "throng", "--ignore-disjoint-bases"],
        capture_output=True, text=True, cwd=tmp_path,
    )
    assert done.returncode == 0, done.stdout + done.stderr
