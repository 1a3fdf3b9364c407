#!/usr/bin/env python3
"""The cost of Python: `world.step(n=100)` on the 100k flock against `throng bench` for the same
steps, alternated in one run, and `positions()` at 1,000,000 agents.

    python python/benches/overhead.py [--bin target/release/throng] [--rounds 3]

Both sides build the same world (`flock`, seed 1, 2 threads), run 10 untimed steps, then time
100: the CLI's figure is its `ms_per_step.mean` (step time summed over the steps), Python's the
wall-clock time of one `step(n=100)` call divided by 100, so it includes everything Python adds.
"""

import argparse
import json
import statistics
import subprocess
import time

import numpy as np

import throng


def cli_mean_ms(binary, agents, steps, threads):
    out = subprocess.run(
        [binary, "bench", "flock", "--agents", str(agents), "--steps", str(steps),
         "--warmup", "10", "--threads", str(threads), "--json"],
        check=True, capture_output=True, text=True,
    ).stdout
    return json.loads(out)["ms_per_step"]["mean"]


def python_mean_ms(agents, steps, threads):
    world = throng.World.from_scenario("flock", agents=agents, threads=threads)
    world.step(n=10)
    t = time.perf_counter()
    world.step(n=steps)
    return (time.perf_counter() - t) * 1e3 / steps


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--bin", default="target/release/throng")
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--agents", type=int, default=100_000)
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--big", type=int, default=1_000_000, help="agents for positions()")
    a = p.parse_args()

    cli, py = [], []
    for _ in range(a.rounds):
        cli.append(cli_mean_ms(a.bin, a.agents, 100, a.threads))
        py.append(python_mean_ms(a.agents, 100, a.threads))
    print(f"step, {a.agents} agents, {a.threads} threads, ms/step per round")
    print("  CLI    " + "  ".join(f"{x:7.3f}" for x in cli) + f"   median {statistics.median(cli):.3f}")
    print("  Python " + "  ".join(f"{x:7.3f}" for x in py) + f"   median {statistics.median(py):.3f}")
    print(f"  Python / CLI (medians): {statistics.median(py) / statistics.median(cli):.3f}")

    world = throng.World.from_scenario("flock", agents=a.big, threads=a.threads)
    world.step()
    out = np.empty((len(world), 2), dtype=np.float32)

    def timed(f, n=30):
        f()
        ts = []
        for _ in range(n):
            t = time.perf_counter()
            f()
            ts.append((time.perf_counter() - t) * 1e3)
        return statistics.median(ts), min(ts)

    fresh = timed(lambda: world.positions())
    filled = timed(lambda: world.positions(out=out))
    by_id = timed(lambda: world.positions(order="id"))
    print(f"positions(), {len(world)} agents, ms (median, min over 30 calls)")
    print(f"  fresh array     {fresh[0]:6.2f}  {fresh[1]:6.2f}")
    print(f"  out= array      {filled[0]:6.2f}  {filled[1]:6.2f}")
    print(f"  order='id'      {by_id[0]:6.2f}  {by_id[1]:6.2f}")


if __name__ == "__main__":
    main()
