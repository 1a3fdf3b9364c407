"""One journey scene in JuPedSim 1.4.2 and in throng.Simulation, run alternately in one process.

usage:
    python journeys.py [--agents 10000] [--block 200] [--rounds 3] [--warmup 20]
                       [--cap 60] [--tail-block 500] [--seed 1]

Needs jupedsim 1.4.2, shapely and numpy, and throng's wheel, in one venv:
    python3 -m venv /tmp/peers/pyenv
    /tmp/peers/pyenv/bin/pip install jupedsim==1.4.2 pedpy==1.5.1 shapely numpy
    /tmp/peers/pyenv/bin/pip install --force-reinstall --no-deps target/wheels/throng-*.whl
Every result is one JSON object on its own stdout line; a short summary follows them on stdout,
progress goes to stderr.

The scene (the same for both, written once with each API)
--------------------------------------------------------
* An open concourse 215 m x 184 m (WKT, below) with two holes: a kiosk 4 m x 10 m at
  x 190..194, y 87..97 right behind the hall's point, and a column 2 m x 2 m at x 195..197,
  y 60..62.
* Stages: a waypoint (the hall) at (188, 92), reached within 100 m; two exit stages at the east
  wall, north x 200..215, y 140..184 and south x 200..215, y 0..44 (each 15 m x 44 m).
* Two journeys, both waypoint first: journey "rr" goes on by a weighted round robin, 1 to the
  north exit for every 3 to the south; journey "lt" goes on to the least targeted of the two
  exits (the exit fewest live agents head for at the moment of the choice).
* Agents: a lattice of 100 x 100 (N = 10,000 by default; otherwise its N nearest the hall,
  column by column from x = 180.2) in x 2..180.2, y 2.9..181.1, 1.8 m apart (0.31 persons/m^2,
  free walking at the start), every position moved by up to 0.05 m along each axis (numpy
  default_rng(seed), uniform); agent k follows "rr" when k is even and "lt" when odd. The
  agents within 100 m of the hall's point choose their exit in the first step, the others when
  they come within 100 m. Radius 0.2 m and desired speed 1.2 m/s for everyone (JuPedSim's
  CollisionFreeSpeedModelAgentParameters defaults, set explicitly on both sides); dt 0.01 s.
* The model: the collision-free speed model with JuPedSim's parameters in both. JuPedSim runs
  its defaults (time gap 1 s, repulsions 8 / 0.1 m between agents and 5 / 0.02 m from walls);
  throng gets the same through Simulation(params=THRONG_PARAMS): spacing between centres less
  the radii, speed min(v0, s / T), T = 1 s, the paper's strip, no pressure term (its own
  defaults differ: the time gap taken at 1.13 m/s, a path 0.8 bodies wide, spacing to contact,
  a smooth speed function, the pressure term). JuPedSim's neighbour
  cut-off is 3 m, throng's 2 m; beyond 2 m the repulsion is below 1e-6 and the speed at v0.

What is measured
----------------
Three simulations of the scene: JuPedSim (one thread: it has no other), throng with
threads=1 and throng on all cores (threads=None). Each first runs `warmup` untimed
iterations; then `rounds` rounds, in each of which JuPedSim, throng on one thread and throng
on all threads in turn run `block` iterations, timed by time.perf_counter around
iterate(block). Agent-steps per second = block * (agents before + agents after) / 2 / seconds.
Every agent is still inside during the timed rounds at the default sizes (the nearest exit is
about 20 m, 17 s, from the nearest agent), so all three are timed at the same agent count. Per
round: the ratios throng / JuPedSim in agent-steps per second.

Then all three go on, alternately in blocks of `tail-block` iterations (timed too), until every
simulation is empty or has simulated `cap` seconds. Exit counts: throng's exit_counts();
JuPedSim has no counter, so after every block each live agent's stage is noted and an agent
that is gone is counted at the exit stage it last had (both exits lie inside the waypoint's
100 m and over 40 m from where anyone comes within it, so none completes the waypoint and
leaves within one block of 5 s; "elsewhere" counts any that did). Reported per exit: both
counts and the relative difference (throng - JuPedSim) / JuPedSim, and whether the two throng
runs agree (they must: results do not depend on the thread count).
"""
import argparse
import json
import os
import statistics
import sys
import time

import numpy as np

CONCOURSE = ("POLYGON ((0 0, 215 0, 215 184, 0 184, 0 0), "
             "(190 87, 194 87, 194 97, 190 97, 190 87), "
             "(195 60, 197 60, 197 62, 195 62, 195 60))")
