"""``handeye-pick run`` against the simulated controller through the real ur_rtde: every request
kind and reply status, bad lines, a fault mid-cycle and resume, SIGTERM mid-move, capture-pose
latching while the arm moves between capture and pick, and the TCP listener with its token."""

from __future__ import annotations

import json
import os
import select
import signal
import socket
import subprocess
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from handeye_pick.geometry import invert, transform_point, ur_pose_to_matrix
from handeye_pick.hand_eye.files import HandEyeMode, load_hand_eye
from mocks.ur_controller import SimulatedController
from tests.integration.test_pick_cli import (
    CLI,
    DEMO,
    ROOT,
    TCP_OFFSET,
    audit_records,
    motion_commands,
    write_config,
)

SimFactory = Callable[..., SimulatedController]
HOME_Q = "[0, -1.5708, 1.5708, -1.5708, -1.5708, 0]"
LOOP_SECTIONS = {
    "poses": f"  home: {{joints_rad: {HOME_Q}}}\n"
    "  aside: {tcp_pose: [-0.40, -0.25, 0.40, 3.14159265, 0, 0]}\n",
    "place": "  poses:\n    - [-0.30, 0.35, 0.15, 3.14159265, 0, 0]\n"
    "    - [-0.40, 0.35, 0.15, 3.14159265, 0, 0]\n  approach_mm: 80\n  retreat_mm: 80\n",
}
ONE_PLACE = "  poses: [[-0.3, 0.35, 0.15, 3.14159265, 0, 0]]\n  approach_mm: 80\n  retreat_mm: 80\n"
# Position of an object on the table in the base frame (m): reached from the home pose.
OBJECT_BASE_M = np.array([-0.52, -0.10, 0.06])
REPLY_TIMEOUT_S = 60.0


class Loop:
    """A running ``handeye-pick run`` with pipes; ``ask`` sends a request and reads its reply."""

    def __init__(self, config: Path, *extra: str) -> None:
        self.process = subprocess.Popen(
            [*CLI, "run", "--config", str(config), *extra],
            cwd=ROOT,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
        )
        self._pending = b""  # read from stdout, not yet returned as a line

    def send(self, line: str | bytes) -> None:
        assert self.process.stdin is not None
        self.process.stdin.write(line if isinstance(line, bytes) else line.encode() + b"\n")
        self.process.stdin.flush()

    def reply(self) -> dict[str, Any]:
        """The next line ``run`` wrote (a reply or an event), read from the pipe unbuffered: a
        buffered reader could hold a second line where ``select`` does not see it."""
        assert self.process.stdout is not None
        fd = self.process.stdout.fileno()
        deadline = time.monotonic() + REPLY_TIMEOUT_S
        while b"\n" not in self._pending:
            ready, _, _ = select.select([fd], [], [], max(0.0, deadline - time.monotonic()))
            if not ready:
                self.process.kill()
                self.process.wait()
                raise AssertionError(f"no reply within {REPLY_TIMEOUT_S} s: {self.stderr()}")
            chunk = os.read(fd, 65536)
            assert chunk, f"run ended: {self.stderr()}"
            self._pending += chunk
        line, self._pending = self._pending.split(b"\n", 1)
        reply: dict[str, Any] = json.loads(line)
        return reply

    def ask(self, request: dict[str, Any]) -> dict[str, Any]:
        self.send(json.dumps(request))
        return self.reply()

    def close(self) -> int:
        if self.process.stdin is not None and not self.process.stdin.closed:
            self.process.stdin.close()
        return self.process.wait(timeout=30)

    def stderr(self) -> str:
        assert self.process.stderr is not None
        if self.process.poll() is None:
            return "(still running)"
        return self.process.stderr.read().decode(errors="replace")


@contextmanager
def loop(config: Path, *extra: str) -> Iterator[Loop]:
    running = Loop(config, *extra)
    try:
        yield running
    finally:
        if running.process.poll() is None:
            running.process.kill()
            running.process.wait()


def detection_for(T_base_flange: np.ndarray, p_base_m: np.ndarray) -> dict[str, Any]:
    """The camera-frame detection (mm) of a base-frame point seen from a flange pose, through
    the demo's eye-in-hand calibration."""
    T_flange_cam = load_hand_eye(DEMO / "hand_eye.yaml", HandEyeMode.EYE_IN_HAND, "mm").T_cal
    p_cam_m = transform_point(invert(T_base_flange @ T_flange_cam), p_base_m)
    return {"position_mm": (p_cam_m * 1000.0).tolist()}


