"""``status`` and the program the controller runs (issue 30, item 2): a session ends its own
control script when it closes, and ``status`` tells an operator's program from ur_rtde's script
and says who holds the cell, so it never sends the operator to the pendant for nothing
(docs/field-experience.md, "A control script left playing").

The CLI in a subprocess, the real ur_rtde, the simulated UR; a pendant program is the
simulator's dashboard ``play`` of the loaded program, which ignores ur_rtde's registers.
"""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

from handeye_pick.cell.session import Cell
from handeye_pick.robot.port import RuntimeState
from handeye_pick.robot.ur.arm import URRtdeArm
from mocks.ur_controller import SimulatedController
from tests.integration.test_operator_cli import _dashboard, cli_json
from tests.integration.test_pick_cli import DEMO, TCP_OFFSET, run_json, write_config

SimFactory = Callable[..., SimulatedController]
WATCHDOG_S = 2.0
"""The longest window a config allows: a script left by a session would still be playing when
``status`` looks, had the session not ended it."""
PENDANT_ADVICE = "a pick would stop it; stop it on the pendant, or let it finish"


def test_status_is_ready_right_after_each_of_several_picks(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    config = write_config(tmp_path, ctl.host, watchdog_s=str(WATCHDOG_S))
    # Every pick plans from the home pose the demo detection was seen from, wherever the arm is.
    pose = [repr(v) for v in ctl.snapshot().flange_pose]
    detection = str(DEMO / "detection.yaml")
    for attempt in range(3):
        pick_status, pick = run_json(config, "--detection", detection, "--capture-pose-ur", *pose)
        assert (pick_status, pick["status"]) == (0, "picked"), (attempt, pick)
        status, report = cli_json("status", "--config", str(config))
        assert (status, report["ready"], report["problems"]) == (0, True, []), (attempt, report)
        # the pick ended its own script as it closed: nothing is left for the watchdog
        assert report["runtime_state"] == "STOPPED", (attempt, report)
        assert report["notes"] == [], (attempt, report)
    assert [c["kind"] for c in ctl.commands].count("moveL") == 9  # three picks, three moves each


def test_a_pendant_program_is_not_ready_with_the_pendant_advice(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    assert _dashboard(ctl.host, "load /programs/pick.urp", "play") == [
        "Loading program: /programs/pick.urp",
        "Starting program",
    ]
    status, report = cli_json("status", "--config", str(write_config(tmp_path, ctl.host)))
    assert status == 3, report
    assert report["program_state"] == "PLAYING pick.urp"
    assert report["problems"] == [
        f"a program is running on the controller (PLAYING pick.urp): {PENDANT_ADVICE}"
    ]
    assert report["notes"] == []
    assert _dashboard(ctl.host, "programState") == ["PLAYING pick.urp"]  # left as found


def test_a_session_holding_the_cell_is_named_and_the_pendant_is_not(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    config = write_config(tmp_path, ctl.host)
    with Cell(config) as cell:
        status, report = cli_json("status", "--config", str(config))
        assert cell.status().ready  # the session goes on undisturbed
    assert status == 3, report
    assert report["program_state"] == "PLAYING rtde_control"
    assert len(report["problems"]) == 1, report
    problem = report["problems"][0]
    assert problem.startswith(f"cell {ctl.host} is in use by process {os.getpid()} ("), problem
    assert problem.endswith(
        "stop that session (or let it finish) before a pick; nothing to do on the pendant"
    )
    assert report["notes"] == []


def test_a_control_script_left_without_a_client_is_ready_with_a_note(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    # Another ur_rtde program that uploads its script, sets no watchdog and leaves without
    # stopping it: the script plays on with no client.
    leave = "import os, sys, rtde_control; rtde_control.RTDEControlInterface(sys.argv[1]); "
    leave += "os._exit(0)"
    subprocess.run([sys.executable, "-c", leave, ctl.host], check=True, timeout=60)
    config = write_config(tmp_path, ctl.host)
    status, report = cli_json("status", "--config", str(config))
    assert (status, report["program_state"], report["problems"]) == (
        0,
        "PLAYING rtde_control",
        [],
    ), report
    assert report["notes"] == [
        "ur_rtde's control script is running (PLAYING rtde_control) with no client left (a "
        "session that ended without stopping it, or another ur_rtde program): a pick will "
        "replace it"
    ]
    pick_status, pick = run_json(config, "--detection", str(DEMO / "detection.yaml"))
    assert (pick_status, pick["status"]) == (0, "picked"), pick  # and so it does


def test_a_closing_session_ends_its_own_script_and_no_other_program(
    sim_controller: SimFactory,
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    with URRtdeArm(ctl.host, watchdog_s=WATCHDOG_S):
        assert ctl.snapshot().runtime_state == RuntimeState.PLAYING
    assert ctl.snapshot().runtime_state == RuntimeState.STOPPED  # ended at close, not starved
    # The operator stops the session's script and plays a pendant program under it: the close
    # sends its stop through the command register, which that program does not read, and the
    # wait for the stop ends with the call's bound.
    with URRtdeArm(ctl.host, watchdog_s=WATCHDOG_S, call_timeout_s=3.0):
        assert _dashboard(ctl.host, "stop", "load /programs/pick.urp", "play")[-1] == (
            "Starting program"
        )
    assert _dashboard(ctl.host, "programState") == ["PLAYING pick.urp"]