HALL, HALL_REACH = (188.0, 92.0), 100.0
NORTH = "POLYGON ((200 140, 215 140, 215 184, 200 184, 200 140))"
SOUTH = "POLYGON ((200 0, 215 0, 215 44, 200 44, 200 0))"
RR_WEIGHTS = (1, 3)  # north, south
LATTICE = 1.8  # m between neighbours along x and y
# throng's speed model set to JuPedSim's: spacing between centres less the radii, speed
# min(v0, s / T) with T = 1 s, no pressure terms (throng's defaults are calibrated otherwise).
THRONG_PARAMS = {"cfsm": {"time_gap": 1.0, "pressed_time_gap": 1.0, "pressed_anisotropy": 1.0,
                          "reference_speed": 0.0, "path_width": 1.0,
                          "spacing": "centre", "speed_function": "linear"}}
V0, RADIUS, DT = 1.2, 0.2, 0.01


def log(*a):
    print(*a, file=sys.stderr, flush=True)


def loadavg():
    with open("/proc/loadavg") as f:
        return f.read().strip()


def emit(result):
    print(json.dumps(result), flush=True)


def positions(n, seed):
    """The n of the 100 x 100 jittered lattice nearest the hall, as (x, y) tuples."""
    if n > 10_000:
        raise SystemExit("the lattice holds 10,000 agents")
    rng = np.random.default_rng(seed)
    i, j = np.meshgrid(np.arange(100), np.arange(100), indexing="ij")
    xy = np.stack([180.2 - LATTICE * i.ravel(), 2.9 + LATTICE * j.ravel()], axis=1)
    xy += rng.uniform(-0.05, 0.05, size=xy.shape)
    return [(float(x), float(y)) for x, y in xy[:n]]


class JuPedSim:
    """The scene in JuPedSim."""

    name = "jupedsim"

    def __init__(self, pos):
        import jupedsim as jps
        import shapely

        self.version = jps.__version__
        self.sim = jps.Simulation(model=jps.CollisionFreeSpeedModel(),
                                  geometry=shapely.from_wkt(CONCOURSE), dt=DT)
        hall = self.sim.add_waypoint_stage(HALL, HALL_REACH)
        north = self.sim.add_exit_stage(shapely.from_wkt(NORTH))
        south = self.sim.add_exit_stage(shapely.from_wkt(SOUTH))
        self.exits = {north: "north", south: "south"}
        rr = jps.JourneyDescription([hall, north, south])
        rr.set_transition_for_stage(hall, jps.Transition.create_round_robin_transition(
            [(north, RR_WEIGHTS[0]), (south, RR_WEIGHTS[1])]))
        lt = jps.JourneyDescription([hall, north, south])
        lt.set_transition_for_stage(
            hall, jps.Transition.create_least_targeted_transition([north, south]))
        journeys = [self.sim.add_journey(rr), self.sim.add_journey(lt)]
        for k, p in enumerate(pos):
            self.sim.add_agent(jps.CollisionFreeSpeedModelAgentParameters(
                position=p, journey_id=journeys[k % 2], stage_id=hall,
                desired_speed=V0, radius=RADIUS))
        self.left = {"north": 0, "south": 0, "elsewhere": 0}
        self.iterations = 0
        self.stage_of = self._stages()

    def _stages(self):
        return {a.id: a.stage_id for a in self.sim.agents()}

    def iterate(self, n):
        self.sim.iterate(n)

    def after_block(self):
        now = self._stages()
        for id_, stage in self.stage_of.items():
            if id_ not in now:
                self.left[self.exits.get(stage, "elsewhere")] += 1
        self.stage_of = now

    def count(self):
        return self.sim.agent_count()

    def elapsed(self):
        return self.sim.elapsed_time()

    def exit_counts(self):
        return dict(self.left)


class Throng:
    """The scene in throng.Simulation."""

    def __init__(self, pos, threads, seed):
        import throng

        self.name = "throng_1" if threads == 1 else "throng_all"
        self.sim = throng.Simulation(geometry=CONCOURSE, model="cfsm", dt=DT, seed=seed,
                                     threads=threads, params=THRONG_PARAMS)
        hall = self.sim.add_waypoint_stage(HALL, HALL_REACH)
        north = self.sim.add_exit_stage(NORTH)
        south = self.sim.add_exit_stage(SOUTH)
        self.exits = {north: "north", south: "south"}
        rr = throng.Journey([hall, north, south])
        rr.set_transition(hall, throng.Transition.round_robin(
            [(north, RR_WEIGHTS[0]), (south, RR_WEIGHTS[1])]))
        lt = throng.Journey([hall, north, south])
        lt.set_transition(hall, throng.Transition.least_targeted([north, south]))
        journeys = [self.sim.add_journey(rr), self.sim.add_journey(lt)]
        # One call per journey would reorder the ids; one agent per call keeps id k = agent k.
        for k, p in enumerate(pos):
            self.sim.add_agents([p], journey=journeys[k % 2], stage=hall,
                                desired_speed=V0, radius=RADIUS)
        self.iterations = 0

    def iterate(self, n):
        self.sim.iterate(n)

    def after_block(self):
        pass

    def count(self):
        return self.sim.agent_count()

    def elapsed(self):
        return self.sim.elapsed_time()

    def exit_counts(self):
        c = self.sim.exit_counts()
        return {name: int(c.get(s, 0)) for s, name in self.exits.items()}


