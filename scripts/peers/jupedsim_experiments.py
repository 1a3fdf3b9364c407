"""JuPedSim 1.4.2 on set-ups that reproduce published Juelich pedestrian experiments.

usage:
    python jupedsim_experiments.py CASE --model cfsm|sfm [--quick] [--out DIR]
                                   [--json-out FILE] [--summary FILE]

CASE is one of unidirectional, single-file, bidirectional, t-junction, bottleneck-width, all.
Needs jupedsim 1.4.2, pedpy 1.5.1 and shapely (a venv: python3 -m venv /tmp/peers/pyenv &&
/tmp/peers/pyenv/bin/pip install jupedsim==1.4.2 pedpy==1.5.1). Each case prints one JSON object
on its own stdout line (with CASE all: five lines, in the order above); progress goes to stderr.
--out DIR holds the trajectory files (default /tmp/peers/jupedsim-out/experiments).
--json-out FILE writes all results to FILE; if FILE already holds results written by this script,
entries for other (case, model, quick) combinations are kept and the invocation log is appended,
so one file can collect both models. --summary FILE then writes a markdown summary of everything
in the JSON file (one table per case, the wall-clock time and the command lines).

What is compared
----------------
For each case the script simulates a set of runs, measures them the way the experiments were
measured (Voronoi method), and bins the measured samples by Voronoi density. The experiment data
are the files in ../shared/experiments/ beside the repository (EXPERIMENTS_DIR moves it;
copied from JuPedSim's old validation suite; see its
README). `reference_bins(case)` bins the experiment rows the same way. Every bin [lo, hi) carries
the experiment's mean speed and row count, the simulation's mean Voronoi speed and sample count,
and the relative error (sim - exp) / exp, which is null when either side has fewer than 5 samples.
Samples outside the bin range are not counted (the number left out is reported).

Common settings (all cases)
---------------------------
* time step dt = 0.01 s; random seed 1 (for the random placements).
* Every agent has the case's desired speed (FREE_SPEED: the experiment's mean speed in its lowest
  density bin; 1.34 m/s in the bottleneck), fixed, no spread, and radius 0.2 m (0.18 m in
  single-file).
* Models: `cfsm` = jps.CollisionFreeSpeedModel() with its defaults (neighbour repulsion strength 8,
  range 0.1 m; wall repulsion strength 5, range 0.02 m) and agent time_gap 1 s (its default);
  `sfm` = jps.SocialForceModel() with its defaults (body force k = 120000 kg/s^2, friction
  kappa = 240000 kg/(m s)) and the defaults of jps.SocialForceModelAgentParameters (mass 80 kg,
  reaction time tau 0.5 s, agent and obstacle scale A = 2000 N, force distance B = 0.08 m), except
  desired speed and radius as above. Initial velocity and orientation are the defaults, (0, 0).
* Walls are the boundary of the walkable polygon. Agents follow a journey with a single exit stage
  (an area; an agent is removed when it reaches it); JuPedSim's own navigation mesh routing steers
  them there (this matters only in the T-junction).
* Trajectories are written every 10th step (10 frames per second) with jps.SqliteTrajectoryWriter
  (closed after the run) and read back with PedPy 1.5.1.
* 2D measurement (PedPy): individual Voronoi cells from compute_individual_voronoi_polygons
  (walkable area = the simulation geometry, no cut-off), Voronoi density per frame from
  compute_voronoi_density in the measurement area, Voronoi speed per frame from
  compute_voronoi_speed using individual speeds from compute_individual_speed(frame_step=5,
  i.e. positions 0.5 s before and after, speed_calculation=BORDER_SINGLE_SIDED), speed magnitude
  (no movement direction). Classic density (persons in the area / its size) and classic speed
  (mean individual speed of those persons) are computed too and reported alongside.
  To save time, the Voronoi cells of the two straight corridors (unidirectional and bidirectional)
  are computed only for agents within 10 m (along x) of the measurement area; cells of agents
  farther away cannot reach the area unless a gap of more than 10 m opens in the crowd.
  The trajectory is cut to the measurement window plus 1 s on either side before the speeds are
  computed, so the 0.5 s speed window is always full inside the measurement window.
* Samples: every trajectory frame (10 per second) in the measurement window [t0, t1] in which at
  least one agent stands inside the measurement area; one sample = (Voronoi density, Voronoi
  speed, classic density, classic speed) of that frame. The runs of one case are pooled.
  A bin's simulated value is the mean Voronoi speed of its samples.
* The simulation of a fundamental-diagram case runs until t1 + 1 s (not until the geometry is
  empty); the number of agents still inside is reported. A run that raises an error is recorded
  with its error message; its samples are used only if the simulation got past t1 (or all
  agents left the geometry before t1 without an error; the later frames are then simply empty).

1. unidirectional (experiment: unidirectional flow in a 1.8 m wide corridor, ug-180-*)
   Corridor x 0..200 m, y 0..1.8 m. At t = 0 the strip x 0..90 holds a crowd of nominal density
   RHO in {0.3, 0.6, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0} /m^2 (quick: 0.6, 1.5, 2.5, 3.5).
   RHO <= 3: jps.distribute_by_density (minimum centre distance 0.41 m, 0.21 m from the walls).
   RHO > 3: a triangular lattice: rows along x whose centres are 0.21 m from the walls and at least
   0.42 m apart (4 rows in 1.8 m, 0.46 m apart), neighbouring rows shifted by half the spacing
   along x, the spacing chosen so that the strip holds round(RHO * 90 * 1.8) agents, positions
   jittered by up to 5 mm (seeded); the first agent of a row is 0.25 m from x = 0. If random
   placement fails at RHO <= 3 the lattice is used instead and this is recorded.
   Everyone walks to an exit stage x 199..200. Measurement area x 45..51 (6 m, full width),
   window t 10..30 s (the crowd's rear needs more than 30 s to pass x = 45 at 1.34 m/s). Bins
   0.5 /m^2 wide from 0 to 5. Reference: all files in unidirectional/ pooled (density, speed).

2. single-file (experiment: single-file movement, n14 ... n70)
   Corridor x 0..200 m, y 0..0.6 m, radius 0.18 m. Agents on the line y = 0.3 at
   x = 0.2 + k / RHO (k = 0, 1, ... while x <= 90), RHO at the centre of each bin from 0.375 to
   2.625 /m, quick or full. All walk to an exit stage x 199..200.
   One-dimensional Voronoi measurement in x 45..47 (2 m), window t 10..30 s, computed by this
   script from the trajectories: in each frame the agents are sorted by x; an agent's 1D cell
   runs from the midpoint to the agent behind to the midpoint to the agent ahead; the rearmost and
   the foremost agent get a cell whose missing half has the width of its other half. Density =
   sum over agents of |cell n [45, 47]| / |cell| / 2 m; speed = sum over agents of
   |cell n [45, 47]| * v_x / 2 m, with v_x the x component of PedPy's individual velocity
   (frame_step 5, BORDER_SINGLE_SIDED). Classic values: agents with 45 <= x <= 47, their number
   / 2 m and their mean v_x. Samples: frames with at least one agent in 45 <= x <= 47. Bins
   0.25 /m wide from 0 to 3.25. Reference: all files in single-file/ pooled (density in 1/m,
   speed; n28.dat has no header line).

3. bidirectional (experiment: bidirectional flow in a 3.6 m wide corridor, bot-360-*)
   Corridor x 0..100 m, y 0..3.6 m. Crowd placed at random as in case 1 in x 20..80 at RHO in
   {0.5, 1.0, 1.5, 2.0, 2.5, 3.0} /m^2 (quick: 1.0, 2.0). Agents with an even placement index
   (0, 2, 4, ... in the order distribute_by_density returns them) walk to an exit stage at
   x 99..100, those with an odd index to one at x 0..1. Measurement area x 47..53 (6 m, full
   width), window t 5..20 s, speed magnitude. Bins 0.5 /m^2 wide from 0 to 5. Reference:
   all files in bidirectional/ pooled. (The experiment had its own inflow and outflow openings;
   here the two streams start mixed at random, so lanes must form during the run.)

4. t-junction (experiment: merging in a T-junction with 2.4 m wide corridors, ko-240-*-240)
   Walkable area = the union of the main corridor x -30..29, y -2.4..0 and the branch
   x -2.4..0, y 0..8; exit stage y 7..8 across the branch. Two crowds, random as in case 1, at
   RHO in {1.0, 2.0, 3.0} /m^2 (quick: 2.0) in the arms x -30..-9 and x 8..29 (full width).
   Everyone's only stage is the exit; the route through the junction comes from JuPedSim's
   navigation-mesh routing (shortest path; no waypoint is used). Measurement areas (2 m x 2.4 m):
   left x -4.5..-2.5, y -2.4..0; right x 1..3, y -2.4..0; front x -2.4..0, y 1..3. Window
   t 10..50 s. Bins 0.5 /m^2 wide from 0 to 5. References: front = t-junction/ko-*_id_1.dat
   pooled; arms = ko-*_id_2 and ko-*_id_3 pooled (left and right simulated samples are pooled
   the same way; a frame counts once per area in which an agent stands).

5. bottleneck-width (experiments: flow through bottlenecks of width b, 2006Kretz, 2009Seyfried,
   2006EG)
   Room 10 m x 10 m (x, y 0..10) with, on its right wall, an exit corridor of width B (centred at
   y = 5) and 4 m length (x 10..14); exit stage in its last 0.5 m (x 13.5..14). 200 agents placed
   with jps.distribute_by_number in the room (minimum centre distance 0.45 m, 0.25 m from the
   walls, seed 1), all walking to the exit; runs until the geometry is empty or 200 s simulated.
   B in {0.8, 0.9, 1.0, 1.1, 1.2, 1.6, 2.0, 2.5} m (quick: 1.0, 1.6). PedPy compute_n_t on the
   line x = 10 (the bottleneck entrance) gives each agent's first crossing; J = (i1 - i0) /
   (t[i1] - t[i0]) with i0 = floor(0.2 n), i1 = ceil(0.8 n) - 1 over the sorted crossing times
   (the middle 60% of the crossings); J is left null when the simulation raised an error (for
   example an agent pushed out of the walkable area), and a run still holding agents after 200 s
   is recorded as an error, its J computed from the crossings up to then (null with fewer than
   10 crossings). Reference per width: the mean of all experiment values at
   exactly that width from bottleneck-kretz/2006Kretz.txt, bottleneck-other/2009Seyfried.txt and
   bottleneck-other/2006EG.txt (tab-separated width, flow; CRLF), pooled row by row; null where
   none has that width. Relative error of J per width, null without a reference. (The
   experiments' own geometries, bottleneck lengths and participant numbers differ from this
   room; only the width is matched.)
"""
import argparse
import datetime
import json
import math
import os
import pathlib
import random
import shlex
import sys
import time
import traceback

