"""Memory stays flat over thousands of steps of a 10,000-agent world driven from Python."""

import numpy as np

import throng


def rss_mb():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * 4096 / 2**20


def test_rss_is_flat_over_10000_steps_with_array_reads():
    world = throng.World.from_scenario("flock", agents=10000, seed=1)
    out = np.empty((10000, 2), dtype=np.float32)

    def drive(calls):
        for _ in range(calls):
            world.step(n=20)
            world.positions(out=out)
            world.velocities()
            world.ids(order="id")
            world.trajectories(0)

    drive(20)  # 400 steps: buffers and allocator pools at their working size
    before = rss_mb()
    drive(500)  # 10,000 more: 2,000 arrays of 10,000 rows made and dropped
    after = rss_mb()
    assert world.frame == 10400
    assert after - before < 4.0, (before, after)
