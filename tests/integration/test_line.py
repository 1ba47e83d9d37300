"""The cell in the line (docs/line.md): ``handeye-pick run`` against the simulated controller
through the real ur_rtde, commanded and watched through its three doors while the vision
program picks: its own requests, the OPC UA server (a real asyncua client) and the wired
handshake (the simulator's inputs and outputs, driven as a PLC would)."""

from __future__ import annotations

import asyncio
import json
import socket
import subprocess
import time
from pathlib import Path
from typing import Any

import pytest
from asyncua import Client, ua

from handeye_pick.geometry import ur_pose_to_matrix
from handeye_pick.line.users import hashed_line
from handeye_pick.report.shift import shift_report
from mocks.ur_controller import SimulatedController
from tests.integration.test_pick_cli import CLI, ROOT, TCP_OFFSET, audit_records
from tests.integration.test_run_loop import (
    OBJECT_BASE_M,
    SimFactory,
    _unlock_protective_stop,
    detection_for,
    loop,
    loop_config,
)

NAMESPACE = "urn:handeye-pick:line"
IO = (
    "  io:\n    inputs: {cycle_stop: 4, stop: 5, resume: 6}\n"
    "    outputs: {ready: 4, executing: 5, held: 6, halted: 7, heartbeat: 3}\n"
)
WAIT_S = 30.0


def free_port(host: str) -> int:
    with socket.socket() as probe:
        probe.bind((host, 0))
        port: int = probe.getsockname()[1]
        return port


def opcua(url: str, action: str, *, user: tuple[str, str] | None = None,
          security: str | None = None) -> Any:
    """One client session: ``read NAME`` (a variable of the Line object, or ``State``), or
    ``call METHOD``; returns the value or the method's outputs."""

    async def session() -> Any:
        client = Client(url, timeout=10)
        if user is not None:
            client.set_user(user[0])
            client.set_password(user[1])
        if security is not None:
            await client.set_security_string(security)
        async with client:
            ns = await client.get_namespace_index(NAMESPACE)
            machines = await client.nodes.objects.get_child([f"{ns}:Machines"])
            cell = (await machines.get_children())[0]
            kind, name = action.split(" ", 1)
            if kind == "call":
                line = await cell.get_child([f"{ns}:Line"])
                return await line.call_method(f"{ns}:{name}")
            if name == "State":
                path = [f"{ns}:MachineryBuildingBlocks", f"{ns}:MachineryItemState",
                        f"{ns}:CurrentState"]
                return (await (await cell.get_child(path)).read_value()).Text
            path = [f"{ns}:Line", *(f"{ns}:{part}" for part in name.split("/"))]
            return await (await cell.get_child(path)).read_value()

    return asyncio.run(session())


def wait_for(what: str, check: Any) -> Any:
    """Poll ``check()`` until it returns something truthy (a condition, never a duration)."""
    deadline = time.monotonic() + WAIT_S
    while time.monotonic() < deadline:
        value = check()
        if value:
            return value
        time.sleep(0.05)
    raise AssertionError(f"{what}: not within {WAIT_S} s")


def output(ctl: SimulatedController, bit: int) -> bool:
    return bool(ctl.snapshot().standard_digital_out >> bit & 1)


def pick_request(rid: str, run: Any) -> dict[str, Any]:
    """Move home, capture there, and the pick of the object seen from there."""
    assert run.ask({"id": f"{rid}-home", "op": "move", "pose": "home"})["status"] == "moved"
    captured = run.ask({"id": f"{rid}-capture", "op": "capture"})
    detection = detection_for(ur_pose_to_matrix(captured["flange_pose_ur"]), OBJECT_BASE_M)
    return {"id": rid, "op": "pick", "capture_id": captured["capture_id"],
            "candidates": [detection], "events": True}


def reply_to(run: Any, rid: str) -> dict[str, Any]:
    """The reply to request ``rid``, past its event lines."""
    while True:
        line = run.reply()
        if line.get("id") == rid and "event" not in line:
            return line