EXP_DIR = pathlib.Path(
    os.environ.get(
        "EXPERIMENTS_DIR",
        pathlib.Path(__file__).resolve().parents[3] / "shared" / "experiments",
    )
)
DT = 0.01
V0 = 1.34
# Desired speed per case: the experiment's mean speed in its lowest density bin (the
# participants' free speed), as throng's exp-* cases set it; Weidmann's 1.34 m/s for the
# bottleneck.
FREE_SPEED = {
    "unidirectional": 1.11,
    "single-file": 1.13,
    "bidirectional": 1.5,
    "t-junction": 1.23,
    "bottleneck-width": 1.34,
}
SEED = 1
EVERY = 10  # trajectory frames: every 10th step -> 10 fps
MIN_N = 5  # fewer samples than this on either side -> relative error null
CASES = ["unidirectional", "single-file", "bidirectional", "t-junction", "bottleneck-width"]


def log(*a):
    print(*a, file=sys.stderr, flush=True)


# ---------------------------------------------------------------------------------------------
# Experiment data and binning
# ---------------------------------------------------------------------------------------------

def read_pairs(path):
    """Rows of (first, second) float columns; '#' lines, blank lines and CRLF are skipped."""
    rows = []
    with open(path) as f:
        for line in f:
            s = line.strip()
            if not s or s.startswith("#"):
                continue
            parts = s.replace(",", " ").split()
            try:
                rows.append((float(parts[0]), float(parts[1])))
            except (ValueError, IndexError):
                continue
    return rows


