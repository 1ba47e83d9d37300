"""Blend only where it pays (issue 29, section 2): a stretch of corners goes as one path only
when the time its corners save beats what a path start costs on the controller the session
drives, measured at connect; the plan record says which way and why.

The same three via poses (gentle turns, 200 mm legs, 1 m/s: the corners save about a second)
are driven against a simulated controller that starts programs at once, and against one that
takes 3 s to start one; judged on what the controller received and on the plan record.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

from handeye_pick import Cell
from mocks.ur_controller import SimulatedController
from tests.integration.test_pick_cli import TCP_OFFSET, audit_records, write_config

SimFactory = Callable[..., SimulatedController]
FAST = "  speed_mps: 1.0\n  accel_mps2: 1.2\n  grasp_speed_mps: 0.1\n  blend_mm: 50\n"


def _capture_through_vias(
    ctl: SimulatedController, tmp_path: Path, motion: str = FAST
) -> dict[str, Any]:
    """Move to the capture pose through two via poses, each leg 200 mm and turning gently from
    where the arm stands; the stretch's entry in the plan record."""
    p = list(ctl.snapshot().tcp_pose)

    def at(dx: float, dy: float) -> list[float]:
        return [p[0] + dx, p[1] + dy, p[2], *p[3:]]

    poses = {"v1": at(0.0, 0.2), "v2": at(0.04, 0.4), "cam": at(0.1, 0.6)}
    config = write_config(
        tmp_path,
        ctl.host,
        motion=motion,
        poses="".join(f"  {name}: {{tcp_pose: {pose}}}\n" for name, pose in poses.items()),
        capture="  pose: cam\n  via: [v1, v2]\n",
    )
    with Cell(config) as cell:
        cell.capture()
    plan = [r for r in audit_records(tmp_path) if r["event"] == "plan"][-1]
    (stretch,) = plan["stretches"]
    assert stretch["moves"] == ["via v1", "via v2", "cam"]
    return dict(stretch)


def test_a_stretch_whose_corners_save_less_than_a_path_start_is_sent_stop_and_go(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True, program_start_s=3.0)
    stretch = _capture_through_vias(ctl, tmp_path)
    assert stretch["sent"] == "stop-and-go", stretch
    assert stretch["path_start_s"] > 3.0  # measured at connect: the 3 s start and the upload
    assert stretch["stop_and_go_s"] - stretch["blended_s"] < stretch["path_start_s"]
    assert "would save" in stretch["why"]
    # The controller got three single moves and no path.
    assert [c["kind"] for c in ctl.commands] == ["moveL", "moveL", "moveL"]
    plan = [r for r in audit_records(tmp_path) if r["event"] == "plan"][-1]
    assert "blends_mm" not in plan  # every target a stop


def test_a_stretch_whose_corners_save_more_than_a_path_start_is_sent_as_one_path(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    stretch = _capture_through_vias(ctl, tmp_path)
    assert stretch["sent"] == "blended", stretch
    assert 0.0 < stretch["path_start_s"] < stretch["stop_and_go_s"] - stretch["blended_s"]
    assert [c["kind"] for c in ctl.commands] == ["movePath"]
    (path,) = [c for c in ctl.commands if c["kind"] == "movePath"]
    assert path["radii"][-1] == 0.0  # ends at rest on the capture pose
    assert all(radius > 0.0 for radius in path["radii"][:-1])  # rounded at both via poses


def test_blend_always_sends_the_path_whatever_its_start_costs(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    """``motion.blend_always`` (a comparison's setting): the path goes although it does not
    pay, and the record says why."""
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True, program_start_s=3.0)
    stretch = _capture_through_vias(ctl, tmp_path, FAST + "  blend_always: true\n")
    assert stretch["sent"] == "blended", stretch
    assert stretch["why"].startswith("motion.blend_always")
    assert [c["kind"] for c in ctl.commands] == ["movePath"]
