#!/usr/bin/env python3
"""A parameter sweep on a Dask cluster: the Vicsek model's order-disorder transition, or how
ordered a Reynolds flock gets as the weight of alignment grows.

Each run steps a built-in scenario from a random start and reports its polarisation, the order
parameter |mean unit velocity| (0: headings at random, 1: all agents move the same way). With
`--model vicsek` (the default) the runs sweep the `vicsek` scenario's noise from 0 to 2 pi; with
`--model flock` they sweep the alignment weight of the `flock` scenario (boids on a torus at
constant density). The runs are mapped over the cluster's workers by `throng.sweep`; the script
draws the polarisation against the parameter, one dot per seed and the mean over seeds, into a
PNG.

    python examples/python/sweep.py sweep.png                              # a 2-worker LocalCluster
    python examples/python/sweep.py sweep.png --model flock                # the alignment sweep
    python examples/python/sweep.py sweep.png --scheduler tcp://HOST:8786  # an existing cluster

With `--scheduler` the script connects to a running scheduler instead of starting a local
cluster (start one with `dask scheduler` and `dask worker tcp://HOST:8786` on each machine,
with `dask-ssh`, or with `dask-jobqueue` on a batch system); every worker needs `throng`
installed. The numbers are the same wherever the runs go.
"""

import argparse
import sys

# Per model: the scenario, the override the sweep varies, its default values, the axis label.
MODELS = {
    "vicsek": (
        "vicsek",
        "groups.particles.steering.behaviours.vicsek.noise",
        "0,0.5,1,1.5,2,2.5,3,3.5,4,5,6.283",
        "noise width (radians), 2 agents per unit area, radius 1",
    ),
    "flock": (
        "flock",
        "groups.boids.steering.behaviours.alignment.weight",
        "0,0.125,0.25,0.5,1,2,4",
        "alignment weight (separation 1.5, cohesion 0.8)",
    ),
}


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("png", help="where to write the plot")
    parser.add_argument("--scheduler", help="address of a running Dask scheduler")
    parser.add_argument("--workers", type=int, default=2, help="LocalCluster workers (default 2)")
    parser.add_argument("--agents", type=int, default=1000)
    parser.add_argument("--steps", type=int, default=300)
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--model", choices=sorted(MODELS), default="vicsek")
    parser.add_argument("--values", help="the swept values, comma-separated (default per model)")
    args = parser.parse_args(argv)
    scenario, key, default_values, label = MODELS[args.model]

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from dask.distributed import Client, LocalCluster

    import throng

    weights = [float(w) for w in (args.values or default_values).split(",")]
    runs = [
        {"scenario": scenario, "agents": args.agents, "seed": seed, "steps": args.steps, key: w}
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

    summary = df.groupby(key)["polarisation"].agg(["mean", "std", "min", "max"])
    print(summary.rename_axis(key.rsplit(".", 1)[-1]).to_string(float_format="%.3f"))
    print(f"median run time {df['time_run_s'].median():.2f} s on {df['time_threads'].iloc[0]} "
          f"thread(s) per run", file=sys.stderr)

    fig, ax = plt.subplots(figsize=(6, 4), dpi=120)
    ax.scatter(df[key], df["polarisation"], s=14, alpha=0.5, label="one seed")
    ax.plot(summary.index, summary["mean"], marker="o", label=f"mean of {args.seeds} seeds")
    if args.model == "flock":
        ax.set_xscale("symlog", linthresh=min([w for w in weights if w > 0], default=1.0))
        ax.set_xticks(weights)
        ax.set_xticklabels([f"{w:g}" for w in weights])
        ax.minorticks_off()
    ax.set_xlabel(label)
    ax.set_ylabel("polarisation |<v/|v|>|")
    ax.set_ylim(0, 1)
    ax.set_title(f"{scenario}, {args.agents} agents, after {args.steps} steps")
    ax.legend(loc="upper right" if args.model == "vicsek" else "upper left")
    fig.tight_layout()
    fig.savefig(args.png)
    print(f"wrote {args.png}", file=sys.stderr)


if __name__ == "__main__":
    main()