def make_edges(lo, hi, width):
    n = int(round((hi - lo) / width))
    return [round(lo + i * width, 6) for i in range(n + 1)]


def bin_samples(samples, edges):
    """samples: (density, speed) pairs -> per bin [lo, hi): mean speed and count."""
    out = []
    for lo, hi in zip(edges[:-1], edges[1:]):
        vs = [v for d, v in samples if lo <= d < hi]
        out.append(dict(lo=lo, hi=hi, n=len(vs),
                        speed=(sum(vs) / len(vs)) if vs else None))
    return out


BIN_SPEC = {
    "unidirectional": (0.0, 5.0, 0.5),
    "single-file": (0.0, 3.25, 0.25),
    "bidirectional": (0.0, 5.0, 0.5),
    "t-junction": (0.0, 5.0, 0.5),
}

BOTTLENECK_REF_FILES = ["bottleneck-kretz/2006Kretz.txt", "bottleneck-other/2009Seyfried.txt",
                        "bottleneck-other/2006EG.txt"]


def experiment_rows(case):
    """Pooled experiment rows (density, speed) of a case; for t-junction a dict front/arms."""
    if case == "unidirectional":
        files = sorted((EXP_DIR / "unidirectional").iterdir())
    elif case == "single-file":
        files = sorted((EXP_DIR / "single-file").glob("*.dat"))
    elif case == "bidirectional":
        files = sorted((EXP_DIR / "bidirectional").glob("*.dat"))
    elif case == "t-junction":
        tj = EXP_DIR / "t-junction"
        front = [r for f in sorted(tj.glob("ko-*_id_1.dat")) for r in read_pairs(f)]
        arms = [r for pat in ("ko-*_id_2.dat", "ko-*_id_3.dat")
                for f in sorted(tj.glob(pat)) for r in read_pairs(f)]
        return {"front": front, "arms": arms}
    else:
        raise ValueError(case)
    return [r for f in files for r in read_pairs(f)]


def bottleneck_reference():
    """width -> dict(mean J, n, per-source values) from the three reference files."""
    ref = {}
    for rel in BOTTLENECK_REF_FILES:
        for b, j in read_pairs(EXP_DIR / rel):
            key = round(b, 3)
            e = ref.setdefault(key, dict(values=[], sources={}))
            e["values"].append(j)
            e["sources"].setdefault(pathlib.Path(rel).stem, []).append(j)
    return {b: dict(J=sum(e["values"]) / len(e["values"]), n=len(e["values"]),
                    sources=e["sources"]) for b, e in ref.items()}


def reference_bins(case):
    """Experiment reference of a case: per bin [lo, hi) the mean speed and row count.

    unidirectional / single-file / bidirectional: a list of bins; t-junction: a dict with the bin
    lists 'front' and 'arms'; bottleneck-width: a dict width -> mean J (and row count)."""
    if case == "bottleneck-width":
        return bottleneck_reference()
    edges = make_edges(*BIN_SPEC[case])
    rows = experiment_rows(case)
    if isinstance(rows, dict):
        return {k: bin_samples(v, edges) for k, v in rows.items()}
    return bin_samples(rows, edges)


def rel_err(sim, n_sim, exp, n_exp):
    if sim is None or exp is None or n_sim < MIN_N or n_exp < MIN_N or exp == 0:
        return None
    return (sim - exp) / exp


def compare_bins(ref_bins, samples, edges):
    """Join reference bins with simulated samples (dicts with rho_v, v_v, rho_c, v_c)."""
    out = []
    for rb, (lo, hi) in zip(ref_bins, zip(edges[:-1], edges[1:])):
        ss = [s for s in samples if lo <= s["rho_v"] < hi]
        n = len(ss)
        v = sum(s["v_v"] for s in ss) / n if n else None
        out.append(dict(
            lo=lo, hi=hi, exp_speed=r4(rb["speed"]), exp_n=rb["n"],
            jps_speed=r4(v), jps_n=n,
            jps_voronoi_density_mean=r4(sum(s["rho_v"] for s in ss) / n) if n else None,
            jps_classic_density_mean=r4(sum(s["rho_c"] for s in ss) / n) if n else None,
            jps_classic_speed_mean=r4(mean([s["v_c"] for s in ss if s["v_c"] is not None])),
            rel_err=r4(rel_err(v, n, rb["speed"], rb["n"]))))
    return out


