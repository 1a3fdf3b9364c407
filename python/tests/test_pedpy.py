"""PedPy reads the CLI's trajectory formats: `--trajectories FILE.txt` (PedPy's text format) and
`FILE.sqlite` (JuPedSim's SQLite, version 2) load with PedPy's own loaders, hold the same frames
and positions, and give PedPy's classic density and speed in a measurement area that match the
scenario: 30 pedestrians walking east at 1.3 m/s through a 4 x 6 m area."""

import math
import sqlite3
import subprocess

import numpy as np
import pytest

pedpy = pytest.importorskip(
    "pedpy", reason="PedPy is not installed (python/requirements-test.txt has it for Python >= 3.11)"
)

SPEED = 1.3
DT = 0.05
EVERY = 2
STEPS = 200

# Six rows of five pedestrians, 1 m apart in a 30 x 6 m corridor, each walking to a point 20 m
# east of its start (too far to reach in the 10 s run, so none slows down).
SCENARIO = f"""
name = "walk-east"
description = "Thirty pedestrians walk east along a corridor at {SPEED} m/s."
seed = 3
dt = {DT}
steps = {STEPS}

[world]
kind = "bounded"
size = [30, 6]

[[groups]]
name = "walkers"
count = 30
spawn = {{ kind = "grid", origin = [1, 0.5], spacing = [1, 1], columns = 5 }}
goal = {{ kind = "offset", by = [20, 0] }}
model = "kinematic"
max_speed = {SPEED}
steering = {{ behaviours = [{{ kind = "arrive", target = "own", target_radius = 0, slow_radius = 0.5, time_to_target = 0.1 }}] }}
"""

AREA = pedpy.MeasurementArea([(8, 0), (12, 0), (12, 6), (8, 6)])


def run(throng_bin, scenario, out):
    done = subprocess.run(
        [str(throng_bin), "run", str(scenario), "--every", str(EVERY), "--quiet",
         "--trajectories", str(out)],
        capture_output=True, text=True,
    )
    assert done.returncode == 0, done.stderr
    assert out.is_file()


@pytest.fixture(scope="module")
def loaded(throng_bin, tmp_path_factory):
    tmp = tmp_path_factory.mktemp("pedpy")
    scenario = tmp / "walk.toml"
    scenario.write_text(SCENARIO)
    txt, db = tmp / "walk.txt", tmp / "walk.sqlite"
    run(throng_bin, scenario, txt)
    run(throng_bin, scenario, db)
    return {
        "txt": pedpy.load_trajectory_from_txt(trajectory_file=txt),
        "sqlite": pedpy.load_trajectory_from_jupedsim_sqlite(trajectory_file=db),
        "db": db,
    }


def test_both_formats_hold_the_same_frames_and_positions(loaded):
    txt, db = loaded["txt"], loaded["sqlite"]
    assert txt.frame_rate == db.frame_rate == pytest.approx(1 / (DT * EVERY))
    a = txt.data.sort_values(["frame", "id"]).reset_index(drop=True)
    b = db.data.sort_values(["frame", "id"]).reset_index(drop=True)
    frames = STEPS // EVERY + 1
    assert a.frame.nunique() == b.frame.nunique() == frames
    assert len(a) == len(b) == 30 * frames
    np.testing.assert_array_equal(a.frame.to_numpy(), b.frame.to_numpy())
    np.testing.assert_array_equal(a.id.to_numpy(), b.id.to_numpy())
    # The text holds each float32 in its shortest decimal form, the database its exact value:
    # as float32 they are the same numbers.
    for c in ["x", "y"]:
        np.testing.assert_array_equal(
            a[c].to_numpy(np.float32), b[c].to_numpy(np.float32), err_msg=c
        )


@pytest.mark.parametrize("fmt", ["txt", "sqlite"])
def test_classic_density_and_speed_in_a_measurement_area(loaded, fmt):
    traj = loaded[fmt]
    density = pedpy.compute_classic_density(traj_data=traj, measurement_area=AREA)
    assert (density.density >= 0).all()
    # The block of 5 x 6 pedestrians (one per square metre) crosses the 24 m^2 area: at its
    # fullest the area holds 4 or 5 columns of 6, about 1 person/m^2.
    peak = density.density.max()
    assert 24 / 24 <= peak <= 30 / 24, peak
    occupied = density[density.density > 0]
    assert len(occupied) > 0.3 * len(density)

    speed = pedpy.compute_individual_speed(
        traj_data=traj, frame_step=5, speed_calculation=pedpy.SpeedCalculation.BORDER_SINGLE_SIDED
    )
    assert np.isfinite(speed.speed).all()
    assert speed.speed.to_numpy() == pytest.approx(SPEED, rel=1e-3)
    mean = pedpy.compute_mean_speed_per_frame(
        traj_data=traj, individual_speed=speed, measurement_area=AREA
    )
    # PedPy reports 0 for frames with nobody in the area.
    inside = mean.index.isin(occupied.index)
    assert inside.sum() == len(occupied)
    assert mean.speed[inside].to_numpy() == pytest.approx(SPEED, rel=1e-3)
    assert (mean.speed[~inside] == 0).all()
    # Time runs as frame / frame rate: the front reaches x = 8 after (8 - 5) / 1.3 s.
    first = occupied.index.min() / traj.frame_rate
    assert first == pytest.approx((8 - 5) / SPEED, abs=2 / traj.frame_rate)