def loop_config(tmp_path: Path, host: str, **sections: str) -> Path:
    return write_config(tmp_path, host, **{**LOOP_SECTIONS, **sections})


def test_every_request_kind_through_a_pipe(sim_controller: SimFactory, tmp_path: Path) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    with loop(loop_config(tmp_path, ctl.host)) as run:
        moved = run.ask({"id": "m", "op": "move", "pose": "home"})
        assert (moved["ok"], moved["status"]) == (True, "moved")
        captured = run.ask({"id": 1, "op": "capture"})
        assert captured["ok"] is True
        T_capture = ur_pose_to_matrix(captured["flange_pose_ur"])
        np.testing.assert_allclose(
            T_capture, ur_pose_to_matrix(ctl.snapshot().flange_pose), atol=1e-9
        )
        request = {
            "id": "p1",
            "op": "pick",
            "capture_id": captured["capture_id"],
            "candidates": [detection_for(T_capture, OBJECT_BASE_M)],
        }
        picked = run.ask(request)
        assert (picked["ok"], picked["status"], picked["candidate"]) == (True, "placed", 0), picked
        np.testing.assert_allclose(picked["targets"]["grasp"][:3], OBJECT_BASE_M, atol=1e-6)
        assert picked["place"]["index"] == 0
        status = run.ask({"id": "s", "op": "status"})
        assert (status["ok"], status["ready"], status["halted"]) == (True, True, False)
        # A second cycle places at the second place pose.
        captured = run.ask({"id": 2, "op": "capture", "pose": "home"})
        T_capture = ur_pose_to_matrix(captured["flange_pose_ur"])
        again = run.ask(
            {
                "id": "p2",
                "op": "pick",
                "capture_id": captured["capture_id"],
                "candidates": [detection_for(T_capture, OBJECT_BASE_M)],
            }
        )
        assert (again["status"], again["place"]["index"], again["cycle"]) == ("placed", 1, 2)
        assert run.ask({"id": "q", "op": "quit"})["status"] == "bye"
        assert run.close() == 0
    records = audit_records(tmp_path)
    picks = [r for r in records if r.get("request_id") == "p1"]
    assert [r["event"] for r in picks] == ["plan", "outcome"]
    assert {r["capture_id"] for r in picks} == {"c1"}
    assert {r["cycle"] for r in picks} == {1}
    assert picks[-1]["status"] == "placed"
    # approach, grasp, retreat, place-approach, place, place-retreat per pick; two moves home
    assert len(motion_commands(ctl)) == 2 * 6 + 2


