"""Faults injected into a running simulator from the command line (admin channel), and the
simulator runnable from a clone: mocks/ is not installed with the package, so
``python -m mocks.ur_controller`` runs from the repository root, or elsewhere with the root on
PYTHONPATH."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

from mocks.ur_controller import SimulatedController
from mocks.ur_controller.controller import Controller
from mocks.ur_controller.options import ControllerOptions
from tests.conftest import next_loopback_host

ROOT = Path(__file__).resolve().parents[2]


def run_module(*args: str, cwd: Path = ROOT, pythonpath: Path | None = None,
               ) -> subprocess.CompletedProcess[str]:
    """`python -m mocks.ur_controller ARGS` from `cwd` (the repository root by default), with
    `pythonpath` as the only PYTHONPATH."""
    env = {key: value for key, value in os.environ.items() if key != "PYTHONPATH"}
    if pythonpath is not None:
        env["PYTHONPATH"] = str(pythonpath)
    return subprocess.run([sys.executable, "-m", "mocks.ur_controller", *args], cwd=cwd,
                          env=env, capture_output=True, text=True, timeout=60, check=False)


def test_inject_from_the_command_line_reaches_a_running_controller(
    sim_controller: Callable[..., SimulatedController],
) -> None:
    ctl = sim_controller(instant=True)
    done = run_module("inject", "--host", ctl.host, "protective-stop")
    assert (done.returncode, done.stderr) == (0, "")
    assert ctl.snapshot().safety_mode == 3


def test_inject_a_timed_fault_for_a_later_move(
    sim_controller: Callable[..., SimulatedController],
) -> None:
    ctl = sim_controller(instant=True)
    assert run_module("inject", "--host", ctl.host, "stop-program@move:1:0.5").returncode == 0
    assert ctl.snapshot().safety_mode == 1  # not yet: it waits for the first move


def test_inject_refuses_a_bad_fault_and_says_why(
    sim_controller: Callable[..., SimulatedController],
) -> None:
    ctl = sim_controller(instant=True)
    done = run_module("inject", "--host", ctl.host, "explode")
    assert done.returncode == 2
    assert "explode" in done.stderr
    assert len(done.stderr.splitlines()) == 1


def test_inject_without_a_controller_fails_clearly() -> None:
    done = run_module("inject", "--host", next_loopback_host(), "protective-stop")
    assert done.returncode == 3
    assert "no simulated controller answers" in done.stderr


def test_a_controller_never_offers_the_admin_channel_off_loopback() -> None:
    ctl = Controller(ControllerOptions(host="10.1.2.3", allow_non_loopback=True))  # never started
    assert ctl.ports == {"rtde": 30004, "dashboard": 29999, "script": 30003, "robotiq": 63352}


def test_help_runs_from_the_clone_root_or_with_it_on_the_path(tmp_path: Path) -> None:
    for done in (run_module("--help"), run_module("--help", cwd=tmp_path, pythonpath=ROOT)):
        assert done.returncode == 0, done.stderr
        assert "--profile" in done.stdout


def test_the_simulators_are_not_installed_with_the_package(tmp_path: Path) -> None:
    # Elsewhere, without the clone on the path, no "mocks" comes from the installed project.
    done = run_module("--help", cwd=tmp_path)
    assert done.returncode == 1
    assert "No module named 'mocks'" in done.stderr


@pytest.mark.parametrize("argument", ["--profile", "--model"])
def test_bad_choices_are_refused(argument: str) -> None:
    done = run_module("--host", next_loopback_host(), argument, "nonsense")
    assert done.returncode == 2


@pytest.mark.parametrize(("arguments", "message"), [
    (["--profile", "cb3", "--model", "ur5e"], "for the cb3 profile"),
    (["--tracking", "--instant"], "tracking needs real-time motion"),
    (["--feedback-input", "16", "40"], "feedback_input"),
    (["--part-width-mm", "90"], "part width"),
])
def test_inconsistent_options_are_refused_in_one_line(arguments: list[str], message: str,
                                                     ) -> None:
    done = run_module("--host", next_loopback_host(), *arguments)
    assert done.returncode == 2
    assert message in done.stderr
    assert len(done.stderr.splitlines()) == 1
