"""Draws docs/validation/*.png from the JSON of `throng validate --json` (see
scripts/validation-plots)."""
import json
import math
import pathlib
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

out = pathlib.Path(sys.argv[1])
MODELS = {"cfsm": "throng, collision-free speed model", "social_force": "throng, social force model"}
# JuPedSim 1.4.2 (default CFSM), measured on the same machine kind with ../shared/peers/jupedsim.
PEER_BOTTLENECK = [(0.8, 0.93), (1.0, 1.02), (1.2, 1.10), (1.6, 1.17), (2.0, 1.12), (2.5, 1.11)]
PEER_FD_RATIO = [(0.5, 1.03), (1.0, 0.94), (2.0, 0.67), (3.0, 0.64)]


def weidmann(rho):
    return max(0.0, 1.34 * (1 - math.exp(-1.913 * (1 / rho - 1 / 5.4))))


def series(doc, case, name):
    for c in doc["cases"]:
        if c["id"] == case:
            for s in c["series"]:
                if s["name"] == name:
                    return s["points"]
    return []


docs = {m: json.loads((out / f"results-{m}.json").read_text()) for m in MODELS}

fig, ax = plt.subplots(figsize=(6.4, 4.2))
rho = [0.2 + 0.01 * k for k in range(520)]
ax.plot(rho, [weidmann(r) for r in rho], "k-", label="Weidmann (1993)")
ax.fill_between(rho, [0.85 * weidmann(r) for r in rho], [1.15 * weidmann(r) for r in rho],
                color="0.85", label="Weidmann +- 15%")
ax.plot([r for r, _ in PEER_FD_RATIO], [q * weidmann(r) for r, q in PEER_FD_RATIO], "s--",
        color="tab:gray", label="JuPedSim 1.4.2, CFSM")
for m, label in MODELS.items():
    pts = series(docs[m], "rimea-04", "fundamental diagram")
    ax.plot([p[0] for p in pts], [p[1] for p in pts], "o-", label=label)
ax.set_xlabel("density (persons/m$^2$)")
ax.set_ylabel("speed (m/s)")
ax.set_xlim(0, 5.5)
ax.set_ylim(0, 1.6)
ax.set_title("Fundamental diagram: corridor 4 m wide, area 10 x 4 m, t 10-30 s")
ax.legend(fontsize=8)
fig.tight_layout()
fig.savefig(out / "fundamental-diagram.png", dpi=110)

fig, ax = plt.subplots(figsize=(6.4, 4.2))
ax.axhspan(1.5, 2.1, color="0.88", label="criterion 1.5-2.1 (experiments about 1.6-2.0)")
ax.plot([b for b, _ in PEER_BOTTLENECK], [j for _, j in PEER_BOTTLENECK], "s--",
        color="tab:gray", label="JuPedSim 1.4.2, CFSM")
for m, label in MODELS.items():
    pts = series(docs[m], "bottleneck", "bottleneck")
    ax.plot([p[0] for p in pts], [p[1] for p in pts], "o-", label=label)
ax.set_xlabel("bottleneck width b (m)")
ax.set_ylabel("specific flow J/b (persons/(m s))")
ax.set_ylim(0, 4)
ax.set_title("Bottleneck: 200 pedestrians, room 10 x 10 m, corridor 4 m long")
ax.legend(fontsize=8)
fig.tight_layout()
fig.savefig(out / "bottleneck.png", dpi=110)
print(f"wrote {out}/fundamental-diagram.png and {out}/bottleneck.png")
