"""A robot crossing a crowd: a delivery robot (radius 0.4 m, driven from outside at 0.8 m/s)
crosses the path of 40 pedestrians walking to an exit; they walk round it or wait.

Run: python examples/python/robot_crossing.py
"""

import numpy as np

import throng

HALL = "POLYGON ((0 0, 30 0, 30 20, 0 20, 0 0))"


def main() -> dict:
    sim = throng.Simulation(geometry=HALL, dt=0.01, seed=13)
    out = sim.add_exit_stage("POLYGON ((28 8, 30 8, 30 12, 28 12, 28 8))")
    j = sim.add_journey(throng.Journey([out]))
    people = sim.add_agents(
        [(1.0 + 0.8 * (k % 6), 7.0 + 0.8 * (k // 6)) for k in range(40)], journey=j
    )
    robot = sim.add_agents((14.0, 1.0), model="external", radius=0.4)
    closest = np.inf
    for k in range(6000):
        y = min(1.0 + 0.8 * k * 0.01, 19.0)
        sim.set_external([robot], [(14.0, y)], [(0.0, 0.8)])
        sim.iterate()
        ids, p, r = sim.ids(), sim.positions().astype(np.float64), sim.radii()
        others = ids != robot
        gap = np.hypot(p[others, 0] - 14.0, p[others, 1] - y) - r[others] - 0.4
        if gap.size:
            closest = min(closest, gap.min())
    return {"left": sim.exit_counts()[out], "people": len(people), "closest_gap": closest}


if __name__ == "__main__":
    r = main()
    print(f"{r['left']} of {r['people']} passed; closest gap to the robot {r['closest_gap']:.3f} m")
