"""Hostile values that once killed the interpreter or slipped past the library's ceilings.

Each input that crashed runs in a child interpreter, so that a crash fails its test instead of
ending the pytest run: the child must exit 0 after catching a ThrongError naming the argument.
"""

import subprocess
import sys
import textwrap

import numpy as np
import pytest

import throng
from throng import ThrongError, World

#: Values nested deeper than the bindings accept, built in the child: a list that contains
#: itself, and lists and dicts nested 10,000 deep.
BUILD = """
import throng
loop = []
loop.append(loop)
deep = 0
for _ in range(10_000):
    deep = [deep]
deep_dict = 0
for _ in range(10_000):
    deep_dict = {"a": deep_dict}
"""

CALLS = {
    "override": ('throng.World.from_scenario("flock", agents=10, world__size=VALUE)', "world__size"),
    "from_toml": ('throng.World.from_toml("[[groups]]\\ncount = 1", x=VALUE)', "x"),
    "set_group_params": (
        'throng.World.from_scenario("flock", agents=10).set_group_params(0, {"steering": VALUE})',
        "params.steering",
    ),
    "add_gravity_point": (
        'throng.World.from_scenario("flock", agents=10).add_gravity_point((0, 0), 1.0, 5.0, motion={"kind": VALUE})',
        "motion.kind",
    ),
    "sweep run": ('throng.run({"scenario": "flock", "agents": 10, "steps": 1, "x": VALUE})', "x"),
}


@pytest.mark.parametrize("value", ["loop", "deep", "deep_dict"])
@pytest.mark.parametrize("call", sorted(CALLS))
def test_values_nested_too_deep_are_a_throng_error(call, value):
    expr, argument = CALLS[call]
    script = BUILD + textwrap.dedent(
        f"""
        try:
            {expr.replace("VALUE", value)}
        except throng.ThrongError as e:
            assert "nest more than 64 levels" in str(e), e
            assert str(e).startswith("invalid {argument}"), e
        else:
            raise SystemExit("accepted")
        """
    )
    r = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert r.returncode == 0, f"exit {r.returncode}: {r.stderr[-2000:]}"


def test_values_nested_as_deep_as_a_scenario_are_accepted():
    w = World.from_scenario("flock", agents=10)
    p = w.group_params(0)
    w.set_group_params(0, p)
    assert w.group_params(0) == p


def test_a_rust_panic_is_a_throng_error():
    with pytest.raises(ThrongError, match="internal error.*made to panic"):
        throng._throng._panic("made to panic")


@pytest.mark.parametrize(
    "call",
    [
        lambda w: w.set_targets([0], [[1e20, 0.0]]),
        lambda w: w.add_wall((0.0, 0.0), (1e20, 0.0)),
        lambda w: w.add_circle((1e20, 0.0), 1.0),
        lambda w: w.add_gravity_point((1e20, 0.0), 1.0, 5.0),
        lambda w: w.set_gravity_position(w.add_gravity_point((0.0, 0.0), 1.0, 5.0), (0.0, -1e20)),
        lambda w: w.set_group_params(
            0, {"steering": {"behaviours": [{"kind": "seek", "target": {"point": [1e20, 0]}}]}}
        ),
    ],
)
def test_coordinates_beyond_the_ceiling_are_refused(call):
    w = World.from_scenario("flock", agents=10)
    with pytest.raises(ThrongError, match="1e18"):
        call(w)
    w.step()
    assert np.isfinite(w.positions()).all()


def test_threads_beyond_the_clis_ceiling_are_refused():
    with pytest.raises(ThrongError, match="at most 1024") as e:
        World.from_scenario("flock", agents=10, threads=2000)
    assert e.value.parameter == "threads"


def test_set_group_params_refuses_a_field_the_world_does_not_have():
    w = World.from_scenario("flock", agents=10)
    follow = {"steering": {"behaviours": [{"kind": "follow_field", "field": 3}]}}
    with pytest.raises(ThrongError, match="field 3"):
        w.set_group_params(0, follow)
    w.step()
    assert w.frame == 1


def test_add_group_refuses_a_field_the_world_does_not_have():
    w = World.from_scenario("flock", agents=10)
    follow = {"steering": {"behaviours": [{"kind": "follow_field", "field": 3}]}}
    with pytest.raises(ThrongError, match="field 3"):
        w.add_group(follow)
    w.step()
    assert w.frame == 1


def test_add_agents_beyond_the_agent_ceiling_is_refused_before_it_copies():
    # A broadcast view of 10^8 + 1 rows takes no memory; copying it would take 800 MB.
    rows = np.broadcast_to(np.zeros(2, np.float32), (100_000_001, 2))
    w = World.from_scenario("flock", agents=10)
    with pytest.raises(ThrongError, match="positions.*100000001 rows, more than"):
        w.add_agents(rows)
    assert len(w) == 10


def test_add_agents_beyond_an_address_space_limit_is_refused_naming_it():
    # In a child: an address-space limit 400 MB above what the interpreter holds, then 50
    # million agents (about 13 GB of state) asked for. The child must catch the error.
    script = textwrap.dedent(
        """
        import resource
        import numpy as np
        import throng
        w = throng.World.from_scenario("flock", agents=10)
        size = int(open("/proc/self/status").read().split("VmSize:")[1].split()[0]) * 1024
        resource.setrlimit(resource.RLIMIT_AS, (size + (400 << 20), resource.RLIM_INFINITY))
        rows = np.broadcast_to(np.zeros(2, np.float32), (50_000_000, 2))
        try:
            w.add_agents(rows)
        except throng.ThrongError as e:
            assert "not enough memory for agents" in str(e) and "ulimit -v" in str(e), e
        else:
            raise SystemExit("accepted")
        assert len(w) == 10
        """
    )
    child = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120)
    assert child.returncode == 0, child.stderr[-2000:]