def mean(xs):
    xs = [x for x in xs if x is not None and not (isinstance(x, float) and math.isnan(x))]
    return sum(xs) / len(xs) if xs else None


def r4(x):
    return None if x is None else round(float(x), 4)


# ---------------------------------------------------------------------------------------------
# Simulation helpers
# ---------------------------------------------------------------------------------------------

def make_model(name):
    import jupedsim as jps
    if name == "cfsm":
        return jps.CollisionFreeSpeedModel()
    if name == "sfm":
        return jps.SocialForceModel()
    raise SystemExit(f"unknown model {name} (cfsm|sfm)")


def agent_params(model, pos, journey, stage, radius):
    import jupedsim as jps
    if model == "cfsm":
        return jps.CollisionFreeSpeedModelAgentParameters(
            position=pos, journey_id=journey, stage_id=stage, desired_speed=V0, radius=radius,
            time_gap=1.0)
    return jps.SocialForceModelAgentParameters(
        position=pos, journey_id=journey, stage_id=stage, desired_speed=V0, radius=radius)


def random_positions(polygon, rho):
    import jupedsim as jps
    return jps.distribute_by_density(polygon=polygon, density=rho, distance_to_agents=0.41,
                                     distance_to_polygon=0.21, seed=SEED)


def lattice_positions(x0, x1, y0, y1, rho):
    """Triangular lattice with round(rho * area) agents, rows 0.21 m from the walls."""
    rng = random.Random(SEED)
    W, L = y1 - y0, x1 - x0
    n_target = int(round(rho * L * W))
    rows = int((W - 0.42) / 0.42) + 1
    dy = (W - 0.42) / (rows - 1)
    dx = L * rows / n_target
    if min(dx, math.hypot(dx / 2, dy)) <= 0.41:
        raise ValueError(f"lattice too dense: dx {dx:.3f} dy {dy:.3f}")
    pos = []
    for r in range(rows):
        x = x0 + (dx / 2) * (r % 2) + 0.25
        while x < x1 and len(pos) < n_target:
            pos.append((x + rng.uniform(-0.005, 0.005),
                        y0 + 0.21 + r * dy + rng.uniform(-0.005, 0.005)))
            x += dx
    return pos


def place_crowd(box, rho, lattice_above=None):
    """(positions, placement label); random up to lattice_above (if given), else lattice."""
    import shapely
    x0, y0, x1, y1 = box
    if lattice_above is not None and rho > lattice_above:
        return lattice_positions(x0, x1, y0, y1, rho), "lattice"
    try:
        return random_positions(shapely.box(x0, y0, x1, y1), rho), "random"
    except Exception as e:  # noqa: BLE001 - jupedsim raises its own error types
        if lattice_above is None:
            raise
        log(f"  random placement failed at rho {rho} ({e}); using the lattice")
        return lattice_positions(x0, x1, y0, y1, rho), f"lattice (random failed: {e})"


def simulate(model, geometry, agents, exits, traj, radius, t_end=None, tmax=None):
    """Run one simulation.

    agents: list of (position, exit index); exits: list of shapely polygons (exit stages).
    t_end: run exactly until this time; tmax: run until empty or this time.
    Returns an info dict (error, sim time, agents left, wall time)."""
    import jupedsim as jps
    traj.unlink(missing_ok=True)
    info = dict(n_agents=len(agents), traj_file=str(traj), error=None)
    writer = jps.SqliteTrajectoryWriter(output_file=traj, every_nth_frame=EVERY)
    t0 = time.perf_counter()
    sim = None
    try:
        sim = jps.Simulation(model=make_model(model), geometry=geometry, dt=DT,
                             trajectory_writer=writer)
        routes = []
        for poly in exits:
            ex = sim.add_exit_stage(poly)
            routes.append((sim.add_journey(jps.JourneyDescription([ex])), ex))
        for pos, k in agents:
            jr, st = routes[k]
            sim.add_agent(agent_params(model, pos, jr, st, radius))
        if t_end is not None:
            n_it = int(round(t_end / DT))
            while sim.iteration_count() < n_it and sim.agent_count() > 0:
                sim.iterate(min(100, n_it - sim.iteration_count()))
        else:
            max_it = int(round(tmax / DT))
            while sim.agent_count() > 0 and sim.iteration_count() < max_it:
                sim.iterate(10)
    except Exception as e:  # noqa: BLE001
        info["error"] = f"{type(e).__name__}: {e}"
        log("  ERROR", info["error"])
        log(traceback.format_exc(limit=3))
    finally:
        writer.close()  # commits the last buffered frames
    info["wall_s"] = round(time.perf_counter() - t0, 2)
    if sim is not None:
        info["sim_time_s"] = round(sim.elapsed_time(), 2)
        info["agents_left"] = sim.agent_count()
    else:
        info["sim_time_s"], info["agents_left"] = 0.0, None
    return info


# ---------------------------------------------------------------------------------------------
# Measurement
# ---------------------------------------------------------------------------------------------

def load_window(traj, t0, t1):
    """PedPy trajectory cut to the frames [t0 - 1 s, t1 + 1 s]; also the frame rate."""
    import pedpy
    td = pedpy.load_trajectory_from_jupedsim_sqlite(trajectory_file=traj)
    fr = td.frame_rate
    d = td.data
    d = d[(d.frame >= int(round(t0 * fr)) - int(fr)) & (d.frame <= int(round(t1 * fr)) + int(fr))]
    return d.copy(), fr