def timed_block(sim, n):
    sim.iterations += n
    n0 = sim.count()
    t0 = time.perf_counter()
    sim.iterate(n)
    s = time.perf_counter() - t0
    n1 = sim.count()
    sim.after_block()
    steps = n * (n0 + n1) / 2
    return dict(iterations=n, agents_before=n0, agents_after=n1, seconds=s,
                agent_steps=steps, agent_steps_per_s=steps / s if s > 0 else None)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--agents", type=int, default=10_000)
    ap.add_argument("--block", type=int, default=200)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--warmup", type=int, default=20)
    ap.add_argument("--cap", type=float, default=60.0, help="simulated seconds")
    ap.add_argument("--tail-block", type=int, default=500)
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()

    import throng

    load_start = loadavg()
    pos = positions(a.agents, a.seed)
    t0 = time.perf_counter()
    sims = [JuPedSim(pos), Throng(pos, 1, a.seed), Throng(pos, None, a.seed)]
    log(f"{a.agents} agents set up in three simulations in {time.perf_counter() - t0:.1f} s")
    for s in sims:
        s.iterate(a.warmup)
        s.iterations += a.warmup
        s.after_block()

    ratios = {"throng_1": [], "throng_all": []}
    for r in range(a.rounds):
        res = {}
        for s in sims:
            b = timed_block(s, a.block)
            res[s.name] = b
            emit(dict(result="round", round=r, sim=s.name,
                      **{k: (round(v, 4) if isinstance(v, float) else v) for k, v in b.items()}))
        for t in ratios:
            ratios[t].append(res[t]["agent_steps_per_s"] / res["jupedsim"]["agent_steps_per_s"])
        log(f"round {r}: " + ", ".join(
            f"{k} {v['seconds'] / a.block * 1e3:.2f} ms/it" for k, v in res.items()))

    cap_iterations = round(a.cap / DT)
    totals = {s.name: [0.0, 0.0] for s in sims}  # agent-steps, seconds (after the rounds)
    while True:
        live = [s for s in sims if s.count() > 0 and s.iterations < cap_iterations]
        if not live:
            break
        for s in live:
            b = timed_block(s, min(a.tail_block, cap_iterations - s.iterations))
            totals[s.name][0] += b["agent_steps"]
            totals[s.name][1] += b["seconds"]
        log("t = " + ", ".join(f"{s.name} {s.elapsed():.0f} s ({s.count()} in)" for s in sims))

    speed = dict(result="speed", agents=a.agents, block=a.block, rounds=a.rounds,
                 warmup=a.warmup, dt=DT,
                 ratio_threads_1=[round(x, 2) for x in ratios["throng_1"]],
                 ratio_threads_all=[round(x, 2) for x in ratios["throng_all"]],
                 ratio_threads_1_median=round(statistics.median(ratios["throng_1"]), 2),
                 ratio_threads_all_median=round(statistics.median(ratios["throng_all"]), 2),
                 threads_all=os.cpu_count(),
                 tail_agent_steps_per_s={k: round(v[0] / v[1]) if v[1] > 0 else None
                                         for k, v in totals.items()})
    emit(speed)

    counts = {s.name: s.exit_counts() for s in sims}
    jp = counts["jupedsim"]
    rel = {e: ((counts["throng_1"][e] - jp[e]) / jp[e] if jp[e] else None)
           for e in ("north", "south")}
    exits = dict(result="exits", cap_s=a.cap,
                 iterations={s.name: s.iterations for s in sims},
                 elapsed_s={s.name: round(s.elapsed(), 2) for s in sims},
                 left_inside={s.name: s.count() for s in sims},
                 counts=counts,
                 rel_diff={e: (round(v, 4) if v is not None else None) for e, v in rel.items()},
                 throng_threads_agree=counts["throng_1"] == counts["throng_all"],
                 within_10_percent=all(v is not None and abs(v) <= 0.10 for v in rel.values()),
                 jupedsim=sims[0].version, throng=getattr(throng, "__version__", None),
                 loadavg_start=load_start, loadavg_end=loadavg())
    emit(exits)

    print(f"speed, throng / JuPedSim in agent-steps/s at {a.agents} agents "
          f"({a.rounds} rounds of {a.block} iterations):")
    print(f"  1 thread:  {', '.join(f'{x:.1f}x' for x in ratios['throng_1'])}")
    print(f"  {os.cpu_count()} threads: {', '.join(f'{x:.1f}x' for x in ratios['throng_all'])}")
    print(f"exits after {cap_iterations} iterations or empty (north, south): JuPedSim {jp['north']}, "
          f"{jp['south']}; throng {counts['throng_1']['north']}, "
          f"{counts['throng_1']['south']}; difference "
          + ", ".join(f"{e} {v:+.1%}" if v is not None else f"{e} n/a" for e, v in rel.items()))


if __name__ == "__main__":
    main()
