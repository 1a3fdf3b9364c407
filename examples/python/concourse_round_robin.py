"""A station concourse with two exits: every traveller passes the ticket hall, then one in
four takes the north stairs and three in four the south stairs (weighted round robin).

Run: python examples/python/concourse_round_robin.py
"""

import throng

CONCOURSE = "POLYGON ((0 0, 40 0, 40 20, 0 20, 0 0), (18 8, 22 8, 22 12, 18 12, 18 8))"


def main(agents: int = 400) -> dict:
    sim = throng.Simulation(geometry=CONCOURSE, dt=0.01, seed=7)
    hall = sim.add_waypoint_stage((12.0, 10.0), 3.0)
    north = sim.add_exit_stage("POLYGON ((38 16, 40 16, 40 20, 38 20, 38 16))")
    south = sim.add_exit_stage("POLYGON ((38 0, 40 0, 40 4, 38 4, 38 0))")
    journey = throng.Journey([hall, north, south])
    journey.set_transition(hall, throng.Transition.round_robin([(north, 1), (south, 3)]))
    j = sim.add_journey(journey)
    positions = [(0.5 + 0.55 * (k % 20), 0.5 + 0.55 * (k // 20)) for k in range(agents)]
    sim.add_agents(positions, journey=j)
    while sim.agent_count() > 0 and sim.elapsed_time() < 400:
        sim.iterate(500)
    counts = sim.exit_counts()
    return {"north": counts[north], "south": counts[south], "time": sim.elapsed_time()}


if __name__ == "__main__":
    r = main()
    print(f"north {r['north']}, south {r['south']}, empty after {r['time']:.0f} s")