def test_a_cycle_stop_over_opcua_mid_pick_lets_it_place_and_holds_the_next_after_garbage(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, speed_factor=2.0)
    port = free_port(ctl.host)
    url = f"opc.tcp://{ctl.host}:{port}"
    with loop(loop_config(tmp_path, ctl.host), "--opcua", f"{ctl.host}:{port}") as run:
        assert run.ask({"id": "up", "op": "status"})["ok"] is True  # run (and OPC UA) is up
        for garbage in (b"\x00" * 64, b"HELF" + b"\xff" * 4096, b"not OPC UA at all\r\n"):
            with socket.create_connection((ctl.host, port)) as client:  # costs the cell nothing
                client.sendall(garbage)
        run.send(json.dumps(pick_request("p1", run)))
        step = run.reply()
        assert (step["id"], step["event"]) == ("p1", "step"), step
        status, text = opcua(url, "call CycleStop")
        assert status.is_good(), text
        assert "holding after request p1" in text
        placed = reply_to(run, "p1")
        assert (placed["ok"], placed["status"]) == (True, "placed"), placed
        held = run.ask({"id": "c2", "op": "capture"})
        assert (held["ok"], held["status"], held["held_by"]) == (
            False, "held", "OPC UA anonymous client"), held
        status_reply = run.ask({"id": "s", "op": "status"})
        assert (status_reply["held"], status_reply["line_state"]) == (True, "NotExecuting")
        assert wait_for("Held over OPC UA", lambda: opcua(url, "read Held")) is True
        released = run.ask({"id": "r", "op": "release"})
        assert (released["ok"], released["held"]) == (True, False), released
        assert run.ask({"id": "c3", "op": "capture"})["status"] == "captured"
        assert run.ask({"id": "q", "op": "quit"})["status"] == "bye"
        assert run.close() == 0
    commands = [(r["command"], r["by"]) for r in audit_records(tmp_path) if r["event"] == "line"]
    assert commands == [("cycle-stop", "OPC UA anonymous client"), ("release", "request r")]


def test_the_wired_plc_stops_mid_move_and_resumes_only_once_the_controller_is_ready(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, speed_factor=1.0)
    port = free_port(ctl.host)
    url = f"opc.tcp://{ctl.host}:{port}"
    config = loop_config(tmp_path, ctl.host, line=IO)
    with loop(config, "--opcua", f"{ctl.host}:{port}") as run:
        wait_for("ready output", lambda: output(ctl, 4))
        beat = output(ctl, 3)
        wait_for("heartbeat toggles", lambda: output(ctl, 3) != beat)
        run.send(json.dumps(pick_request("p1", run)))
        assert reply_to(run, "p1")["status"] == "placed"
        run.send(json.dumps(pick_request("p2", run)))
        wait_for("the arm moves", lambda: ctl.snapshot().moving)
        assert output(ctl, 5)  # executing
        ctl.set_inputs({5: True})  # the PLC's immediate stop: a rising edge
        stopped = reply_to(run, "p2")
        assert (stopped["ok"], stopped["status"]) == (False, "stopped"), stopped
        wait_for("halted output", lambda: output(ctl, 7) and not output(ctl, 4))
        ctl.set_inputs({5: False})
        ctl.inject("protective-stop")
        status, text = opcua(url, "call Resume")
        assert not status.is_good(), text
        assert "protective" in text.lower(), text
        assert run.ask({"id": "h", "op": "capture"})["status"] == "halted"
        _unlock_protective_stop(ctl.host)
        ctl.set_inputs({6: True})  # the PLC's resume
        wait_for("ready again", lambda: output(ctl, 4) and not output(ctl, 7))
        ctl.set_inputs({6: False})
        assert run.ask({"id": "s", "op": "status"})["halted"] is False
        run.send(json.dumps(pick_request("p3", run)))
        reply = reply_to(run, "p3")
        assert reply["status"] == "placed", reply
        last = wait_for("counters published", lambda: opcua(url, "read Counters/Placed") == 2)
        counters = {name: opcua(url, f"read Counters/{name}")
                    for name in ("Placed", "Stopped", "Cycles", "HaltedSeconds")}
        code, text = opcua(url, "read LastErrorCode"), opcua(url, "read LastErrorText")
        assert last
        assert run.ask({"id": "q", "op": "quit"})["status"] == "bye"
        assert run.close() == 0
    assert ctl.snapshot().standard_digital_out & 0b11111000 == 0  # every line output off
    report = shift_report(tmp_path / "picks.jsonl")
    assert counters == {
        "Placed": report.statuses["placed"],
        "Stopped": report.statuses["stopped"],
        "Cycles": report.cycles,
        "HaltedSeconds": round(report.halted_s, 3),
    }
    assert (code, "protective stop" in text) == (301, True), text  # the refused resume's connect
    records = audit_records(tmp_path)
    line = [(r["command"], r["by"], r["ok"]) for r in records if r["event"] == "line"]
    assert line == [
        ("stop", "input DI5 (stop)", True),
        ("resume", "OPC UA anonymous client", False),
        ("resume", "input DI6 (resume)", True),
    ]


