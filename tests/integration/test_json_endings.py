"""``--json`` on every ending: the real CLI in a subprocess, against the simulated UR where one
is needed. Whatever ends the run (a refusal before connecting, a fault, SIGTERM, success), stdout
is exactly one JSON report whose ``exit_status`` is the process's, and it names the ``pick_id``
of records on disk, or says why none was written (docs/commands.md, "--json: one report on
every ending").
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import time
from pathlib import Path
from typing import Any

import pytest

from handeye_pick.cell.lock import CellLock
from tests.integration.test_pick_cli import (
    CLI,
    DEMO,
    ROOT,
    TCP_OFFSET,
    SimFactory,
    audit_records,
    write_config,
)

DETECTION = ("--detection", str(DEMO / "detection.yaml"))


def cli_json(*args: str) -> tuple[subprocess.CompletedProcess[str], dict[str, Any]]:
    """``handeye-pick ARGS --json`` from the repository root, and its one report."""
    result = subprocess.run(
        [*CLI, *args, "--json"],
        cwd=ROOT,
        stdin=subprocess.DEVNULL,
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    return result, one_report(result.stdout, result.returncode, args[0])


def one_report(stdout: str, exit_status: int, command: str) -> dict[str, Any]:
    """The report, checked for what every report holds: one JSON object (``json.loads`` takes
    nothing more), the command, the process's exit status, and a pick id or why there is
    none."""
    report: dict[str, Any] = json.loads(stdout)
    assert (report["command"], report["exit_status"]) == (command, exit_status), report
    assert ("pick_id" in report) != ("audit_record" in report), report
    if "pick_id" not in report:
        assert report["audit_record"].startswith("none written: "), report
    return report


def pick_ids_on_disk(tmp_path: Path) -> set[str]:
    return {record["pick_id"] for record in audit_records(tmp_path)}


# --- refused before connecting: nothing sent, no audit record -----------------------------------


@pytest.mark.parametrize(
    ("command", "point"),
    [("pick", ("--xyz", "35", "-20", "384")), ("touch-test", ("--xyz", "35", "-20", "384"))],
)
def test_a_cell_in_use_is_refused_with_a_report(
    tmp_path: Path, loopback_host: str, command: str, point: tuple[str, ...]
) -> None:
    config = write_config(tmp_path, loopback_host)
    lock = CellLock(loopback_host)  # the lock a running session holds
    lock.acquire()
    try:
        result, report = cli_json(command, "--config", str(config), *point)
    finally:
        lock.release()
    assert result.returncode == 3, result.stderr
    (line,) = result.stderr.strip().splitlines()  # still one line for a person
    assert f"in use by process {os.getpid()}" in line
    assert report["status"] == "refused"
    assert report["error_type"] == "CellInUse"
    assert "nothing was sent" in report["error"]
    assert "before any record" in report["audit_record"]
    assert audit_records(tmp_path) == []


def test_a_config_refused_before_connecting_is_reported(
    tmp_path: Path, loopback_host: str
) -> None:
    config = write_config(tmp_path, loopback_host)
    config.write_text(config.read_text() + "colour: blue\n")
    result, report = cli_json("pick", "--config", str(config), *DETECTION)
    assert result.returncode == 2, result.stderr
    assert (report["status"], report["error_type"]) == ("bad-input", "ConfigError")
    assert "colour" in report["error"]
    assert audit_records(tmp_path) == []


def test_a_detection_refused_before_connecting_is_reported(
    tmp_path: Path, loopback_host: str
) -> None:
    detection = tmp_path / "detection.yaml"
    detection.write_text("position_mm: [1, 2]\n")
    config = write_config(tmp_path, loopback_host)
    result, report = cli_json("pick", "--config", str(config), "--detection", str(detection))
    assert result.returncode == 2, result.stderr
    assert (report["status"], report["error_type"]) == ("bad-input", "DetectionError")
    assert "position_mm" in report["error"]
    assert report["host"] == loopback_host  # what the run knew before it was refused
    assert audit_records(tmp_path) == []


@pytest.mark.parametrize(
    "args",
    [
        ("pick", "--config", "cell.yaml", "--xyz", "1", "2"),  # --xyz takes three numbers
        ("status", "--config", "cell.yaml", "--no-such-flag"),
        ("convert", "--from", "ur", "--to", "quaternion", "0", "0", "0", "0", "0", "0"),
    ],
)
def test_flags_argparse_refuses_are_reported(args: tuple[str, ...]) -> None:
    result, report = cli_json(*args)
    assert result.returncode == 2, result.stderr
    assert (report["status"], report["error_type"]) == ("bad-input", "InputError")
    assert report["error"].startswith("handeye-pick")


def test_an_audit_file_that_cannot_take_a_record_is_reported(
    tmp_path: Path, loopback_host: str
) -> None:
    # /dev/full takes no write and no fsync: the audit check refuses before connecting.
    config = write_config(tmp_path, loopback_host, audit="  file: /dev/full\n")
    result, report = cli_json("pick", "--config", str(config), *DETECTION)
    assert result.returncode == 2, result.stderr
    assert (report["status"], report["error_type"]) == ("bad-input", "AuditError")
    assert report["audit_record"] == "none written: the audit file cannot take a record (see error)"


# --- connecting and after: the pick id of the records on disk ------------------------------------


def test_an_unreachable_host_is_reported_with_its_connect_record(
    tmp_path: Path, loopback_host: str
) -> None:
    # Nothing listens there: the failed connect is audited, so the report names its record.
    config = write_config(tmp_path, loopback_host)
    result, report = cli_json("pick", "--config", str(config), *DETECTION)
    assert result.returncode == 4, result.stderr
    assert (report["status"], report["error_type"]) == ("fault", "RobotConnectionError")
    (outcome,) = audit_records(tmp_path)
    assert (outcome["step"], outcome["pick_id"]) == ("connect", report["pick_id"])


def test_a_pick_reports_the_pick_id_of_its_records(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    result, report = cli_json("pick", "--config", str(write_config(tmp_path, ctl.host)), *DETECTION)
    assert result.returncode == 0, result.stderr
    assert report["status"] == "picked"
    assert pick_ids_on_disk(tmp_path) == {report["pick_id"]}


def test_a_preflight_refusal_after_connecting_names_its_records(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    # 1.5 m below the camera is out of a UR5e's reach; the box allows it: the controller's
    # checks refuse, nothing moves, and the refusal is an audited outcome.
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    box = "  min_mm: [-3000, -3000, -3000]\n  max_mm: [3000, 3000, 3000]\n  max_tilt_deg: 30\n"
    config = write_config(tmp_path, ctl.host, workspace=box)
    result, report = cli_json("pick", "--config", str(config), "--xyz", "0", "0", "1500")
    assert result.returncode == 3, result.stderr
    assert report["status"] == "refused"
    assert [check for check in report["checks"] if not check["passed"]]
    assert audit_records(tmp_path)[-1]["pick_id"] == report["pick_id"]


def test_a_fault_mid_pick_names_its_records(sim_controller: SimFactory, tmp_path: Path) -> None:
    ctl = sim_controller(
        tcp_offset=TCP_OFFSET, speed_factor=4.0, inject=("protective-stop@move:2:0.5",)
    )
    result, report = cli_json("pick", "--config", str(write_config(tmp_path, ctl.host)), *DETECTION)
    assert result.returncode == 4, result.stderr
    assert (report["status"], report["error_type"]) == ("fault", "RobotFault")
    assert "protective stop" in report["error"]
    plan, outcome = audit_records(tmp_path)
    assert plan["pick_id"] == outcome["pick_id"] == report["pick_id"]
    assert report["targets"] == plan["targets"]  # the plan as far as the pick got


def test_sigterm_mid_move_reports_once_after_the_outcome(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, speed_factor=0.2)
    config = write_config(tmp_path, ctl.host)
    pick = subprocess.Popen(
        [*CLI, "pick", "--config", str(config), *DETECTION, "--json"],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        deadline = time.monotonic() + 30.0
        while not ctl.snapshot().moving:  # the approach is on its way
            assert time.monotonic() < deadline, "the pick never moved"
            time.sleep(0.01)
        pick.send_signal(signal.SIGTERM)
        out, err = pick.communicate(timeout=30)
    finally:
        if pick.poll() is None:
            pick.kill()
    assert pick.returncode == 143, err
    report = one_report(out, 143, "pick")
    assert (report["status"], report["error"]) == ("interrupted", "terminated (SIGTERM)")
    _, outcome = audit_records(tmp_path)
    assert (outcome["status"], outcome["pick_id"]) == ("interrupted", report["pick_id"])
    assert not ctl.snapshot().moving


def test_a_reader_that_closes_the_pipe_gets_no_traceback(tmp_path: Path) -> None:
    """``handeye-pick report --json | head -c 1``: the reader has what it wanted; the command
    ends with its own status and nothing but its own lines on stderr."""
    audit = tmp_path / "audit.jsonl"
    audit.write_text("")
    process = subprocess.Popen(
        [*CLI, "report", str(audit), "--json"],
        cwd=ROOT,
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert process.stdout is not None
    assert process.stderr is not None
    process.stdout.close()  # before the report is written: every write to it fails
    stderr = process.stderr.read()
    assert process.wait(timeout=60) == 0, stderr
    assert "Traceback" not in stderr, stderr
    assert "BrokenPipe" not in stderr, stderr