def measure_2d(traj, walkable, areas, t0, t1, crop_margin=None):
    """Per measurement area: list of per-frame samples in [t0, t1] with >= 1 agent in the area.

    areas: dict name -> shapely polygon. crop_margin: Voronoi only for agents whose x is within
    this margin of the area's x range (None: all agents)."""
    import numpy as np
    import pedpy
    d, fr = load_window(traj, t0, t1)
    f0, f1 = int(round(t0 * fr)), int(round(t1 * fr))
    wa = pedpy.WalkableArea(walkable)
    out = {}
    for name, poly in areas.items():
        ma = pedpy.MeasurementArea(poly)
        if crop_margin is not None:
            xa, _, xb, _ = poly.bounds
            dv = d[(d.x > xa - crop_margin) & (d.x < xb + crop_margin)]
        else:
            dv = d
        tdv = pedpy.TrajectoryData(data=dv.copy(), frame_rate=fr)
        speed = pedpy.compute_individual_speed(
            traj_data=tdv, frame_step=5,
            speed_calculation=pedpy.SpeedCalculation.BORDER_SINGLE_SIDED)
        cd = pedpy.compute_classic_density(traj_data=tdv, measurement_area=ma)
        cs = pedpy.compute_mean_speed_per_frame(traj_data=tdv, individual_speed=speed,
                                                measurement_area=ma)
        vor = pedpy.compute_individual_voronoi_polygons(traj_data=tdv, walkable_area=wa)
        vd, inter = pedpy.compute_voronoi_density(individual_voronoi_data=vor,
                                                  measurement_area=ma)
        vs = pedpy.compute_voronoi_speed(traj_data=tdv, individual_speed=speed,
                                         individual_voronoi_intersection=inter,
                                         measurement_area=ma)
        idx = lambda df: df.set_index("frame") if "frame" in df.columns else df  # noqa: E731
        cd, cs, vd, vs = idx(cd), idx(cs), idx(vd), idx(vs)
        samples = []
        for f in range(f0, f1 + 1):
            if f not in cd.index or f not in vd.index or f not in vs.index:
                continue
            rho_c = float(cd.at[f, "density"])
            if rho_c <= 0:  # nobody inside the area in this frame
                continue
            v_c = float(cs.at[f, "speed"]) if f in cs.index else None
            samples.append(dict(frame=f, rho_v=float(vd.at[f, "density"]),
                                v_v=float(vs.at[f, "speed"]), rho_c=rho_c,
                                v_c=None if v_c is None or np.isnan(v_c) else v_c))
        out[name] = samples
    return out


def measure_1d(traj, xa, xb, t0, t1):
    """1D Voronoi density and speed in [xa, xb] (see the module docstring), per frame."""
    import pedpy
    d, fr = load_window(traj, t0, t1)
    f0, f1 = int(round(t0 * fr)), int(round(t1 * fr))
    td = pedpy.TrajectoryData(data=d.copy(), frame_rate=fr)
    vel = pedpy.compute_individual_speed(
        traj_data=td, frame_step=5, compute_velocity=True,
        speed_calculation=pedpy.SpeedCalculation.BORDER_SINGLE_SIDED)
    vx = {(int(r.id), int(r.frame)): float(r.v_x) for r in vel.itertuples()}
    L = xb - xa
    samples = []
    for f, g in d[(d.frame >= f0) & (d.frame <= f1)].groupby("frame"):
        g = g.sort_values("x")
        xs, ids = g.x.to_numpy(), g.id.to_numpy()
        inside = [(xa <= x <= xb) for x in xs]
        if not any(inside):
            continue
        n = len(xs)
        rho_v = v_v = 0.0
        for i in range(n):
            if n == 1:
                continue  # a lone agent has no cell
            back = (xs[i] - xs[i - 1]) / 2 if i > 0 else (xs[i + 1] - xs[i]) / 2
            ahead = (xs[i + 1] - xs[i]) / 2 if i < n - 1 else back
            lo, hi = xs[i] - back, xs[i] + ahead
            if hi <= lo:
                continue
            ov = max(0.0, min(hi, xb) - max(lo, xa))
            if ov <= 0:
                continue
            rho_v += ov / (hi - lo) / L
            v_v += ov * vx[(int(ids[i]), int(f))] / L
        vin = [vx[(int(ids[i]), int(f))] for i in range(n) if inside[i]]
        samples.append(dict(frame=int(f), rho_v=rho_v, v_v=v_v, rho_c=len(vin) / L,
                            v_c=sum(vin) / len(vin)))
    return samples


def run_summary(samples):
    if not samples:
        return dict(samples=0)
    return dict(samples=len(samples),
                rho_voronoi=r4(mean([s["rho_v"] for s in samples])),
                v_voronoi=r4(mean([s["v_v"] for s in samples])),
                rho_classic=r4(mean([s["rho_c"] for s in samples])),
                v_classic=r4(mean([s["v_c"] for s in samples])))


# ---------------------------------------------------------------------------------------------
# Cases
# ---------------------------------------------------------------------------------------------

