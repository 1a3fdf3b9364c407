#!/usr/bin/env python3
"""A flocking-parameter sweep on a Dask cluster: how ordered does a flock get as the weight of
Reynolds' alignment grows?

Each run steps the built-in `flock` scenario (boids on a torus at constant density) from a
random start and reports its polarisation, the Vicsek order parameter |mean unit velocity|
(0: headings at random, 1: all agents fly the same way). The runs are mapped over the cluster's
workers by `throng.sweep`; the script draws the polarisation against the alignment weight, one
dot per seed and the mean over seeds, into a PNG.

    python examples/python/sweep.py sweep.png                              # a 2-worker LocalCluster
    python examples/python/sweep.py sweep.png --scheduler tcp://HOST:8786  # an existing cluster

With `--scheduler` the script connects to a running scheduler instead of starting a local
cluster (start one with `dask scheduler` and `dask worker tcp://HOST:8786` on each machine,
with `dask-ssh`, or with `dask-jobqueue` on a batch system); every worker needs `throng`
installed. The numbers are the same wherever the runs go.
"""

import argparse
import sys

WEIGHT = "groups.boids.steering.behaviours.alignment.weight"


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("png", help="where to write the plot")
    parser.add_argument("--scheduler", help="address of a running Dask scheduler")
    parser.add_argument("--workers", type=int, default=2, help="LocalCluster workers (default 2)")
    parser.add_argument("--agents", type=int, default=1000)
    parser.add_argument("--steps", type=int, default=300)
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument(
        "--weights", default="0,0.125,0.25,0.5,1,2,4", help="alignment weights, comma-separated"
    )
    args = parser.parse_args(argv)

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from dask.distributed import Client, LocalCluster

    import throng

    weights = [float(w) for w in args.weights.split(",")]
    runs = [
        {"scenario": "flock", "agents": args.agents, "seed": seed, "steps": args.steps, WEIGHT: w}
        for w in weights
        for seed in range(1, args.seeds + 1)
    ]

    if args.scheduler:
        client = Client(args.scheduler)
        cluster = None
    else:
        cluster = LocalCluster(
            n_workers=args.workers, threads_per_worker=1, dashboard_address=None
        )
        client = Client(cluster)
    try:
        print(f"{len(runs)} runs on {client}", file=sys.stderr)
        df = throng.sweep(runs, client=client, timings=True)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()

    summary = df.groupby(WEIGHT)["polarisation"].agg(["mean", "std", "min", "max"])
    print(summary.rename_axis("alignment weight").to_string(float_format="%.3f"))
    print(f"median run time {df['time_run_s'].median():.2f} s on {df['time_threads'].iloc[0]} "
          f"thread(s) per run", file=sys.stderr)

    fig, ax = plt.subplots(figsize=(6, 4), dpi=120)
    ax.scatter(df[WEIGHT], df["polarisation"], s=14, alpha=0.5, label="one seed")
    ax.plot(summary.index, summary["mean"], marker="o", label=f"mean of {args.seeds} seeds")
    ax.set_xscale("symlog", linthresh=min([w for w in weights if w > 0], default=1.0))
    ax.set_xticks(weights)
    ax.set_xticklabels([f"{w:g}" for w in weights])
    ax.minorticks_off()
    ax.set_xlabel("alignment weight (separation 1.5, cohesion 0.8)")
    ax.set_ylabel("polarisation |<v/|v|>|")
    ax.set_ylim(0, 1)
    ax.set_title(f"flock, {args.agents} agents, after {args.steps} steps")
    ax.legend(loc="upper left")
    fig.tight_layout()
    fig.savefig(args.png)
    print(f"wrote {args.png}", file=sys.stderr)


if __name__ == "__main__":
    main()
