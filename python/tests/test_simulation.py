"""throng.Simulation: pedestrian studies built in Python without TOML (stages, journeys,
transitions, per-agent parameters), its examples run with their outcomes asserted, and its bad
input raised as ThrongError naming the thing."""

import math
import runpy
from pathlib import Path

import numpy as np
import pytest

import throng

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "python"
HALL = "POLYGON ((0 0, 30 0, 30 20, 0 20, 0 0))"


def example(name):
    return runpy.run_path(str(EXAMPLES / f"{name}.py"))["main"]


def test_a_bottleneck_from_wkt_empties_at_a_measured_flow():
    r = example("bottleneck_wkt")()
    assert r["left"] == 100
    # A 1 m door: the Juelich bottleneck experiments give about 1.9 persons/s per metre of
    # width at this size; the speed model lies within a third of it.
    assert 1.2 < r["flow"] < 2.6, r


def test_the_ticket_gate_queue_lets_through_exactly_the_popped_count():
    r = example("ticket_gate_queue")()
    assert r["popped"] == 21
    assert r["left"] == r["popped"]
    assert r["in_queue"] == 9


def test_the_waiting_area_holds_everyone_until_the_signal():
    r = example("waiting_area")()
    assert r["held"] == {"agents": 40, "waiting": 40}
    assert r["left"] == 40 and r["agents"] == 0


def test_the_concourse_splits_one_to_three_within_ten_percent():
    r = example("concourse_round_robin")()
    assert r["north"] + r["south"] == 400
    assert abs(r["north"] / 400 - 0.25) <= 0.025, r


