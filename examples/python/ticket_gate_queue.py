"""A ticket gate: 30 travellers queue in 12 slots before a gate that lets one person through
every 2 s, then walk to the platform exit.

Run: python examples/python/ticket_gate_queue.py
"""

import throng

HALL = "POLYGON ((0 0, 30 0, 30 12, 0 12, 0 0))"


def main(seconds: float = 40.0) -> dict:
    sim = throng.Simulation(geometry=HALL, dt=0.01, seed=3)
    slots = [(20.0 - 0.7 * k, 6.0) for k in range(12)]
    gate = sim.add_queue_stage(slots)
    platform = sim.add_exit_stage("POLYGON ((28 4, 30 4, 30 8, 28 8, 28 4))")
    journey = throng.Journey([gate, platform])
    journey.set_transition(gate, throng.Transition.fixed(platform))
    j = sim.add_journey(journey)
    positions = [(1.0 + 1.0 * (k % 6), 2.0 + 1.5 * (k // 6)) for k in range(30)]
    sim.add_agents(positions, journey=j)
    sim.iterate(3000)  # 30 s for the queue to form
    popped = 0
    released_at = sim.elapsed_time()
    while sim.elapsed_time() - released_at < seconds:
        if sim.iteration_count() % 200 == 0 and gate.count_enqueued() > 0:
            gate.pop(1)
            popped += 1
        sim.iterate()
    sim.iterate(2000)  # 20 s for the last released to reach the platform
    return {"popped": popped, "left": sim.exit_counts()[platform], "in_queue": gate.count_enqueued()}


if __name__ == "__main__":
    r = main()
    print(f"{r['popped']} let through the gate, {r['left']} reached the platform, {r['in_queue']} queueing")