def fd_case(case, model, quick, out):
    """unidirectional, single-file, bidirectional, t-junction."""
    import shapely
    global V0
    V0 = FREE_SPEED[case]
    edges = make_edges(*BIN_SPEC[case])
    runs = []
    pooled = {}  # reference group -> samples
    if case == "unidirectional":
        rhos = [0.6, 1.5, 2.5, 3.5] if quick else [0.3, 0.6, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0]
        geo, radius, (t0, t1) = shapely.box(0, 0, 200, 1.8), 0.2, (10.0, 30.0)
        exits = [shapely.box(199, 0, 200, 1.8)]
        areas = {"main": shapely.box(45, 0, 51, 1.8)}
        groups = {"main": "main"}
    elif case == "single-file":
        # A line keeps its spacing: the runs sit at the bins' centres; bodies 0.36 m long.
        rhos = [0.375, 0.625, 0.875, 1.125, 1.375, 1.625, 1.875, 2.125, 2.375, 2.625]
        geo, radius, (t0, t1) = shapely.box(0, 0, 200, 0.6), 0.18, (10.0, 30.0)
        exits = [shapely.box(199, 0, 200, 0.6)]
        groups = {"main": "main"}
    elif case == "bidirectional":
        rhos = [1.0, 2.0] if quick else [0.5, 1.0, 1.5, 2.0, 2.5, 3.0]
        geo, radius, (t0, t1) = shapely.box(0, 0, 100, 3.6), 0.2, (5.0, 20.0)
        exits = [shapely.box(99, 0, 100, 3.6), shapely.box(0, 0, 1, 3.6)]
        areas = {"main": shapely.box(47, 0, 53, 3.6)}
        groups = {"main": "main"}
    elif case == "t-junction":
        rhos = [2.0] if quick else [1.0, 2.0, 3.0]
        geo = shapely.union(shapely.box(-30, -2.4, 29, 0), shapely.box(-2.4, 0, 0, 8)).normalize()
        radius, (t0, t1) = 0.2, (10.0, 50.0)
        exits = [shapely.box(-2.4, 7, 0, 8)]
        areas = {"left": shapely.box(-4.5, -2.4, -2.5, 0), "right": shapely.box(1, -2.4, 3, 0),
                 "front": shapely.box(-2.4, 1, 0, 3)}
        groups = {"left": "arms", "right": "arms", "front": "front"}
    else:
        raise ValueError(case)

    for rho in rhos:
        log(f"[{case} {model}] rho {rho}")
        run = dict(rho_nominal=rho)
        try:
            if case == "unidirectional":
                pos, placement = place_crowd((0, 0, 90, 1.8), rho, lattice_above=3.0)
                agents = [(p, 0) for p in pos]
            elif case == "single-file":
                pos, k = [], 0
                while 0.2 + k / rho <= 90 + 1e-9:
                    pos.append((0.2 + k / rho, 0.3))
                    k += 1
                placement = "line"
                agents = [(p, 0) for p in pos]
            elif case == "bidirectional":
                pos, placement = place_crowd((20, 0, 80, 3.6), rho)
                agents = [(p, i % 2) for i, p in enumerate(pos)]
            else:
                pl, pa = place_crowd((-30, -2.4, -9, 0), rho)
                pr, pb = place_crowd((8, -2.4, 29, 0), rho)
                pos, placement = pl + pr, f"{pa}/{pb}"
                agents = [(p, 0) for p in pos]
        except Exception as e:  # noqa: BLE001
            run.update(error=f"placement: {type(e).__name__}: {e}")
            log("  ERROR", run["error"])
            runs.append(run)
            continue
        run["placement"] = placement
        traj = pathlib.Path(out) / f"{case}_{model}_rho{rho:g}.sqlite"
        info = simulate(model, geo, agents, exits, traj, radius, t_end=t1 + 1.0)
        run.update(info)
        emptied = info["error"] is None and info.get("agents_left") == 0
        if info["sim_time_s"] < t1 - 1e-6 and not emptied:
            run["samples_used"] = False
            log(f"  run stopped at t = {info['sim_time_s']} s before t1 = {t1}: samples not used")
            runs.append(run)
            continue
        try:
            if case == "single-file":
                per_area = {"main": measure_1d(traj, 45.0, 47.0, t0, t1)}
            else:
                crop = 10.0 if case in ("unidirectional", "bidirectional") else None
                per_area = measure_2d(traj, geo, areas, t0, t1, crop_margin=crop)
        except Exception as e:  # noqa: BLE001
            run.update(error=(run.get("error") or "") + f" analysis: {type(e).__name__}: {e}",
                       samples_used=False)
            log("  ERROR", run["error"])
            log(traceback.format_exc(limit=4))
            runs.append(run)
            continue
        run["samples_used"] = True
        run["areas"] = {name: run_summary(s) for name, s in per_area.items()}
        for name, s in per_area.items():
            pooled.setdefault(groups[name], []).extend(s)
        log(f"  N={info['n_agents']} {placement} wall {info['wall_s']} s, "
            + "; ".join(f"{k}: {v}" for k, v in run["areas"].items()))
        runs.append(run)

    ref = reference_bins(case)
    res = dict(case=case, model=model, quick=quick, dt=DT, v0=V0, radius=radius, seed=SEED,
               window_s=[t0, t1], densities=rhos, runs=runs)
    lo, hi, _ = BIN_SPEC[case]
    if case == "t-junction":
        res["bins"] = {g: compare_bins(ref[g], pooled.get(g, []), edges) for g in ("front", "arms")}
        res["samples_outside_bins"] = {g: sum(1 for s in pooled.get(g, [])
                                              if not lo <= s["rho_v"] < hi)
                                       for g in ("front", "arms")}
    else:
        res["bins"] = compare_bins(ref, pooled.get("main", []), edges)
        res["samples_outside_bins"] = sum(1 for s in pooled.get("main", [])
                                          if not lo <= s["rho_v"] < hi)
    return res


