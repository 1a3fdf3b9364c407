"""Simulation.record: trajectories written as the simulation goes by the library's writers (the
CLI's), complete once close() has finished them, and read by PedPy: the bottleneck of
examples/python/bottleneck_wkt.py recorded as JuPedSim SQLite, PedPy text and CSV, with PedPy's
N-t flow at the door equal to throng's own. Bad paths raise ThrongError and leave nothing
behind."""

import gc
import sqlite3
from pathlib import Path

import numpy as np
import pytest

import throng

ROOM = "POLYGON ((0 0, 10 0, 10 4.5, 14 4.5, 14 5.5, 10 5.5, 10 10, 0 10, 0 0))"
EXIT = "POLYGON ((13 4.5, 14 4.5, 14 5.5, 13 5.5, 13 4.5))"
DT = 0.01
EVERY = 5
AGENTS = 100


def bottleneck(seed=1):
    """The example's bottleneck: 100 pedestrians leave a 10 x 10 m room through a 1 m door and a
    corridor 4 m long to an exit at its end."""
    sim = throng.Simulation(geometry=ROOM, model="cfsm", dt=DT, seed=seed)
    exit_ = sim.add_exit_stage(EXIT)
    journey = sim.add_journey(throng.Journey([exit_]))
    positions = [(1.0 + 0.8 * (k % 10), 1.0 + 0.8 * (k // 10)) for k in range(AGENTS)]
    sim.add_agents(positions, journey=journey)
    return sim, exit_


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("record")
    files = {"sqlite": tmp / "run.sqlite", "txt": tmp / "run.txt", "csv": tmp / "run.csv"}
    sim, exit_ = bottleneck()
    sim.record(files["sqlite"], every=EVERY)
    sim.record(str(files["txt"]), every=EVERY)
    sim.record(files["csv"], every=EVERY)
    # throng's own departure times: the simulated time of the step each agent left in.
    departures, left = [], 0
    while sim.agent_count() > 0 and sim.elapsed_time() < 300:
        sim.iterate(1)
        now = sim.exit_counts()[exit_]
        departures += [sim.elapsed_time()] * (now - left)
        left = now
    assert all(not p.exists() for p in files.values()), "written before close()"
    sim.close()
    sim.close()
    assert sorted(p.name for p in tmp.iterdir()) == ["run.csv", "run.sqlite", "run.txt"]
    return {
        "files": files,
        "departures": departures,
        "steps": sim.iteration_count(),
        "walkable": sim.walkable_area(),
    }


def test_the_recording_holds_every_written_frame(recorded):
    assert len(recorded["departures"]) == AGENTS
    frames = recorded["steps"] // EVERY + 1
    db = sqlite3.connect(recorded["files"]["sqlite"])
    meta = dict(db.execute("SELECT key, value FROM metadata"))
    assert meta["version"] == "2" and float(meta["fps"]) == pytest.approx(1 / (DT * EVERY))
    # The bounds are the walkable area's, not the box around the agents.
    assert [float(meta[k]) for k in ("xmin", "xmax", "ymin", "ymax")] == [0, 14, 0, 10]
    assert db.execute("SELECT COUNT(*) FROM frame_data").fetchone() == (frames,)
    assert db.execute("SELECT MIN(frame), MAX(frame) FROM frame_data").fetchone() == (0, frames - 1)
    assert db.execute("SELECT COUNT(*) FROM trajectory_data WHERE frame = 0").fetchone() == (AGENTS,)
    db.close()
    csv = np.loadtxt(recorded["files"]["csv"], delimiter=",", skiprows=1)
    assert csv.shape[1] == 9
    assert np.array_equal(np.unique(csv[:, 0]) % EVERY, np.zeros(frames_with_agents(recorded)))


def frames_with_agents(recorded):
    """The written frames that hold a row: every one but the last when the run ended on a
    written frame, since the last step left nobody (a frame of nobody has no rows in the CSV
    and text formats; the database's frame table still lists it)."""
    frames = recorded["steps"] // EVERY + 1
    return frames - (1 if recorded["steps"] % EVERY == 0 else 0)


def test_pedpy_reads_the_database_with_its_walkable_area_and_the_text_file(recorded):
    pedpy = pytest.importorskip(
        "pedpy", reason="PedPy is not installed (python/requirements-test.txt has it for Python >= 3.11)"
    )
    shapely = pytest.importorskip("shapely")
    db, txt = recorded["files"]["sqlite"], recorded["files"]["txt"]
    traj = pedpy.load_trajectory_from_jupedsim_sqlite(trajectory_file=db)
    area = pedpy.load_walkable_area_from_jupedsim_sqlite(trajectory_file=db)
    assert area.polygon.equals(shapely.from_wkt(recorded["walkable"]))
    assert area.polygon.area == pytest.approx(104.0)
    text = pedpy.load_trajectory_from_txt(trajectory_file=txt)
    assert text.frame_rate == traj.frame_rate == pytest.approx(1 / (DT * EVERY))
    a = traj.data.sort_values(["frame", "id"]).reset_index(drop=True)
    b = text.data.sort_values(["frame", "id"]).reset_index(drop=True)
    assert len(a) == len(b) and a.frame.nunique() == frames_with_agents(recorded)
    assert (a.frame.values == b.frame.values).all() and (a.id.values == b.id.values).all()
    assert np.allclose(a.x, b.x, atol=1e-5) and np.allclose(a.y, b.y, atol=1e-5)


def test_pedpy_n_t_flow_at_the_exit_equals_throngs_own_within_two_percent(recorded):
    pedpy = pytest.importorskip(
        "pedpy", reason="PedPy is not installed (python/requirements-test.txt has it for Python >= 3.11)"
    )
    traj = pedpy.load_trajectory_from_jupedsim_sqlite(trajectory_file=recorded["files"]["sqlite"])
    # Across the corridor, 0.5 m before the exit polygon: everyone crosses it on the way out.
    line = pedpy.MeasurementLine([(12.5, 4.5), (12.5, 5.5)])
    n_t, crossings = pedpy.compute_n_t(traj_data=traj, measurement_line=line)
    departures = recorded["departures"]
    assert len(crossings) == n_t.cumulative_pedestrians.max() == len(departures) == AGENTS
    span = (crossings.frame.max() - crossings.frame.min()) / traj.frame_rate
    pedpy_flow = len(crossings) / span
    throng_flow = len(departures) / (departures[-1] - departures[0])
    assert pedpy_flow == pytest.approx(throng_flow, rel=0.02), (pedpy_flow, throng_flow)


def test_garbage_collection_finishes_a_recording_that_was_not_closed(tmp_path):
    sim, _ = bottleneck()
    path = tmp_path / "gc.sqlite"
    sim.record(path, every=10)
    sim.iterate(100)
    assert not path.exists()
    del sim
    gc.collect()
    db = sqlite3.connect(path)
    assert db.execute("SELECT COUNT(*) FROM frame_data").fetchone() == (11,)
    indexes = db.execute("SELECT name FROM sqlite_master WHERE type = 'index'").fetchall()
    assert ("frame_id_idx",) in indexes
    db.close()


def test_a_simulation_records_again_after_close(tmp_path):
    sim, _ = bottleneck()
    first, second = tmp_path / "a.txt", tmp_path / "b.txt"
    sim.record(first)
    sim.iterate(3)
    sim.close()
    sim.record(second, every=2)
    sim.iterate(4)
    sim.close()

    def frames(p):
        return {row.split("\t")[1] for row in p.read_text().splitlines() if not row.startswith("#")}

    assert frames(first) == {"0", "1", "2", "3"}
    assert frames(second) == {"0", "1", "2"}


def test_bad_paths_raise_throng_error_and_leave_nothing_behind(tmp_path):
    sim, _ = bottleneck()
    bad = [
        (tmp_path, "path", "folder"),
        (tmp_path / "missing" / "run.sqlite", "path", "missing"),
        (tmp_path / "run.parquet", "path", ".parquet"),
        (tmp_path / "run.csv.gz", "path", "compress"),
    ]
    for path, parameter, words in bad:
        with pytest.raises(throng.ThrongError, match=words) as e:
            sim.record(path)
        assert e.value.parameter == parameter
    with pytest.raises(throng.ThrongError) as e:
        sim.record(tmp_path / "run.csv", every=0)
    assert e.value.parameter == "every"
    with pytest.raises(throng.ThrongError):
        sim.record(tmp_path / "run.csv", every=-1)
    sim.record(tmp_path / "run.csv")
    with pytest.raises(throng.ThrongError, match="being recorded already") as e:
        sim.record(tmp_path / "." / "run.csv")
    assert e.value.parameter == "path"
    other, _ = bottleneck()
    with pytest.raises(throng.ThrongError, match="being recorded already"):
        other.record(tmp_path / "run.csv")
    sim.iterate(2)
    sim.close()
    other.record(tmp_path / "run.csv")
    other.close()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.csv"]


def test_a_database_is_refused_on_a_device(tmp_path):
    if not Path("/dev/null").exists():
        pytest.skip("no /dev/null")
    sim, _ = bottleneck()
    link = tmp_path / "null.sqlite"
    link.symlink_to("/dev/null")
    with pytest.raises(throng.ThrongError, match="regular file") as e:
        sim.record(link)
    assert e.value.parameter == "path"
    assert Path("/dev/null").is_char_device()
