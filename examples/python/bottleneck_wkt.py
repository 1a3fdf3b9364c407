"""A bottleneck built from WKT: 100 pedestrians leave a 10 x 10 m room through a 1 m door
and a corridor 4 m long, with the collision-free speed model (JuPedSim's default).

Run: python examples/python/bottleneck_wkt.py
"""

import throng

ROOM = (
    "POLYGON ((0 0, 10 0, 10 4.5, 14 4.5, 14 5.5, 10 5.5, 10 10, 0 10, 0 0))"
)


def main(seed: int = 1) -> dict:
    sim = throng.Simulation(geometry=ROOM, model="cfsm", dt=0.01, seed=seed)
    exit_ = sim.add_exit_stage("POLYGON ((13 4.5, 14 4.5, 14 5.5, 13 5.5, 13 4.5))")
    journey = sim.add_journey(throng.Journey([exit_]))
    positions = [(1.0 + 0.8 * (k % 10), 1.0 + 0.8 * (k // 10)) for k in range(100)]
    sim.add_agents(positions, journey=journey)
    while sim.agent_count() > 0 and sim.elapsed_time() < 300:
        sim.iterate(100)
    return {
        "left": sim.exit_counts()[exit_],
        "evacuation_time": sim.elapsed_time(),
        "flow": sim.exit_counts()[exit_] / sim.elapsed_time(),
    }


if __name__ == "__main__":
    r = main()
    print(f"{r['left']} left in {r['evacuation_time']:.1f} s ({r['flow']:.2f} persons/s)")
