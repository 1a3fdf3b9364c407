"""Calibrates a pedestrian model's default parameters against the Juelich experiments.

usage: python examples/python/calibrate.py MODEL OUT.csv [--full] [--dask]

MODEL is ``cfsm`` or ``social_force``. Every combination of the grid below runs the ``exp-*``
cases of ``throng validate`` (and RiMEA 4, the fundamental diagram against Weidmann's, and the
``bottleneck`` case) through ``throng.sweep``, one row per case and parameter set, written to
OUT.csv; the parameter sets are then ranked by the checks they pass over all the cases (the
validation's own criteria: a bin within 15% of the experiment's, a RiMEA criterion), ties
broken by the mean over the ``exp-*`` cases of the mean absolute relative error per bin, and
the best ten printed. The count comes first because the mean is ruled by the worst case: a set
that misses one experiment by 300% and meets the others is a better default than one that
misses all of them by 50%. ``--full`` runs the cases at their full size (default: ``quick``);
``--dask`` maps the runs over a ``dask.distributed.LocalCluster`` of one worker per core. One
parameter set per model, not per case: that is what a default is.
"""

from __future__ import annotations

import itertools
import sys

import throng

CASES = [
    "exp-unidirectional",
    "exp-bidirectional",
    "exp-single-file",
    "exp-t-junction",
    "exp-bottleneck-width",
    "rimea-04",
    "bottleneck",
]

GRIDS = {
    # The time gap at the reference speed (0: as given for every desired speed) and the width
    # of the path kept clear ahead; the grid of the defaults' calibration (docs/VALIDATION.md).
    "cfsm": {
        "cfsm.time_gap": [0.6, 0.8, 0.9, 1.0],
        "cfsm.reference_speed": [0.0, 1.13],
        "cfsm.path_width": [0.7, 0.8, 1.0],
    },
    # The agents' repulsion: its strength (N, on 80 kg), range and anisotropy, from the 2000
    # paper's strong, short repulsion towards the soft, long one of Johansson, Helbing and
    # Shukla's fit to video tracks (0.42 m/s^2, that is 34 N, over 1.65 m, lambda 0.12).
    "social_force": {
        "social_force.a": [40.0, 80.0, 160.0, 2000.0],
        "social_force.b": [0.2, 0.4, 0.8],
        "social_force.lambda": [0.1, 0.3],
    },
}


def main() -> None:
    args = [a for a in sys.argv[1:] if not a.startswith("--")]
    if len(args) != 2 or args[0] not in GRIDS:
        sys.exit(__doc__)
    model, out = args
    grid = GRIDS[model]
    quick = "--full" not in sys.argv
    sets = [dict(zip(grid, values)) for values in itertools.product(*grid.values())]
    # The speed model's pressed time gap may not exceed its time gap.
    sets = [
        s
        for s in sets
        if s.get("cfsm.pressed_time_gap", 0) <= s.get("cfsm.time_gap", 1e9)
    ]
    runs = [
        {
            "validate": case,
            "quick": quick,
            "model": model,
            **{f"pedestrian.{k}": v for k, v in s.items()},
        }
        for s in sets
        for case in CASES
    ]
    client = None
    if "--dask" in sys.argv:
        from dask.distributed import Client, LocalCluster

        client = Client(LocalCluster(threads_per_worker=1, processes=True))
    df = throng.sweep(runs, client=client)
    df.to_csv(out, index=False)
    keys = [f"pedestrian.{k}" for k in grid]
    exp = df[df["validate"].str.startswith("exp-")]
    errors = exp.groupby(keys).agg(
        mean_error=("mean_abs_error", "mean"),
        worst=("max_abs_error", "max"),
    )
    checks = df.groupby(keys).agg(
        checks_passed=("checks_passed", "sum"),
        checks=("checks", "sum"),
        cases_passed=("pass", "sum"),
    )
    rimea = df[df["validate"] == "rimea-04"].set_index(keys)["pass"].rename("rimea_04")
    ranked = checks.join(errors).join(rimea).sort_values(
        ["checks_passed", "mean_error"], ascending=[False, True]
    )
    print(ranked.head(10).to_string())


if __name__ == "__main__":
    main()
