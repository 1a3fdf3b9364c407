"""Hostile values that once killed the interpreter or slipped past the library's ceilings."""

import numpy as np
import pytest

from throng import ThrongError, World


@pytest.mark.parametrize(
    "call",
    [
        lambda w: w.set_targets([0], [[1e20, 0.0]]),
        lambda w: w.add_wall((0.0, 0.0), (1e20, 0.0)),
        lambda w: w.add_circle((1e20, 0.0), 1.0),
        lambda w: w.add_gravity_point((1e20, 0.0), 1.0, 5.0),
        lambda w: w.set_gravity_position(w.add_gravity_point((0.0, 0.0), 1.0, 5.0), (0.0, -1e20)),
        lambda w: w.set_group_params(
            0, {"steering": {"behaviours": [{"kind": "seek", "target": {"point": [1e20, 0]}}]}}
        ),
    ],
)
def test_coordinates_beyond_the_ceiling_are_refused(call):
    w = World.from_scenario("flock", agents=10)
    with pytest.raises(ThrongError, match="1e18"):
        call(w)
    w.step()
    assert np.isfinite(w.positions()).all()

