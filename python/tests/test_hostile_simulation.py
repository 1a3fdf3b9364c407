"""A hostile round on throng.Simulation, journeys and stages: every method fed NaN, infinities,
absurd sizes and ids, malformed geometry, wrong types and a broadcast array of 10^8 + 1 rows,
from a fixed seed. Each call either works or raises ThrongError (or TypeError for a wrong
Python type): never a panic, a crash or a hang, and the state stays finite. docs/RELIABILITY.md
records the counts."""

import random
import warnings

import numpy as np

import throng

HALL = "POLYGON ((0 0, 30 0, 30 20, 0 20, 0 0))"
nums = [0.0, -1.0, 1e-30, 1e30, 1e40, float("nan"), float("inf"), -float("inf"), 2**31, -2**63, 1e18, 3.5]
ints = [0, -1, 1, 2**32, 2**64, -2**70, 10**9]
junk = [None, "x", b"\x00", [], [[]], {}, object(), [1, 2, 3], [(1, 2, 3)], np.zeros((3, 3)), np.array([[np.nan, 1.0]]), "POLYGON ((0 0, 1 1, 0 0))", "MULTIPOLYGON EMPTY", "POLYGON ((0 0, 10 0, 0 10, 10 10, 0 0))", "LINESTRING (0 0, 1 1)", "POLYGON ((" + ", ".join(f"{i} {i%2}" for i in range(20000)) + "))"]
pts = lambda: (random.choice(nums + [1.0, 5.0]), random.choice(nums + [2.0, 7.0]))


def test_every_hostile_call_is_an_error_or_works_and_the_state_stays_finite():
    random.seed(1)
    warnings.simplefilter("ignore", RuntimeWarning)
    counts = {"inputs": 0, "throng_error": 0, "type_error": 0, "ok": 0, "other": 0}
    others = []

    def attempt(f, *a, **k):
        counts["inputs"] += 1
        try:
            f(*a, **k)
            counts["ok"] += 1
        except throng.ThrongError:
            counts["throng_error"] += 1
        except (TypeError, OverflowError):
            counts["type_error"] += 1
        except BaseException as e:  # PanicException derives from BaseException
            counts["other"] += 1
            others.append(f"{f.__name__}{a!r:.80} {type(e).__name__}: {e}")

    for g in junk + nums:
        attempt(throng.Simulation, g)
    for kw in [dict(dt=x) for x in nums] + [dict(seed=x) for x in ints] + [dict(threads=x) for x in ints] + [dict(model=m) for m in ["", "cfsm ", "SFM", "\x00", "external"]]:
        attempt(throng.Simulation, HALL, **kw)

    for round_ in range(30):
        sim = throng.Simulation(HALL, seed=round_)
        stages = []
        for _ in range(8):
            attempt(sim.add_waypoint_stage, pts(), random.choice(nums))
            attempt(sim.add_exit_stage, random.choice(junk + ["POLYGON ((28 8, 30 8, 30 12, 28 12, 28 8))", "POLYGON ((40 8, 50 8, 50 12, 40 12, 40 8))"]))
            attempt(sim.add_queue_stage, random.choice([[pts() for _ in range(3)], [], np.full((5, 2), np.nan), [(5.0, 5.0)] * 2000, "abc"]))
            attempt(sim.add_waiting_set_stage, random.choice([[pts()], [(10.0, 10.0), (11.0, 10.0)], None]))
        ok_exit = sim.add_exit_stage("POLYGON ((28 8, 30 8, 30 12, 28 12, 28 8))")
        q = sim.add_queue_stage([(10.0, 10.0), (10.7, 10.0)])
        wsl = sim.add_waiting_set_stage([(15.0, 5.0)])
        for _ in range(10):
            try:
                j = throng.Journey([random.choice(ints + [ok_exit, q.id, wsl.id]) for _ in range(random.randint(0, 4))]) if random.random() < 0.5 else throng.Journey([q, ok_exit])
            except (throng.ThrongError, TypeError, OverflowError):
                counts["inputs"] += 1; counts["throng_error"] += 1
                j = throng.Journey([q, ok_exit])
            try:
                j.set_transition(random.choice(ints + [q.id]), random.choice([throng.Transition.fixed(ok_exit), throng.Transition.fixed(q), throng.Transition.round_robin([(ok_exit, 0)]), throng.Transition.round_robin([]), throng.Transition.least_targeted([])]))
            except (throng.ThrongError, TypeError, OverflowError):
                pass
            attempt(sim.add_journey, j)
        good = sim.add_journey(throng.Journey([q, ok_exit], chain=True))
        for _ in range(20):
            attempt(sim.add_agents, random.choice([pts(), [pts() for _ in range(4)], np.zeros((0, 2)), np.full((3, 2), np.inf), "x", [[1.0]], np.broadcast_to(np.array([5.0, 5.0]), (10**8 + 1, 2))]), journey=random.choice([good, 99, -1, None]), desired_speed=random.choice([None] + nums), radius=random.choice([None] + nums), model=random.choice([None, "cfsm", "social_force", "external", "nope"]))
        ids = [int(i) for i in sim.ids()]
        for _ in range(20):
            attempt(q.pop, random.choice(ints))
            attempt(setattr, wsl, "active", random.choice([True, False]))
            attempt(sim.set_desired_speeds, random.choice([ids, [10**6], [-1]]), random.choice(nums))
            attempt(sim.set_radii, ids, random.choice(nums))
            attempt(sim.set_external, random.choice([ids[:1], [10**6], []]), [pts()], random.choice([None, [pts()]]))
            attempt(sim.switch_geometry, random.choice(junk + [HALL, "POLYGON ((0 0, 31 0, 31 21, 0 21, 0 0))"]))
            attempt(sim.set_direct_target, random.choice(ints), pts())
            attempt(sim.switch_agent_journey, random.choice(ints), random.choice(ints))
            attempt(sim.remove_agent, random.choice(ints))
            attempt(sim.iterate, random.choice([0, 1, 3, -1]))
        p = sim.positions()
        assert np.all(np.isfinite(p)), "non-finite state"

    assert counts["other"] == 0, "\n".join(others[:20])
    assert counts["inputs"] > 7000 and counts["ok"] > 1000, counts