def test_users_sign_in_anonymous_clients_only_read_and_a_wrong_password_is_refused(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    users = tmp_path / "users"
    users.write_text(hashed_line("panel", "correct horse battery") + "\n")
    port = free_port(ctl.host)
    url = f"opc.tcp://{ctl.host}:{port}"
    client_cert = _client_certificate(tmp_path)
    secure = f"Basic256Sha256,SignAndEncrypt,{client_cert[0]},{client_cert[1]}"
    extra = ("--opcua", f"{ctl.host}:{port}", "--opcua-users", str(users))
    with loop(loop_config(tmp_path, ctl.host), *extra) as run:
        assert run.ask({"id": "s", "op": "status"})["ok"] is True
        with pytest.raises(Exception, match=r"BadUserAccessDenied|BadIdentityToken"):
            opcua(url, "read Held", user=("panel", "wrong horse"), security=secure)
        assert opcua(url, "read State", security=secure) == "NotExecuting"
        with pytest.raises(ua.UaStatusCodeError):
            opcua(url, "call CycleStop", security=secure)
        status, _ = opcua(url, "call CycleStop", user=("panel", "correct horse battery"),
                          security=secure)
        assert status.is_good()
        assert run.ask({"id": "c", "op": "capture"})["status"] == "held"
    by = [r["by"] for r in audit_records(tmp_path) if r["event"] == "line"]
    assert by == ["OPC UA user panel"]


def _client_certificate(tmp_path: Path) -> tuple[Path, Path]:
    from asyncua.crypto import cert_gen
    from cryptography.hazmat.primitives.serialization import Encoding
    from cryptography.x509 import DNSName, UniformResourceIdentifier
    from cryptography.x509.oid import ExtendedKeyUsageOID

    key = cert_gen.generate_private_key()
    cert = cert_gen.generate_self_signed_app_certificate(
        key, "urn:handeye-pick:test-client", {"commonName": "test client"},
        [UniformResourceIdentifier("urn:freeopcua:client"), DNSName("localhost")],
        extended=[ExtendedKeyUsageOID.CLIENT_AUTH],
    )
    key_path, cert_path = tmp_path / "client-key.pem", tmp_path / "client-cert.der"
    key_path.write_bytes(cert_gen.dump_private_key_as_pem(key))
    cert_path.write_bytes(cert.public_bytes(Encoding.DER))
    return cert_path, key_path


@pytest.mark.parametrize(
    "extra",
    [
        ("--opcua", "192.0.2.10:4840"),
        ("--opcua", "192.0.2.10:4840", "--allow-remote"),
    ],
)
def test_a_remote_opcua_address_needs_allow_remote_and_users(
    tmp_path: Path, extra: tuple[str, ...]
) -> None:
    config = loop_config(tmp_path, "127.0.0.250")
    result = subprocess.run([*CLI, "run", "--config", str(config), *extra], cwd=ROOT,
                            capture_output=True, text=True, timeout=60, check=False)
    assert result.returncode == 2, result.stderr
    assert "--allow-remote and --opcua-users FILE" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1, result.stderr


def test_a_resume_over_opcua_runs_while_run_listens_with_no_client(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    port, listen = free_port(ctl.host), free_port(ctl.host)
    url = f"opc.tcp://{ctl.host}:{port}"
    extra = ("--opcua", f"{ctl.host}:{port}", "--listen", f"{ctl.host}:{listen}")
    with loop(loop_config(tmp_path, ctl.host), *extra) as run:
        state = wait_for("the server", lambda: _state_or_none(url))
        assert state == "NotExecuting"
        assert opcua(url, "call Stop")[0].is_good()
        assert wait_for("halted", lambda: _state_or_none(url) == "OutOfService")
        status, text = opcua(url, "call Resume")  # taken by run's thread between clients
        assert status.is_good(), text
        assert wait_for("ready", lambda: _state_or_none(url) == "NotExecuting")
        run.process.terminate()
        run.process.wait(timeout=30)
    commands = [(r["command"], r["ok"]) for r in audit_records(tmp_path) if r["event"] == "line"]
    assert commands == [("stop", True), ("resume", True)]


def _state_or_none(url: str) -> str | None:
    try:
        state: str = opcua(url, "read State")
    except (OSError, asyncio.TimeoutError):
        return None
    return state