def test_the_latched_pose_is_used_when_the_arm_moved_since_the_capture(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    with loop(
        loop_config(
            tmp_path,
            ctl.host,
            place=ONE_PLACE,
        )
    ) as run:
        T_capture = _home_and_capture(run)
        detection = detection_for(T_capture, OBJECT_BASE_M)
        # Zivid's advice: move on as soon as the capture returns. The arm is elsewhere now.
        assert run.ask({"id": "a", "op": "move", "pose": "aside"})["ok"] is True
        T_now = ur_pose_to_matrix(ctl.snapshot().flange_pose)
        assert np.linalg.norm(T_now[:3, 3] - T_capture[:3, 3]) > 0.05
        picked = run.ask(
            {
                "id": "p",
                "op": "pick",
                "capture_id": "c1",
                "candidates": [detection],
            }
        )
        assert picked["status"] == "placed", picked
    grasp = np.array(picked["targets"]["grasp"][:3])
    np.testing.assert_allclose(grasp, OBJECT_BASE_M, atol=1e-6)
    # The live pose would have put the grasp far from the object.
    T_flange_cam = load_hand_eye(DEMO / "hand_eye.yaml", HandEyeMode.EYE_IN_HAND, "mm").T_cal
    live = transform_point(T_now @ T_flange_cam, np.array(detection["position_mm"]) / 1000.0)
    assert np.linalg.norm(live - OBJECT_BASE_M) > 0.05
    grasp_moves = [c for c in motion_commands(ctl) if c["kind"] == "moveL"]
    np.testing.assert_allclose(grasp_moves[2]["target"][:3], OBJECT_BASE_M, atol=1e-6)


def test_bad_lines_are_answered_and_move_nothing(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    good = {"position_mm": [35.0, -20.0, 384.0]}
    bad_requests: list[str | bytes] = [
        "not json",
        "[1, 2]",
        json.dumps({"id": "u", "op": "dance"}),
        json.dumps({"id": "k", "op": "status", "extra": 1}),
        json.dumps({"id": "c", "op": "pick", "capture_id": "c9", "candidates": [good]}),
        json.dumps({"id": "n", "op": "pick", "candidates": [good]}),  # eye-in-hand: no capture
        json.dumps(
            {
                "id": "d",
                "op": "pick",
                "capture_id": "c1",
                "candidates": [good, {"position_mm": [1, 2]}],
            }
        ),
        json.dumps(
            {
                "id": "f",
                "op": "pick",
                "capture_id": "c1",
                "candidates": [{"position_mm": [35.0, -20.0, 1e400]}],
            }
        ),
        json.dumps({"id": "e", "op": "pick", "capture_id": "c1", "candidates": []}),
        json.dumps({"id": "p", "op": "move", "pose": "nowhere"}),
        b"x" * 1_100_000 + b"\n",
    ]
    with loop(loop_config(tmp_path, ctl.host)) as run:
        assert run.ask({"id": "c", "op": "capture"})["capture_id"] == "c1"
        before = len(motion_commands(ctl))
        for line in bad_requests:
            run.send(line)
            reply = run.reply()
            assert reply["ok"] is False, (line[:80], reply)
            assert reply["error"], reply
        assert run.ask({"id": "s", "op": "status"})["ok"] is True  # the loop goes on
        assert run.close() == 0  # end of input: a clean end
    assert len(motion_commands(ctl)) == before


def test_no_candidate_refused_and_picked_statuses(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    config = write_config(tmp_path, ctl.host, poses=LOOP_SECTIONS["poses"])  # no place section
    with loop(config) as run:
        T_capture = _home_and_capture(run)
        below_table = detection_for(T_capture, np.array([-0.52, -0.10, -0.05]))
        far = detection_for(T_capture, np.array([-0.52, 0.85, 0.06]))  # beyond max y
        before = len(motion_commands(ctl))
        none = run.ask(
            {"id": "1", "op": "pick", "capture_id": "c1", "candidates": [below_table, far]}
        )
        assert (none["ok"], none["status"]) == (False, "no-candidate"), none
        assert [r["candidate"] for r in none["refused"]] == [0, 1]
        assert "workspace" in " ".join(none["refused"][0]["reasons"])
        assert len(motion_commands(ctl)) == before
        ctl.set_remote_control(False)
        refused = run.ask(
            {
                "id": "2",
                "op": "pick",
                "capture_id": "c1",
                "candidates": [detection_for(T_capture, OBJECT_BASE_M)],
            }
        )
        assert (refused["ok"], refused["status"]) == (False, "refused"), refused
        assert "Remote Control" in refused["error"]
        ctl.set_remote_control(True)
        picked = run.ask(
            {
                "id": "3",
                "op": "pick",
                "capture_id": "c1",
                "candidates": [below_table, detection_for(T_capture, OBJECT_BASE_M)],
            }
        )
        assert (picked["ok"], picked["status"], picked["candidate"]) == (True, "picked", 1)
        assert picked["refused"][0]["candidate"] == 0


def _home_and_capture(run: Loop) -> np.ndarray:
    """Move home, capture there (capture id c1); the latched T_base_flange (m)."""
    run.ask({"id": "m", "op": "move", "pose": "home"})
    captured = run.ask({"id": "c", "op": "capture"})
    return ur_pose_to_matrix(captured["flange_pose_ur"])


def _unlock_protective_stop(host: str) -> None:
    with socket.create_connection((host, 29999), timeout=5.0) as dashboard:
        reader = dashboard.makefile("r")
        reader.readline()  # banner
        dashboard.sendall(b"unlock protective stop\n")
        assert "releasing" in reader.readline().lower()


def test_status_after_a_lost_link_reads_the_controller_from_outside(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    # A lost link ends the robot session; the operator still sees the pendant's side.
    ctl = sim_controller(
        tcp_offset=TCP_OFFSET, speed_factor=4.0, inject=("drop-connection@move:3:0.5",)
    )
    with loop(loop_config(tmp_path, ctl.host)) as run:
        detection = detection_for(_home_and_capture(run), OBJECT_BASE_M)
        fault = run.ask({"id": "1", "op": "pick", "capture_id": "c1", "candidates": [detection]})
        assert (fault["ok"], fault["status"]) == (False, "fault"), fault
        status = run.ask({"id": "2", "op": "status"})
        assert (status["ready"], status["halted"]) == (False, True), status
        assert status["problems"][0].startswith("halted (RobotConnectionError"), status
        flange = ur_pose_to_matrix(list(ctl.snapshot().flange_pose))
        np.testing.assert_allclose(ur_pose_to_matrix(status["flange_pose_ur"]), flange, atol=1e-6)
        resumed = run.ask({"id": "3", "op": "resume"})
        assert (resumed["ok"], resumed["status"]) == (True, "ready"), resumed


def test_a_fault_mid_cycle_halts_the_loop_until_resume(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(
        tcp_offset=TCP_OFFSET, speed_factor=4.0, inject=("protective-stop@move:3:0.5",)
    )
    with loop(loop_config(tmp_path, ctl.host)) as run:
        detection = detection_for(_home_and_capture(run), OBJECT_BASE_M)
        pick = {"op": "pick", "capture_id": "c1", "candidates": [detection]}
        fault = run.ask({"id": "1", **pick})  # the grasp move (3rd motion) is stopped
        assert (fault["ok"], fault["status"]) == (False, "fault"), fault
        halted_at = len(ctl.commands)
        for request in (
            {"id": "2", **pick},
            {"id": "3", "op": "move", "pose": "home"},
            {"id": "4", "op": "capture"},
            {"id": "5", "op": "place"},
        ):
            reply = run.ask(request)
            assert (reply["ok"], reply["status"]) == (False, "halted"), reply
            assert "protective stop" in reply["error"]
        status = run.ask({"id": "6", "op": "status"})
        assert (status["ready"], status["halted"]) == (False, True)
        still = run.ask({"id": "7", "op": "resume"})  # nothing unlocks it but the operator
        assert (still["ok"], still["status"]) == (False, "refused"), still
        assert ctl.commands[halted_at:] == []  # nothing sent while halted
        _unlock_protective_stop(ctl.host)
        resumed = run.ask({"id": "8", "op": "resume"})
        assert (resumed["ok"], resumed["status"]) == (True, "ready"), resumed
        run.ask({"id": "9", "op": "move", "pose": "home"})
        captured = run.ask({"id": "10", "op": "capture"})
        detection = detection_for(ur_pose_to_matrix(captured["flange_pose_ur"]), OBJECT_BASE_M)
        again = run.ask(
            {
                "id": "11",
                "op": "pick",
                "capture_id": captured["capture_id"],
                "candidates": [detection],
            }
        )
        assert again["status"] == "placed", again
    outcome = next(
        r for r in audit_records(tmp_path) if r.get("request_id") == "1" and r["event"] == "outcome"
    )
    assert (outcome["status"], outcome["step"]) == ("fault", "grasp")


def test_sigterm_mid_move_stops_the_arm_answers_and_exits_143(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, speed_factor=0.3)
    with loop(loop_config(tmp_path, ctl.host)) as run:
        detection = detection_for(_home_and_capture(run), OBJECT_BASE_M)
        run.send(
            json.dumps({"id": "p", "op": "pick", "capture_id": "c1", "candidates": [detection]})
        )
        deadline = time.monotonic() + 30.0
        while not ctl.snapshot().moving and time.monotonic() < deadline:
            time.sleep(0.01)
        assert ctl.snapshot().moving
        run.process.send_signal(signal.SIGTERM)
        reply = run.reply()
        assert (reply["id"], reply["status"]) == ("p", "interrupted"), reply
        assert run.process.wait(timeout=30) == 143
    time.sleep(0.3)
    assert not ctl.snapshot().moving
    assert ctl.commands[-1]["kind"] == "stopL"
    outcome = audit_records(tmp_path)[-1]
    assert (outcome["event"], outcome["status"]) == ("outcome", "interrupted")
    assert outcome["error"]["signal"] == "SIGTERM"


def test_tcp_listener_serves_one_client_at_a_time_with_a_token(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    token_file = tmp_path / "token"
    token_file.write_text("a-shared-secret-of-some-length\n")
    with loop(
        loop_config(tmp_path, ctl.host),
        "--listen",
        f"{ctl.host}:0",
        "--token-file",
        str(token_file),
    ) as run:
        assert run.process.stderr is not None
        port = None
        deadline = time.monotonic() + 30.0
        while port is None and time.monotonic() < deadline:
            line = run.process.stderr.readline().decode()
            if line.startswith("listening on"):
                port = int(line.rsplit(":", 1)[1])
        assert port is not None
        for _ in range(2):  # the session outlives a client
            with socket.create_connection((ctl.host, port), timeout=30.0) as client:
                stream = client.makefile("rw")
                stream.write(json.dumps({"id": "1", "op": "status"}) + "\n")
                stream.flush()
                refused = json.loads(stream.readline())
                assert (refused["ok"], refused["status"]) == (False, "bad-request")
                assert "token" in refused["error"]
                stream.write(
                    json.dumps(
                        {"id": "2", "op": "status", "token": "a-shared-secret-of-some-length"}
                    )
                    + "\n"
                )
                stream.flush()
                assert json.loads(stream.readline())["ready"] is True
        with socket.create_connection((ctl.host, port), timeout=30.0) as client:
            stream = client.makefile("rw")
            stream.write(
                json.dumps({"id": "3", "op": "quit", "token": "a-shared-secret-of-some-length"})
                + "\n"
            )
            stream.flush()
            assert json.loads(stream.readline())["status"] == "bye"
        assert run.process.wait(timeout=30) == 0


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (("--listen", "10.1.2.3:8765"), "not a loopback address"),
        (("--listen", "10.1.2.3:8765", "--allow-remote"), "--token-file"),
        (("--listen", "localhost"), "IP:PORT"),
    ],
)
def test_listen_refuses_what_would_expose_the_robot(
    tmp_path: Path, loopback_host: str, args: tuple[str, ...], message: str
) -> None:
    config = loop_config(tmp_path, loopback_host)
    result = subprocess.run(
        [*CLI, "run", "--config", str(config), *args],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 2
    assert message in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1


def test_eye_to_hand_capture_moves_out_of_view_and_latches_no_pose(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    (tmp_path / "eth.yaml").write_text(
        "[[0, 1, 0, -450], [1, 0, 0, -100], [0, 0, -1, 1200], [0, 0, 0, 1]]\n"
    )
    hand_eye = f"  mode: eye-to-hand\n  file: {tmp_path / 'eth.yaml'}\n  units: mm\n"
    hand_eye += "  camera_position_mm: [-440, -110, 1190]\n"  # taped: file, not its inverse
    config = loop_config(tmp_path, ctl.host, hand_eye=hand_eye, capture="  pose: aside\n")
    with loop(config) as run:
        captured = run.ask({"id": "c", "op": "capture"})
        assert (captured["ok"], captured["flange_pose_ur"]) == (True, None), captured
        np.testing.assert_allclose(ctl.snapshot().tcp_pose[:3], [-0.40, -0.25, 0.40], atol=1e-6)
        # Camera 1.2 m above the base looking down: a point 1140 mm away lies on the table.
        picked = run.ask(
            {"id": "p", "op": "pick", "candidates": [{"position_mm": [-100.0, -70.0, 1140.0]}]}
        )
        assert picked["status"] == "placed", picked
        np.testing.assert_allclose(picked["targets"]["grasp"][:3], [-0.52, -0.20, 0.06], atol=1e-9)


def test_a_second_session_on_a_robot_in_use_is_refused_before_connecting(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    config = loop_config(tmp_path, ctl.host)
    with loop(config) as run:
        assert run.ask({"id": "s", "op": "status"})["ok"] is True  # run holds the robot now
        commands_before = len(ctl.commands)
        second = subprocess.run(
            [*CLI, "pick", "--config", str(config), "--xyz", "35", "-20", "384", "--json"],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=60,
            check=False,
        )
        assert second.returncode == 3, second.stderr
        (line,) = second.stderr.strip().splitlines()
        assert f"in use by process {run.process.pid}" in line
        assert " run --config " in line
        assert "nothing was sent" in line
        report = json.loads(second.stdout)
        assert report["status"] == "refused"
        assert ctl.snapshot().program_running  # run's control program was left running
        assert len(ctl.commands) == commands_before
        assert run.ask({"id": "s2", "op": "status"})["ok"] is True  # and run goes on
        assert run.close() == 0