def bottleneck_case(model, quick, out):
    import shapely
    import jupedsim as jps
    global V0
    V0 = FREE_SPEED["bottleneck-width"]
    widths = [1.0, 1.6] if quick else [0.8, 0.9, 1.0, 1.1, 1.2, 1.6, 2.0, 2.5]
    ref = bottleneck_reference()
    rows = []
    for b in widths:
        log(f"[bottleneck-width {model}] b {b}")
        y0, y1 = 5 - b / 2, 5 + b / 2
        room = shapely.box(0, 0, 10, 10)
        geo = shapely.union(room, shapely.box(10, y0, 14, y1)).normalize()
        row = dict(b=b)
        try:
            pos = jps.distribute_by_number(polygon=room, number_of_agents=200,
                                           distance_to_agents=0.45, distance_to_polygon=0.25,
                                           seed=SEED)
        except Exception as e:  # noqa: BLE001
            row.update(error=f"placement: {type(e).__name__}: {e}")
            rows.append(row)
            continue
        traj = pathlib.Path(out) / f"bottleneck_{model}_b{b:g}.sqlite"
        info = simulate(model, geo, [(p, 0) for p in pos], [shapely.box(13.5, y0, 14, y1)],
                        traj, 0.2, tmax=200.0)
        row.update(info)
        row["evac_time_s"] = info["sim_time_s"] if info.get("agents_left") == 0 else None
        if info["error"] is None and info.get("agents_left"):
            row["error"] = (f"did not empty within 200 s ({info['agents_left']} agents left); "
                            "J from the crossings up to then")
        J = None
        try:
            import pedpy
            td = pedpy.load_trajectory_from_jupedsim_sqlite(trajectory_file=traj)
            line = pedpy.MeasurementLine([(10.0, y0), (10.0, y1)])
            _, crossing = pedpy.compute_n_t(traj_data=td, measurement_line=line)
            times = sorted(crossing[pedpy.FRAME_COL].to_numpy() / td.frame_rate)
            n = len(times)
            row["crossings"] = n
            if n >= 10 and info["error"] is None:
                i0, i1 = int(math.floor(0.2 * n)), int(math.ceil(0.8 * n)) - 1
                J = (i1 - i0) / (times[i1] - times[i0])
                row.update(t_first_cross=round(times[0], 2), t_last_cross=round(times[-1], 2))
        except Exception as e:  # noqa: BLE001
            row["error"] = (row.get("error") or "") + f" analysis: {type(e).__name__}: {e}"
        r = ref.get(round(b, 3))
        row.update(J=r4(J), J_per_b=r4(J / b) if J else None,
                   exp_J=r4(r["J"]) if r else None, exp_n=r["n"] if r else 0,
                   exp_sources={k: v for k, v in r["sources"].items()} if r else {},
                   rel_err=r4((J - r["J"]) / r["J"]) if (J is not None and r) else None)
        log(f"  J={row['J']} exp={row['exp_J']} rel_err={row['rel_err']} "
            f"t_sim={info['sim_time_s']} left={info.get('agents_left')} wall {info['wall_s']} s")
        rows.append(row)
    return dict(case="bottleneck-width", model=model, quick=quick, dt=DT, v0=V0, radius=0.2,
                seed=SEED, n_agents=200, widths=rows)


# ---------------------------------------------------------------------------------------------
# Output
# ---------------------------------------------------------------------------------------------

def fmt(x, nd=3):
    return "-" if x is None else f"{x:.{nd}f}"


def fmt_err(x):
    return "-" if x is None else f"{100 * x:+.0f}%"


def j_cell(w):
    """Bottleneck table cell: J, marked when the run failed or did not empty."""
    if not w:
        return "-"
    if w.get("J") is None:
        if w.get("error", "").startswith("did not empty"):
            return f"clogged ({w.get('crossings', 0)} crossed in 200 s)"
        return "error" if w.get("error") else "-"
    if w.get("agents_left"):
        return f"{w['J']:.3f} ({w.get('crossings', 0)} crossed, not empty)"
    return f"{w['J']:.3f}"


