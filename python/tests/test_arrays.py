"""Arrays are fresh copies or fill `out=` in place; none views the world's moving buffers."""

import numpy as np
import pytest

import throng


@pytest.fixture
def world():
    w = throng.World.from_scenario("flock", agents=400, seed=4)
    w.step(n=7)  # past a reorder: storage order is no longer id order
    return w


def test_shapes_and_dtypes(world):
    n = len(world)
    assert world.positions().shape == (n, 2) and world.positions().dtype == np.float32
    assert world.velocities().shape == (n, 2) and world.velocities().dtype == np.float32
    assert world.orientations().shape == (n,) and world.orientations().dtype == np.float32
    assert world.ids().dtype == np.uint32 and world.groups().dtype == np.uint32
    assert world.arrived().dtype == np.bool_ and not world.arrived().any()
    assert world.positions().flags.c_contiguous and world.positions().flags.owndata is not None


@pytest.mark.parametrize("method,shape,dtype", [
    ("positions", (400, 2), np.float32),
    ("velocities", (400, 2), np.float32),
    ("orientations", (400,), np.float32),
    ("ids", (400,), np.uint32),
    ("groups", (400,), np.uint32),
    ("arrived", (400,), np.bool_),
])
def test_out_fills_in_place_and_returns_the_same_object(world, method, shape, dtype):
    out = np.full(shape, 7, dtype=dtype)
    address = out.__array_interface__["data"][0]
    got = getattr(world, method)(out=out)
    assert got is out
    assert out.__array_interface__["data"][0] == address
    np.testing.assert_array_equal(out, getattr(world, method)())


def test_out_may_be_a_strided_view(world):
    big = np.zeros((400, 5), dtype=np.float32)
    view = big[:, 1:3]
    assert not view.flags.c_contiguous
    assert world.positions(out=view) is view
    np.testing.assert_array_equal(big[:, 1:3], world.positions())
    assert not big[:, [0, 3, 4]].any()
    column = np.zeros((400, 2), dtype=np.float32)[:, 0]
    world.orientations(out=column)
    np.testing.assert_array_equal(column, world.orientations())


@pytest.mark.parametrize("out", [
    np.empty((400, 2), dtype=np.float64),
    np.empty((399, 2), dtype=np.float32),
    np.empty((400, 3), dtype=np.float32),
    np.empty((800,), dtype=np.float32),
    [[0.0, 0.0]] * 400,
])
def test_bad_out_raises_naming_out(world, out):
    with pytest.raises(throng.ThrongError, match="out") as e:
        world.positions(out=out)
    assert e.value.parameter == "out"


def test_read_only_out_raises(world):
    out = np.empty((400, 2), dtype=np.float32)
    out.flags.writeable = False
    with pytest.raises(throng.ThrongError, match="writeable"):
        world.positions(out=out)


def test_arrays_are_copies_that_outlive_changes(world):
    p = world.positions()
    before = p.copy()
    p[:] = -1.0  # writing to the copy leaves the world alone
    assert (world.positions() != -1.0).all()
    ids = world.add_agents(np.full((1000, 2), 3.0))
    world.step(n=5)
    world.remove_agents(ids)
    assert p.shape == (400, 2) and (p == -1.0).all()
    q = world.positions()
    assert not np.array_equal(q, before)


def test_id_order_follows_agents_across_reordering(world):
    ids = world.ids()
    assert not np.array_equal(ids, np.sort(ids))
    by_id = world.positions(order="id")
    np.testing.assert_array_equal(by_id[ids], world.positions())
    np.testing.assert_array_equal(world.ids(order="id"), np.arange(400, dtype=np.uint32))
    with pytest.raises(throng.ThrongError, match="order"):
        world.positions(order="random")
