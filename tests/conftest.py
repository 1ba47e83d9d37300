"""Shared pytest setup: loopback addresses for simulated controllers, the opt-in hardware tier."""

from __future__ import annotations

import itertools
import os
from collections.abc import Callable, Iterator
from typing import Any

import pytest
from hypothesis import settings

from mocks.ur_controller import SimulatedController
from tests.audit_schema import invalid_records

# ur_rtde's ports are fixed (30004, 29999, 30003), so every simulated controller gets its own
# loopback address. 127.0.0.1 is left to the demo and to people running the mock by hand.
# Hypothesis's 200 ms deadline per example fails property tests when this shared machine is busy;
# the properties, not their speed, are what these tests check (speed is in benchmarks/).
settings.register_profile("shared-machine", deadline=None)
settings.load_profile("shared-machine")

# ur_rtde's watchdog window in tests: 0.2 s (the production default) trips spuriously when this
# shared 2-core machine deschedules the simulated controller for longer than that; the test of
# the watchdog itself sets 0.2 s.
TEST_WATCHDOG_S = 1.0



def _worker_hosts() -> range:
    """This process's share of 127.0.0.2-254: pytest-xdist's workers (PYTEST_XDIST_WORKER
    gwN of PYTEST_XDIST_WORKER_COUNT) each cycle through their own addresses."""
    worker = os.environ.get("PYTEST_XDIST_WORKER", "gw0")
    count = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
    index = int(worker.removeprefix("gw")) if worker.startswith("gw") else 0
    share = 253 // max(count, 1)
    return range(2 + index * share, 2 + (index + 1) * share)


_HOSTS: Iterator[str] = (f"127.0.0.{n}" for n in itertools.cycle(_worker_hosts()))


def next_loopback_host() -> str:
    """A loopback address no other test in this run is using right now."""
    return next(_HOSTS)


@pytest.fixture
def loopback_host() -> str:
    """A fresh 127.0.0.N address for one simulated controller."""
    return next_loopback_host()


def start_sim_controller(**kwargs: Any) -> SimulatedController:
    """Start a SimulatedController (kwargs as its constructor's) on a free loopback address.

    Another test session on this machine may hold an address (its ports are busy): move on."""
    for _ in range(20):
        ctl = SimulatedController(host=next_loopback_host(), **kwargs)
        try:
            return ctl.start()
        except OSError:
            continue
    raise RuntimeError("no free 127.0.0.N address for a simulated controller after 20 tries")


@pytest.fixture
def sim_controller() -> Iterator[Callable[..., SimulatedController]]:
    """Factory: `sim_controller(**kwargs)` starts a SimulatedController on a fresh loopback
    address (`ctl.host`) and stops it at teardown. kwargs are SimulatedController's."""
    started: list[SimulatedController] = []

    def start(**kwargs: Any) -> SimulatedController:
        ctl = start_sim_controller(**kwargs)
        started.append(ctl)
        return ctl

    yield start
    for ctl in started:
        ctl.stop()


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


@pytest.fixture(scope="session", autouse=True)
def every_audit_record_matches_the_schema(
    tmp_path_factory: pytest.TempPathFactory,
) -> Iterator[None]:
    """After the whole run: every audit record handeye-pick wrote under the run's temporary
    folders is valid against docs/audit.schema.json (an error here names file, line, problem)."""
    yield
    problems = invalid_records(tmp_path_factory.getbasetemp())
    assert not problems, "audit records not valid against docs/audit.schema.json:\n" + "\n".join(
        problems[:20]
    )