def write_summary(doc, path):
    res = {(r["case"], r["model"], r["quick"]): r for r in doc["results"]}
    quick_flags = sorted({r["quick"] for r in doc["results"]})
    lines = ["# JuPedSim 1.4.2 against Juelich experiment data", ""]
    lines.append("Mean speed per Voronoi-density bin (m/s), samples in brackets; error = "
                 "(JuPedSim - experiment) / experiment, '-' when either side has fewer than "
                 f"{MIN_N} samples. Setups: see the docstring of "
                 "`scripts/peers/jupedsim_experiments.py`.")
    lines.append("")
    for quick in quick_flags:
        if len(quick_flags) > 1:
            lines += [f"## {'quick' if quick else 'full'} runs", ""]
        for case in CASES:
            cf, sf = res.get((case, "cfsm", quick)), res.get((case, "sfm", quick))
            if cf is None and sf is None:
                continue
            if case == "bottleneck-width":
                lines += [f"### {case} (J in 1/s)", "",
                          "| b (m) | experiment J | CFSM J | CFSM err | SFM J | SFM err |",
                          "| --- | --- | --- | --- | --- | --- |"]
                widths = {}
                for r, key in ((cf, "c"), (sf, "s")):
                    for w in (r or {}).get("widths", []):
                        widths.setdefault(w["b"], {})[key] = w
                for b in sorted(widths):
                    c, s = widths[b].get("c", {}), widths[b].get("s", {})
                    e = c or s
                    lines.append(f"| {b:g} | {fmt(e.get('exp_J'))} ({e.get('exp_n', 0)}) | "
                                 f"{j_cell(c)} | {fmt_err(c.get('rel_err'))} | "
                                 f"{j_cell(s)} | {fmt_err(s.get('rel_err'))} |")
                lines.append("")
                continue
            groups = ["front", "arms"] if case == "t-junction" else [None]
            for g in groups:
                title = case if g is None else f"{case}, {g}"
                unit = "1/m" if case == "single-file" else "1/m^2"
                lines += [f"### {title}", "",
                          f"| density bin ({unit}) | experiment | CFSM | CFSM err | SFM | SFM err |",
                          "| --- | --- | --- | --- | --- | --- |"]
                bc = (cf or {}).get("bins")
                bs = (sf or {}).get("bins")
                if g is not None:
                    bc = bc[g] if bc else None
                    bs = bs[g] if bs else None
                base = bc or bs
                for i, b in enumerate(base):
                    c = bc[i] if bc else {}
                    s = bs[i] if bs else {}
                    if not b["exp_n"] and not c.get("jps_n") and not s.get("jps_n"):
                        continue
                    lines.append(
                        f"| [{b['lo']:g}, {b['hi']:g}) | {fmt(b['exp_speed'])} ({b['exp_n']}) | "
                        f"{fmt(c.get('jps_speed'))} ({c.get('jps_n', 0)}) | "
                        f"{fmt_err(c.get('rel_err'))} | "
                        f"{fmt(s.get('jps_speed'))} ({s.get('jps_n', 0)}) | "
                        f"{fmt_err(s.get('rel_err'))} |")
                lines.append("")
            for r in (cf, sf):
                if r is None:
                    continue
                bad = [x for x in r["runs"] if x.get("error") or not x.get("samples_used", True)]
                for x in bad:
                    lines.append(f"- {r['model'].upper()} rho {x['rho_nominal']:g}: "
                                 f"{x.get('error') or 'samples not used'}")
                if bad:
                    lines.append("")
    lines += ["## Runs", ""]
    errs = []
    for r in doc["results"]:
        for x in r.get("runs", []) + r.get("widths", []):
            if x.get("error"):
                key = x.get("rho_nominal", x.get("b"))
                errs.append(f"- {r['case']} {r['model']} {key:g}: {x['error']}")
    if errs:
        lines += ["Errors:", ""] + errs + [""]
    total = sum(inv["wall_s"] for inv in doc.get("invocations", []))
    lines.append(f"Wall-clock time: {total / 60:.1f} min in total.")
    lines.append("")
    lines.append("Command lines:")
    lines.append("")
    for inv in doc.get("invocations", []):
        cmd = inv["command"]
        if inv.get("cwd"):
            cmd = f"cd {inv['cwd']} && {cmd}"
        lines.append(f"- `{cmd}` ({inv['wall_s'] / 60:.1f} min, started {inv['started']})")
    pys = sorted({inv["python"] for inv in doc.get("invocations", []) if inv.get("python")})
    if pys:
        lines += ["", "(`python` = " + ", ".join(f"`{x}`" for x in pys) + ")"]
    lines.append("")
    pathlib.Path(path).write_text("\n".join(lines))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("case", choices=CASES + ["all"])
    ap.add_argument("--model", required=True, choices=["cfsm", "sfm"])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--out", default=os.environ.get("JPS_OUT", "/tmp/peers/jupedsim-out")
                    + "/experiments")
    ap.add_argument("--json-out", default=None)
    ap.add_argument("--summary", default=None, help="markdown summary of the --json-out file")
    a = ap.parse_args()
    import jupedsim as jps
    import pedpy

    pathlib.Path(a.out).mkdir(parents=True, exist_ok=True)
    started = datetime.datetime.now().isoformat(timespec="seconds")
    t_start = time.perf_counter()
    cases = CASES if a.case == "all" else [a.case]
    results = []
    for case in cases:
        tc = time.perf_counter()
        if case == "bottleneck-width":
            r = bottleneck_case(a.model, a.quick, a.out)
        else:
            r = fd_case(case, a.model, a.quick, a.out)
        r.update(wall_s=round(time.perf_counter() - tc, 1), jupedsim=jps.__version__,
                 pedpy=pedpy.__version__)
        results.append(r)
        print(json.dumps(r), flush=True)
    inv = dict(command="python " + " ".join(shlex.quote(x) for x in sys.argv),
               started=started, wall_s=round(time.perf_counter() - t_start, 1),
               model=a.model, cases=cases, quick=a.quick, cwd=os.getcwd(),
               python=sys.executable)
    if a.json_out:
        p = pathlib.Path(a.json_out)
        p.parent.mkdir(parents=True, exist_ok=True)
        doc = dict(description="JuPedSim 1.4.2 against Juelich experiment data "
                               "(scripts/peers/jupedsim_experiments.py)",
                   invocations=[], results=[])
        if p.exists():
            try:
                old = json.loads(p.read_text())
                if isinstance(old, dict) and "results" in old:
                    doc = old
            except json.JSONDecodeError:
                pass
        new_keys = {(r["case"], r["model"], r["quick"]) for r in results}
        doc["results"] = [r for r in doc["results"]
                          if (r["case"], r["model"], r["quick"]) not in new_keys] + results
        doc["invocations"].append(inv)
        p.write_text(json.dumps(doc, indent=1))
        if a.summary:
            write_summary(doc, a.summary)
    elif a.summary:
        write_summary(dict(results=results, invocations=[inv]), a.summary)


if __name__ == "__main__":
    main()
