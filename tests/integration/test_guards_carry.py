"""A carried part is watched during the move, not only at its end (issue 32, item 2), through the
Cell and the real ur_rtde against the simulated controller and its simulated Robotiq, in real
time: the part slips out early in a long carry and the arm must stop near where it slipped,
within a watch period and the braking distance (with slack for a loaded machine), far from the
end of the move.

The bound is physics, not a stopwatch: the controller drops the part at a known fraction of the
move's duration, so the arm has covered at most ``v * fraction * T`` by then; from there it
moves at most at ``v`` until the sequence looks again (``GRASP_WATCH_PERIOD_S``) and the stopL
lands (``SLACK_S``), then brakes over ``v^2 / (2 * stop_decel)``.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from handeye_pick import Cell, load_detection
from handeye_pick.cell.sequence import GRASP_WATCH_PERIOD_S
from handeye_pick.errors import PartDropped
from mocks.ur_controller import SimulatedController
from tests.integration.handeye_cell import wait_until
from tests.integration.test_gripper_pick import (
    PART_MM,
    PLACE,
    robotiq_config,
)
from tests.integration.test_pick_cli import DEMO, TCP_OFFSET, audit_records

SimFactory = Callable[..., SimulatedController]
SPEED_MPS, ACCEL_MPS2, STOP_DECEL_MPS2 = 0.25, 1.2, 10.0  # the config's motion section
MOTION = (
    f"  speed_mps: {SPEED_MPS}\n  accel_mps2: {ACCEL_MPS2}\n  grasp_speed_mps: 0.1\n"
    f"  stop_decel_mps2: {STOP_DECEL_MPS2}\n"
)
DROP_FRACTION = 0.15
SLACK_S = 1.0
"""Time beyond the watch period the client may take to see the loss and land its stopL on a
shared, loaded machine (a gripper round trip, an RTDE poll, the stopL itself): generous, and
still leaves the bound far short of the end of the carry."""


def test_a_part_dropped_early_in_a_long_carry_stops_the_arm_where_it_fell(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    """Guards ``_watching`` in cell/sequence.py (``if fraction < 1.0 and now - last_look <
    GRASP_WATCH_PERIOD_S: return``): a held part is looked at every watch period while the arm
    moves. With ``or`` for ``and`` it is looked at only when the move ends, and the arm carries
    on to the place approach, 0.5 m on, before the loss is noticed.

    The pick leaves the part held (motions 1-3); the place's approach (motion 4) carries it
    from the retreat to 80 mm above the place pose, a single moveL, and the part slips out 15 %
    of the way through it."""
    ctl = sim_controller(
        tcp_offset=TCP_OFFSET,
        part_width_mm=PART_MM,
        inject=(f"gripper-drop@move:4:{DROP_FRACTION}",),
    )
    config = robotiq_config(tmp_path, ctl.host, place=PLACE, motion=MOTION)
    with Cell(config) as cell:
        picked = cell.pick(load_detection(DEMO / "detection.yaml"), place=False)
        assert picked.status == "picked"
        with pytest.raises(PartDropped, match="lost the part"):
            cell.place()
        assert cell.halted is not None
    assert wait_until(lambda: len(ctl.motions) == 4)
    carry = ctl.motions[3]
    assert (carry["kind"], carry["end"]) == ("moveL", "stopped"), carry
    start = np.array(picked.reached["retreat"][:3, 3])
    target = np.array([c for c in ctl.commands if c["kind"] == "moveL"][3]["target"][:3])
    length_m = float(np.linalg.norm(target - start))
    assert length_m > 0.45  # a long carry: about 0.51 m
    # The trapezoid by hand: long enough to cruise (0.052 m of ramps), L / v + v / a.
    assert length_m > SPEED_MPS**2 / ACCEL_MPS2
    duration_s = length_m / SPEED_MPS + SPEED_MPS / ACCEL_MPS2
    covered_at_drop_m = SPEED_MPS * DROP_FRACTION * duration_s  # at most, at full speed
    bound_m = (
        covered_at_drop_m
        + SPEED_MPS * (GRASP_WATCH_PERIOD_S + SLACK_S)
        + SPEED_MPS**2 / (2.0 * STOP_DECEL_MPS2)
    )
    assert bound_m < length_m - 0.1  # the bound tells a watched carry from an unwatched one
    stopped = np.array(ctl.snapshot().tcp_pose[:3])
    travelled_m = float(np.linalg.norm(stopped - start))
    assert travelled_m <= bound_m, (travelled_m, bound_m)
    # On the straight line of the carry, and stopped by the client's stopL, not reached.
    off_line = np.cross(stopped - start, (target - start) / length_m)
    assert float(np.linalg.norm(off_line)) < 1e-3
    assert [c["kind"] for c in ctl.commands][-3:] == ["moveL", "stopL", "setPayload"]
    outcome = audit_records(tmp_path)[-1]
    assert (outcome["status"], outcome["step"]) == ("dropped", "place-approach"), outcome
    assert "place-approach" not in outcome["reached"]
