"""The simulated controller's RTDE interface against UR's RTDE guide, through a client written from
the guide (client.py), not ur_rtde: fields, types, clock, protocol version, the everyday path."""

from __future__ import annotations

import math
import struct
import time
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest
import rtde_control

from mocks.ur_controller import SimulatedController
from tests.conftest import start_sim_controller
from tests.rtde_client.client import RtdeClient
from tests.rtde_client.ur_fields import INPUTS_5_15, OUTPUTS_5_15, RECORD_PY_RECIPE

TCP = (0.01, -0.02, 0.15, 0.0, 0.0, 0.4)
NAME_LIST_LIMIT = 2048  # bytes of names per setup request, as the guide says
UR5E_D1_M = 0.1625
UR5E_UPPER_ARM_M = 0.425


@pytest.fixture(scope="module")
def ctl() -> Iterator[SimulatedController]:
    controller = start_sim_controller(instant=True, tcp_offset=TCP)
    yield controller
    controller.stop()


def connect(host: str) -> RtdeClient:
    client = RtdeClient(host)
    assert client.request_protocol_version(2)
    return client


def streaming(host: str, names: list[str], frequency_hz: float = 125.0) -> RtdeClient:
    client = connect(host)
    assert client.setup_outputs(names, frequency_hz).accepted
    assert client.start()
    return client


def batches(names: list[str]) -> Iterator[list[str]]:
    """Name lists that each fit the guide's 2048-byte limit."""
    batch: list[str] = []
    for name in names:
        if batch and len(",".join([*batch, name])) > NAME_LIST_LIMIT:
            yield batch
            batch = []
        batch.append(name)
    yield batch


def receive_until(client: RtdeClient, condition: Callable[[dict[str, Any]], bool],
                  packages: int = 500) -> dict[str, Any]:
    for _ in range(packages):
        data = client.receive()
        if condition(data):
            return data
    raise AssertionError(f"condition not met in {packages} packages; last: {data}")


def packages_within(client: RtdeClient, quiet_s: float) -> int:
    """How many packages arrive before the connection stays quiet for `quiet_s` (at most 5)."""
    client.sock.settimeout(quiet_s)
    count = 0
    try:
        while count < 5:
            client.read_package()
            count += 1
    except TimeoutError:
        pass
    finally:
        client.sock.settimeout(5.0)
    return count


# --- 1. tcp_offset -------------------------------------------------------------------------------


def test_tcp_offset_is_served_as_the_active_tcp(ctl: SimulatedController) -> None:
    with connect(ctl.host) as client:
        recipe = client.setup_outputs(["timestamp", "tcp_offset"], 125.0)
        assert recipe.types == ("DOUBLE", "VECTOR6D")
        assert client.start()
        assert client.receive()["tcp_offset"] == pytest.approx(TCP)


# --- 2. controller time --------------------------------------------------------------------------


@pytest.mark.parametrize("frequency_hz", [125.0, 500.0])
def test_timestamps_step_in_whole_control_periods(ctl: SimulatedController,
                                                  frequency_hz: float) -> None:
    period_s = 0.002  # e-Series control cycle
    with streaming(ctl.host, ["timestamp"], frequency_hz) as client:
        stamps = [float(client.receive()["timestamp"]) for _ in range(300)]
    cycles = np.array(stamps) / period_s
    np.testing.assert_allclose(cycles, np.round(cycles), atol=1e-6)
    steps = np.diff(np.round(cycles))
    assert np.all(steps >= 0), "the controller clock went back"
    # Late packages come later, never closer together than the requested rate.
    assert np.all((steps == 0) | (steps >= round(500.0 / frequency_hz)))


# --- 3. UR's record.py example recipe ------------------------------------------------------------


def test_record_py_recipe_is_served_with_its_types(ctl: SimulatedController) -> None:
    names = list(RECORD_PY_RECIPE)
    with connect(ctl.host) as client:
        recipe = client.setup_outputs(names, 125.0)
        assert dict(zip(names, recipe.types, strict=True)) == RECORD_PY_RECIPE
        assert client.start()
        data = client.receive()
    assert data["safety_status"] == 1  # NORMAL
    assert data["joint_position_deviation_ratio"] == 0.0  # perfect tracking
    assert data["robot_mode"] == 7


# --- 4. every field of the 5.15 list -------------------------------------------------------------


def test_every_documented_output_is_served_with_its_type(ctl: SimulatedController) -> None:
    with connect(ctl.host) as client:
        for names in batches(list(OUTPUTS_5_15)):
            recipe = client.setup_outputs(names, 125.0)
            assert dict(zip(names, recipe.types, strict=True)) == {
                name: OUTPUTS_5_15[name] for name in names}


def test_every_documented_input_is_accepted_with_its_type(
    sim_controller: Callable[..., SimulatedController],
) -> None:
    ctl = sim_controller(instant=True)  # nothing else holds its inputs
    with connect(ctl.host) as client:
        for names in batches(list(INPUTS_5_15)):
            recipe = client.setup_inputs(names)
            assert recipe.accepted
            assert dict(zip(names, recipe.types, strict=True)) == {
                name: INPUTS_5_15[name] for name in names}


