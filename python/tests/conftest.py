"""Shared fixtures: the CLI binary the parity tests compare against, and a scratch directory."""

import os
import pathlib

import pytest

REPO = pathlib.Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def throng_bin():
    """The `throng` binary: $THRONG_BIN (which must exist), else target/release/throng
    (`cargo build --release`); the parity tests skip when neither is there."""
    given = os.environ.get("THRONG_BIN")
    if given:
        path = pathlib.Path(given)
        assert path.is_file(), f"THRONG_BIN={given} does not exist"
        return path
    target = pathlib.Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target"))
    path = target / "release" / "throng"
    if not path.is_file():
        pytest.skip("no throng binary: run `cargo build --release` or set THRONG_BIN")
    return path
