"""Shared pytest setup: loopback addresses for simulated controllers, the opt-in hardware tier."""

from __future__ import annotations

import itertools
from collections.abc import Iterator

import pytest

# ur_rtde's ports are fixed (30004, 29999, 30003), so every simulated controller gets its own
# loopback address. 127.0.0.1 is left to the demo and to people running the mock by hand.
_HOSTS: Iterator[str] = (f"127.0.0.{n}" for n in itertools.cycle(range(2, 255)))


def next_loopback_host() -> str:
    """A loopback address no other test in this run is using right now."""
    return next(_HOSTS)


@pytest.fixture
def loopback_host() -> str:
    """A fresh 127.0.0.N address for one simulated controller."""
    return next_loopback_host()


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption(
        "--robot-host",
        default=None,
        help="address of a real UR controller; enables tests marked 'hardware' (they move it)",
    )


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    if config.getoption("--robot-host"):
        return
    skip = pytest.mark.skip(reason="needs a real robot: pass --robot-host")
    for item in items:
        if "hardware" in item.keywords:
            item.add_marker(skip)
