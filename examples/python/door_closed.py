"""A door closed mid-evacuation: 80 people leave a room through its east door until, after
14 s, the door is closed (the walkable area switched to one with a wall in the doorway); those
still in the room turn to the north door, those already in the corridor walk on.

Run: python examples/python/door_closed.py
"""

import throng

TWO_DOORS = (
    "POLYGON ((0 0, 20 0, 20 4, 24 4, 24 6, 20 6, 20 10, 11 10, 11 14, 9 14, 9 10, 0 10, 0 0))"
)
# The door becomes a wall 5 cm thick: the room and the corridor beyond it are two parts, so
# that whoever is in the corridor walks on to the east exit.
EAST_CLOSED = (
    "MULTIPOLYGON (((0 0, 20 0, 20 10, 11 10, 11 14, 9 14, 9 10, 0 10, 0 0)), "
    "((20.05 4, 24 4, 24 6, 20.05 6, 20.05 4)))"
)


def main() -> dict:
    sim = throng.Simulation(geometry=TWO_DOORS, dt=0.01, seed=11)
    east = sim.add_exit_stage("POLYGON ((23 4, 24 4, 24 6, 23 6, 23 4))")
    north = sim.add_exit_stage("POLYGON ((9 13, 11 13, 11 14, 9 14, 9 13))")
    to_east = sim.add_journey(throng.Journey([east]))
    to_north = sim.add_journey(throng.Journey([north]))
    ids = sim.add_agents(
        [(1.0 + 0.7 * (k % 12), 1.0 + 0.7 * (k // 12)) for k in range(80)], journey=to_east
    )
    sim.iterate(1400)
    # Refused (naming the agent) while someone stands in the wall's 5 cm: a few steps later.
    while True:
        try:
            sim.switch_geometry(EAST_CLOSED)
            break
        except throng.ThrongError:
            sim.iterate()
    closed_at = sim.elapsed_time()
    left_east = sim.exit_counts()[east]
    # Those in the room are cut off from the east exit: they turn north.
    stranded = [int(i) for i in sim.stranded_agents()]
    in_room = sorted(int(i) for i, p in zip(sim.ids(), sim.positions()) if p[0] < 20.0)
    for i in stranded:
        sim.switch_agent_journey(i, to_north)
    stranded_after = len(sim.stranded_agents())
    in_corridor = {int(i) for i, p in zip(sim.ids(), sim.positions()) if p[0] > 20.0}
    crossed = 0
    while sim.agent_count() > 0 and sim.elapsed_time() < closed_at + 150:
        sim.iterate(10)
        crossed += sum(
            1 for i, p in zip(sim.ids(), sim.positions()) if p[0] > 20.0 and int(i) not in in_corridor
        )
    counts = sim.exit_counts()
    return {
        "closed_at": closed_at,
        "east_before": left_east,
        "east": counts[east],
        "north": counts[north],
        "crossed_after": crossed,
        "in_corridor": len(in_corridor),
        "stranded_were_in_room": stranded == in_room and len(stranded) > 0,
        "stranded_after": stranded_after,
    }


if __name__ == "__main__":
    r = main()
    print(f"door closed at {r['closed_at']:.2f} s: {r['east']} left east, {r['north']} north")