def small(threads=None, seed=1):
    sim = throng.Simulation(HALL, dt=0.01, seed=seed, threads=threads)
    via = sim.add_waypoint_stage((15.0, 10.0), 1.0)
    out = sim.add_exit_stage([(28.0, 8.0), (30.0, 8.0), (30.0, 12.0), (28.0, 12.0)])
    j = sim.add_journey(throng.Journey([via, out], chain=True))
    xy = np.array([(1.0 + 0.7 * (k % 10), 5.0 + 0.7 * (k // 10)) for k in range(60)])
    ids = sim.add_agents(xy, journey=j, desired_speed=1.2)
    return sim, ids, via, out


def test_an_unknown_stage_of_a_journey_names_the_journey_and_the_stage():
    sim, ids, via, out = small()
    with pytest.raises(throng.ThrongError) as e:
        sim.add_journey(throng.Journey([via, 9]))
    assert str(e.value) == "journey 1 names no stage 9 (the world has 2)"
    assert e.value.parameter == "journey"
    j = throng.Journey([via, out])
    j.set_transition(via, throng.Transition.least_targeted([out, 7]))
    with pytest.raises(throng.ThrongError, match=r"^journey 1 names no stage 7 "):
        sim.add_journey(j)
    assert sim.add_journey(throng.Journey([via, out], chain=True)) == 1, "nothing was added"


def test_agents_carry_their_own_parameters_readable_and_writable_between_steps():
    sim, ids, via, out = small()
    assert ids.dtype == np.uint32 and list(ids) == list(range(60))
    assert np.all(sim.desired_speeds() == np.float32(1.2))
    sim.set_desired_speeds(ids[:10], 0.5)
    sim.set_radii(ids[:10], [0.25] * 10)
    speeds = sim.desired_speeds()
    assert np.all(speeds[:10] == np.float32(0.5)) and np.all(speeds[10:] == np.float32(1.2))
    assert np.all(sim.radii()[:10] == np.float32(0.25))
    one = sim.add_agents((2.0, 18.0), journey=0, desired_speed=0.8, radius=0.18)
    assert isinstance(one, int) and sim.agent_journey(one) == (0, via)
    sim.iterate(200)
    assert sim.iteration_count() == 200 and math.isclose(sim.elapsed_time(), 2.0, rel_tol=1e-6)
    # The slow ones are behind.
    x = sim.positions()[:, 0]
    assert x[:10].mean() < x[10:60].mean()


def test_the_same_bits_on_one_and_two_threads():
    a, *_ = small(threads=1)
    b, *_ = small(threads=2)
    a.iterate(500)
    b.iterate(500)
    assert np.array_equal(a.positions(), b.positions())
    assert np.array_equal(a.velocities(), b.velocities())


def test_params_set_the_speed_model_as_jupedsim_has_it():
    def crowd(params):
        sim = throng.Simulation(HALL, dt=0.01, seed=1, params=params)
        out = sim.add_exit_stage([(28.0, 8.0), (30.0, 8.0), (30.0, 12.0), (28.0, 12.0)])
        j = sim.add_journey(throng.Journey([out]))
        xy = np.array([(1.0 + 0.5 * (k % 10), 5.0 + 0.5 * (k // 10)) for k in range(100)])
        sim.add_agents(xy, journey=j, desired_speed=1.2)
        sim.iterate(300)
        return sim.positions()

    jupedsim = {"cfsm": {"time_gap": 1.0, "pressed_time_gap": 1.0, "pressed_anisotropy": 1.0,
                         "reference_speed": 0.0, "path_width": 1.0,
                         "spacing": "centre", "speed_function": "linear"}}
    assert np.array_equal(crowd(None), crowd({}))
    # The paper's strip and gap between discs walk the packed crowd more slowly than the defaults.
    assert crowd(jupedsim)[:, 0].mean() < crowd(None)[:, 0].mean()
    with pytest.raises(throng.ThrongError, match="time_gp"):
        throng.Simulation(HALL, params={"cfsm": {"time_gp": 1.0}})
    with pytest.raises(throng.ThrongError, match="time_gap"):
        throng.Simulation(HALL, params={"cfsm": {"time_gap": -1.0}})
    with pytest.raises(throng.ThrongError, match="params"):
        throng.Simulation(HALL, params={"model": "cfsm"})


def test_a_saved_simulation_keeps_the_params_of_models_no_group_uses_yet(tmp_path):
    params = {"cfsm": {"time_gap": 1.0}, "social_force": {"tau": 0.3}}

    def crowd(sim):
        out = sim.add_exit_stage([(28.0, 8.0), (30.0, 8.0), (30.0, 12.0), (28.0, 12.0)])
        j = sim.add_journey(throng.Journey([out]))
        xy = np.array([(1.0 + 0.5 * (k % 10), 5.0 + 0.5 * (k // 10)) for k in range(60)])
        sim.add_agents(xy[:30], journey=j, desired_speed=1.2)
        sim.add_agents(xy[30:], journey=j, desired_speed=1.2, model="social_force")
        sim.iterate(200)
        return sim.positions()

    # Saved before any agent, so before any group holds the parameters.
    path = tmp_path / "empty.ckpt"
    throng.Simulation(HALL, dt=0.01, seed=1, params=params).save(path)
    resumed = crowd(throng.Simulation.load(path))
    assert np.array_equal(resumed, crowd(throng.Simulation(HALL, dt=0.01, seed=1, params=params)))
    assert not np.array_equal(resumed, crowd(throng.Simulation(HALL, dt=0.01, seed=1)))


def test_model_parameters_per_agent_walk_as_params_for_everyone_would():
    def crowd(params=None, **own):
        sim = throng.Simulation(HALL, dt=0.01, seed=1, params=params)
        out = sim.add_exit_stage([(28.0, 8.0), (30.0, 8.0), (30.0, 12.0), (28.0, 12.0)])
        j = sim.add_journey(throng.Journey([out]))
        xy = np.array([(1.0 + 0.5 * (k % 10), 5.0 + 0.5 * (k // 10)) for k in range(100)])
        ids = sim.add_agents(xy, journey=j, desired_speed=1.2, **own)
        return sim, ids

    everyone, _ = crowd({"cfsm": {"time_gap": 1.1}})
    own, ids = crowd(time_gap=1.1)
    plain, _ = crowd()
    for sim in (everyone, own, plain):
        sim.iterate(300)
    assert np.array_equal(own.positions(), everyone.positions())
    assert not np.array_equal(own.positions(), plain.positions())
    assert np.all(own.agent_params("time_gap") == np.float32(1.1))
    assert np.all(plain.agent_params("time_gap") == np.float32(1.0))
    assert np.all(np.isnan(plain.agent_params("tau")))

    # One per agent, then changed between steps.
    sim, ids = crowd(time_gap=np.linspace(0.5, 1.5, 100))
    assert math.isclose(float(sim.agent_params("time_gap")[99]), 1.5, rel_tol=1e-6)
    sim.set_agent_params(ids[:10], "strength_neighbour", 4.0)
    gaps = sim.agent_params("strength_neighbour")
    assert np.all(gaps[:10] == np.float32(4.0)) and np.all(gaps[10:] == np.float32(8.0))

    # Bad input changes nothing.
    for bad, match in [({"time_gp": 1.0}, "time_gp"), ({"time_gap": -1.0}, "time_gap"),
                       ({"time_gap": float("nan")}, "time_gap"), ({"tau": 0.4}, "tau"),
                       ({"time_gap": [1.0, 2.0]}, "time_gap")]:
        before = sim.agent_count()
        with pytest.raises(throng.ThrongError, match=match):
            sim.add_agents([(20.0, 5.0), (20.0, 6.0), (20.0, 7.0)], journey=0, **bad)
        assert sim.agent_count() == before
    with pytest.raises(throng.ThrongError, match="time_gap"):
        sim.set_agent_params(ids, "time_gap", [1.0] * 99 + [float("inf")])
    assert math.isclose(float(sim.agent_params("time_gap")[0]), 0.5, rel_tol=1e-6)
    with pytest.raises(throng.ThrongError, match="speed_function"):
        sim.agent_params("speed_function")


def test_the_walkable_area_is_the_geometry_given():
    sim = throng.Simulation(HALL)
    assert sim.walkable_area().startswith("POLYGON")
    shapely = pytest.importorskip("shapely")
    assert sim.walkable_area(shapely=True).equals(shapely.from_wkt(HALL))
    # A shapely polygon is accepted as geometry and as an exit.
    poly = shapely.from_wkt(HALL)
    s2 = throng.Simulation(poly)
    s2.add_exit_stage(shapely.box(28, 8, 30, 12))


def test_bad_input_raises_throng_error_naming_the_thing():
    sim, ids, via, out = small()
    with pytest.raises(throng.ThrongError, match="no stage 9"):
        sim.add_journey(throng.Journey([via, 9]))
    cycle = throng.Journey([via, out])
    a = sim.add_waypoint_stage((5.0, 5.0), 1.0)
    b = sim.add_waypoint_stage((9.0, 5.0), 1.0)
    cycle = throng.Journey([a, b])
    cycle.set_transition(a, throng.Transition.fixed(b))
    cycle.set_transition(b, throng.Transition.fixed(a))
    with pytest.raises(throng.ThrongError, match="for ever"):
        sim.add_journey(cycle)
    q = sim.add_queue_stage([(10.0, 2.0), (10.5, 2.0)])
    with pytest.raises(throng.ThrongError, match="cannot pop 3"):
        q.pop(3)
    with pytest.raises(throng.ThrongError, match="finite"):
        sim.add_agents([(1.0, float("nan"))], journey=0)
    with pytest.raises(throng.ThrongError, match="outside the walkable area"):
        sim.add_agents([(5.0, 5.0), (50.0, 5.0)], journey=0)
    assert sim.agent_count() == 60, "a failed add_agents adds nobody"
    with pytest.raises(throng.ThrongError, match="outside the walkable area"):
        sim.add_waypoint_stage((-3.0, 5.0), 1.0)
    with pytest.raises(throng.ThrongError, match="no journey 5"):
        sim.add_agents([(5.0, 5.0)], journey=5)
    with pytest.raises(throng.ThrongError, match="desired_speed"):
        sim.set_desired_speeds(ids[:2], [1.0, float("inf")])
    assert np.all(sim.desired_speeds()[:2] == np.float32(1.2)), "a failed setter changes nothing"
    with pytest.raises(throng.ThrongError, match="unknown pedestrian model"):
        throng.Simulation(HALL, model="boids")
    with pytest.raises(throng.ThrongError, match="dt"):
        throng.Simulation(HALL, dt=float("nan"))
    with pytest.raises(throng.ThrongError):
        throng.Simulation("POLYGON ((0 0, 1 1, 0 0))")


def test_two_models_share_one_simulation_and_keep_apart():
    room = "POLYGON ((0 0, 10 0, 10 4.5, 14 4.5, 14 5.5, 10 5.5, 10 10, 0 10, 0 0))"
    sim = throng.Simulation(room, model="cfsm", seed=2)
    out = sim.add_exit_stage("POLYGON ((13 4.5, 14 4.5, 14 5.5, 13 5.5, 13 4.5))")
    j = sim.add_journey(throng.Journey([out]))
    xy = [(1.0 + 0.8 * (k % 10), 1.0 + 0.8 * (k // 10)) for k in range(60)]
    sim.add_agents(xy[::2], journey=j)
    sim.add_agents(xy[1::2], journey=j, model="social_force")
    closest = math.inf
    while sim.agent_count() > 0 and sim.elapsed_time() < 200:
        sim.iterate(50)
        p = sim.positions().astype(np.float64)
        if len(p) > 1:
            d = np.sqrt(((p[:, None, :] - p[None, :, :]) ** 2).sum(-1))
            np.fill_diagonal(d, np.inf)
            closest = min(closest, d.min())
    assert sim.exit_counts()[out] == 60
    # Bodies of 0.2 m: the two models' agents overlap by at most a quarter of a radius.
    assert closest > 0.35, closest


def test_after_the_door_closes_only_those_beyond_it_leave_east():
    r = example("door_closed")()
    assert r["east"] == r["east_before"] + r["in_corridor"]
    assert r["east"] + r["north"] == 80 and r["north"] > 0
    assert r["crossed_after"] == 0, "nobody in the room passed the closed door"
    assert r["stranded_were_in_room"], "the closed door strands exactly those in the room"
    assert r["stranded_after"] == 0


def test_no_pedestrian_comes_closer_to_the_robot_than_their_radii_less_five_percent():
    r = example("robot_crossing")()
    assert r["left"] == r["people"] == 40
    assert r["closest_gap"] > -0.05 * (0.2 + 0.4), r


def test_external_agents_are_checked_and_follow_no_journey():
    sim, ids, via, out = small()
    robot = sim.add_agents((20.0, 2.0), model="external", radius=0.4)
    assert sim.agent_journey(robot) is None
    with pytest.raises(throng.ThrongError, match="outside the walkable area"):
        sim.set_external([robot], [(40.0, 2.0)])
    with pytest.raises(throng.ThrongError, match="finite"):
        sim.set_external([robot], [(20.0, 2.0)], [(float("nan"), 0.0)])
    with pytest.raises(throng.ThrongError, match="no journey"):
        sim.add_agents((3.0, 3.0), model="external", journey=0)
    with pytest.raises(throng.ThrongError, match="needs a journey"):
        sim.add_agents((3.0, 3.0))
    sim.set_external([robot], [(21.0, 2.0)], [(1.0, 0.0)])
    sim.iterate(10)
    row = list(sim.ids()).index(robot)
    assert tuple(sim.positions()[row]) == (21.0, 2.0)


def test_a_saved_simulation_resumes_bit_for_bit_with_its_queues_and_journeys(tmp_path):
    sim = throng.Simulation(HALL, dt=0.01, seed=4)
    q = sim.add_queue_stage([(20.0 - 0.7 * k, 10.0) for k in range(8)])
    out = sim.add_exit_stage("POLYGON ((28 8, 30 8, 30 12, 28 12, 28 8))")
    j = sim.add_journey(throng.Journey([q, out], chain=True))
    sim.add_agents([(1.0 + k % 5, 5.0 + k // 5) for k in range(20)], journey=j)
    robot = sim.add_agents((15.0, 2.0), model="external", radius=0.4)
    sim.iterate(1500)
    q.pop(2)
    path = tmp_path / "study.ckpt"
    sim.save(path)
    back = throng.Simulation.load(path, threads=1)
    assert back.dt == sim.dt and back.iteration_count() == sim.iteration_count()
    for s in (sim, back):
        s.set_external([robot], [(15.0, 3.0)], [(0.0, 1.0)])
        s.iterate(800)
    assert np.array_equal(sim.positions(), back.positions())
    assert sim.exit_counts() == back.exit_counts() == {out: 2}
    with pytest.raises(throng.ThrongError):
        throng.Simulation.load(tmp_path / "missing.ckpt")
    (tmp_path / "junk.ckpt").write_bytes(b"not a checkpoint")
    with pytest.raises(throng.ThrongError):
        throng.Simulation.load(tmp_path / "junk.ckpt")