def test_input_registers_read_back_what_was_written(
    sim_controller: Callable[..., SimulatedController],
) -> None:
    ctl = sim_controller(instant=True)
    inputs = ["input_int_register_30", "input_double_register_40", "input_bit_registers0_to_31",
              "input_bit_registers32_to_63", "input_bit_register_70"]
    with connect(ctl.host) as writer, streaming(ctl.host, inputs) as reader:
        recipe = writer.setup_inputs(inputs)
        writer.write_inputs(recipe, [-77, 2.5, 0x80000001, 0x00010000, True])
        data = receive_until(reader, lambda d: d["input_int_register_30"] == -77)
    assert data == {"input_int_register_30": -77, "input_double_register_40": 2.5,
                    "input_bit_registers0_to_31": 0x80000001,
                    "input_bit_registers32_to_63": 0x00010000, "input_bit_register_70": True}


def test_payload_reads_back_what_the_program_set(
    sim_controller: Callable[..., SimulatedController],
) -> None:
    ctl = sim_controller(instant=True)
    control = rtde_control.RTDEControlInterface(ctl.host)
    try:
        assert control.setPayload(1.25, [0.0, 0.01, 0.05])
        with streaming(ctl.host, ["payload", "payload_cog"]) as reader:
            data = reader.receive()
    finally:
        control.disconnect()
    assert data["payload"] == 1.25
    assert data["payload_cog"] == pytest.approx((0.0, 0.01, 0.05))


def test_elbow_is_where_a_ur5e_has_its_elbow(ctl: SimulatedController) -> None:
    with streaming(ctl.host, ["elbow_position", "elbow_velocity", "actual_q"]) as client:
        data = client.receive()
    shoulder = np.array([0.0, 0.0, UR5E_D1_M])
    elbow = np.array(data["elbow_position"])
    assert np.linalg.norm(elbow - shoulder) == pytest.approx(UR5E_UPPER_ARM_M, abs=1e-9)
    assert data["elbow_velocity"] == (0.0, 0.0, 0.0)  # the arm is still


# --- 5. protocol version -------------------------------------------------------------------------


def test_protocol_version_3_is_refused_and_the_client_falls_back_to_2(
    ctl: SimulatedController,
) -> None:
    with RtdeClient(ctl.host) as client:
        assert not client.request_protocol_version(3)
        assert not client.request_protocol_version(1)
        assert client.request_protocol_version(2)
        assert client.controller_version()[:2] == (5, 15)


# --- the everyday path ---------------------------------------------------------------------------


def test_unknown_names_are_not_found_and_the_recipe_refused(ctl: SimulatedController) -> None:
    with connect(ctl.host) as client:
        recipe = client.setup_outputs(["timestamp", "no_such_field", "actual_qdd"], 125.0)
        assert recipe.types == ("DOUBLE", "NOT_FOUND", "NOT_FOUND")
        assert not client.start()  # no usable output recipe


def test_claimed_input_registers_are_in_use_for_others_until_released(
    sim_controller: Callable[..., SimulatedController],
) -> None:
    ctl = sim_controller(instant=True)
    names = ["input_int_register_5", "input_double_register_5"]
    with connect(ctl.host) as first:
        assert first.setup_inputs(names).accepted
        with connect(ctl.host) as second:
            refused = second.setup_inputs(["input_double_register_5"])
            assert (refused.recipe_id, refused.types) == (0, ("IN_USE",))
    # Released when the first closed: the controller learns of the close a moment later.
    deadline = time.monotonic() + 5.0
    while True:
        with connect(ctl.host) as third:
            if third.setup_inputs(names).accepted:
                break
        assert time.monotonic() < deadline, "the claim was never released"
        time.sleep(0.01)


def test_pause_and_start_again(ctl: SimulatedController) -> None:
    with streaming(ctl.host, ["timestamp"]) as client:
        before = client.receive()["timestamp"]
        assert client.pause()
        # A package already on its way when the pause arrived may still come, no more.
        assert packages_within(client, 0.3) <= 1
        assert client.start()
        assert client.receive()["timestamp"] > before


def test_malformed_packages_and_text_messages_are_survived(ctl: SimulatedController) -> None:
    with streaming(ctl.host, ["timestamp"]) as client:
        recipe = client.setup_inputs(["input_int_register_44"])
        client.send(b"U", bytes([recipe.recipe_id]) + b"\x00")  # 2 bytes short
        client.send(b"U", bytes([99]) + struct.pack(">i", 1))  # no such recipe
        client.send(b"X", b"whatever")  # no such package type
        client.text_message("hello from a test")
        first = client.receive()["timestamp"]
        time.sleep(0.05)
        assert math.isfinite(float(client.receive()["timestamp"]))
        assert client.receive()["timestamp"] > first