def test_the_walkable_area_is_the_corridor(loaded):
    area = pedpy.load_walkable_area_from_jupedsim_sqlite(trajectory_file=loaded["db"])
    assert math.isclose(area.polygon.area, 30 * 6)
    assert area.polygon.bounds == (0, 0, 30, 6)
    assert AREA.polygon.within(area.polygon)
    with sqlite3.connect(loaded["db"]) as con:
        (version,) = con.execute("SELECT value FROM metadata WHERE key = 'version'").fetchone()
    assert version == "2"


# A crowd spread at random over a 30 x 6 m corridor walking east through a line at x = 15,
# with the Voronoi density measured in a 4 x 6 m area: throng's measurements of the same
# trajectories against PedPy's.
CROWD = f"""
name = "crowd-east"
description = "Sixty pedestrians spread at random walk east through a line and an area."
seed = 5
dt = {DT}
steps = {STEPS}

[world]
kind = "bounded"
size = [30, 6]

[measurements]
voronoi = true
lines = [{{ name = "gate", from = [15, 0], to = [15, 6] }}]
areas = [{{ name = "area", polygon = [[8, 0], [12, 0], [12, 6], [8, 6]] }}]

[[groups]]
name = "walkers"
count = 60
spawn = {{ kind = "spread", min = [0.5, 0.5], max = [12, 5.5], distance = 0.5 }}
goal = {{ kind = "offset", by = [40, 0] }}
model = "kinematic"
max_speed = {SPEED}
radius = 0.2
steering = {{ behaviours = [{{ kind = "seek", target = "own" }}] }}
pedestrian = {{}}
"""


@pytest.fixture(scope="module")
def crowd(throng_bin, tmp_path_factory):
    tmp = tmp_path_factory.mktemp("crowd")
    scenario = tmp / "crowd.toml"
    scenario.write_text(CROWD)
    txt, csv = tmp / "crowd.txt", tmp / "crowd.csv"
    # One step more than the bench below: PedPy's movements end one frame before a trajectory's
    # last (a crossing into the last frame is not one of its crossings), so that it sees every
    # step the bench measures.
    done = subprocess.run(
        [str(throng_bin), "run", str(scenario), "--steps", str(STEPS + 1), "--every", "1",
         "--quiet", "--trajectories", str(txt), "--measurements", str(csv)],
        capture_output=True, text=True,
    )
    assert done.returncode == 0, done.stderr
    bench = subprocess.run(
        [str(throng_bin), "bench", str(scenario), "--steps", str(STEPS), "--warmup", "0",
         "--json"],
        capture_output=True, text=True,
    )
    assert bench.returncode == 0, bench.stderr
    import json
    report = json.loads(bench.stdout.strip().splitlines()[-1])
    return {
        "traj": pedpy.load_trajectory_from_txt(trajectory_file=txt),
        "csv": np.genfromtxt(csv, delimiter=",", names=True),
        "report": report,
    }


def test_voronoi_density_equals_pedpys(crowd):
    traj, rows = crowd["traj"], crowd["csv"]
    walkable = pedpy.WalkableArea([(0, 0), (30, 0), (30, 6), (0, 6)])
    area = pedpy.MeasurementArea([(8, 0), (12, 0), (12, 6), (8, 6)])
    cells = pedpy.compute_individual_voronoi_polygons(traj_data=traj, walkable_area=walkable)
    density, _ = pedpy.compute_voronoi_density(
        individual_voronoi_data=cells, measurement_area=area
    )
    theirs = density.density.reindex(rows["frame"].astype(int), fill_value=0.0).to_numpy()
    ours = rows["area_voronoi_density"]
    assert np.isfinite(ours).all()
    assert ours.max() > 0.5
    np.testing.assert_allclose(ours, theirs, rtol=1e-4, atol=1e-6)


def test_the_n_t_flow_equals_pedpys(crowd):
    traj = crowd["traj"]
    gate = pedpy.MeasurementLine([(15, 0), (15, 6)])
    nt, crossing = pedpy.compute_n_t(traj_data=traj, measurement_line=gate)
    line = next(l for l in crowd["report"]["measurements"]["lines"] if l["name"] == "gate")
    n = int(nt.cumulative_pedestrians.max())
    assert n > 20
    assert line["nt_count"] == n
    # PedPy counts whole frames; throng interpolates the crossing inside its frame: the first
    # and last crossings move by at most one frame each.
    first = nt[nt.cumulative_pedestrians > 0].time.min()
    last = nt[nt.cumulative_pedestrians == n].time.min()
    theirs = (n - 1) / (last - first)
    frame = 1 / traj.frame_rate
    assert line["nt_flow"] == pytest.approx(theirs, rel=2 * frame / (last - first) + 1e-9)
