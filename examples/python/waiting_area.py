"""A waiting area emptied on a signal: 40 passengers wait in a waiting set until the train is
announced, then leave through the platform door.

Run: python examples/python/waiting_area.py
"""

import throng

HALL = "POLYGON ((0 0, 30 0, 30 20, 0 20, 0 0))"


def main() -> dict:
    sim = throng.Simulation(geometry=HALL, dt=0.01, seed=5)
    seats = [(22.0 - 1.0 * (k // 8), 6.0 + 1.0 * (k % 8)) for k in range(48)]
    waiting = sim.add_waiting_set_stage(seats)
    door = sim.add_exit_stage("POLYGON ((28 8, 30 8, 30 12, 28 12, 28 8))")
    j = sim.add_journey(throng.Journey([waiting, door], chain=True))
    positions = [(1.0 + 1.0 * (k % 8), 3.0 + 1.0 * (k // 8)) for k in range(40)]
    sim.add_agents(positions, journey=j)
    sim.iterate(6000)
    held = {"agents": sim.agent_count(), "waiting": waiting.count_waiting()}
    waiting.active = False  # the signal
    sim.iterate(6000)
    return {"held": held, "left": sim.exit_counts()[door], "agents": sim.agent_count()}


if __name__ == "__main__":
    r = main()
    print(f"held {r['held']} before the signal; {r['left']} left after it")
