"""The whole arm's check in a pick against the simulated controller (docs/scene.md): a post in
the forearm's way, which the tool never comes near, refuses the pick before anything moves,
naming the link in the reply, the ``--json`` report and the audit; with ``scene.arm:
unchecked`` the same pick runs (the tool alone is checked) and every check list says so, as
``plan`` does."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from handeye_pick.arm.kinematics import link_poses
from handeye_pick.arm.models import arm_model
from mocks.ur_controller import SimulatedController
from tests.integration.test_arm_model_connect import _below_the_camera
from tests.integration.test_operator_cli import cli
from tests.integration.test_pick_cli import (
    TCP_OFFSET,
    audit_records,
    motion_commands,
    run_json,
    write_config,
)

SimFactory = Callable[..., SimulatedController]
TOOL = "  shape:\n    - {name: probe, box: {size_mm: [30, 30, 30], pose: [0, 0, 0.10, 0, 0, 0]}}\n"


def _post_below_the_forearm(ctl: SimulatedController) -> str:
    """A 40 mm post 150 mm below where the forearm stands at the capture: the arm lowers the
    TCP 300 mm to the approach, the forearm comes down on the post; the TCP passes far from it."""
    index = [link.name for link in arm_model("ur5e").links].index("forearm")
    centre = link_poses(arm_model("ur5e"), np.array(ctl.snapshot().q))[0, index, :3, 3]
    x, y, z = centre - [0.0, 0.0, 0.15]
    pose = f"[{x:.4f}, {y:.4f}, {z:.4f}, 0, 0, 0]"
    return f"    - {{name: post, pose: {pose}, size_mm: [40, 40, 40]}}\n"


def _config(tmp_path: Path, ctl: SimulatedController, arm: str) -> Path:
    scene = f"  arm: {arm}\n  clearance_mm: 5\n  boxes:\n{_post_below_the_forearm(ctl)}"
    return write_config(tmp_path, ctl.host, robot_extra="  model: ur5e\n", scene=scene, tool=TOOL)


def test_a_forearm_that_would_strike_a_post_refuses_the_pick_by_name(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(model="ur5e", tcp_offset=TCP_OFFSET, instant=True)
    status, report = run_json(_config(tmp_path, ctl, "checked"), *_below_the_camera(ctl))
    assert status == 3, report
    assert report["status"] == "refused"
    failed = [c for c in report["checks"] if not c["passed"]]
    assert [(c["name"], c["target"]) for c in failed] == [("arm collision", "approach")]
    assert failed[0]["detail"].startswith("forearm would come ")
    assert "into box 'post' at " in failed[0]["detail"]
    assert "forearm would come " in str(report)  # the reply carries it
    assert motion_commands(ctl) == []
    (outcome,) = audit_records(tmp_path)
    assert outcome["status"] == "refused"
    assert "forearm would come " in str(outcome)


def test_unchecked_runs_the_same_pick_and_says_the_arm_is_not_checked(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(model="ur5e", tcp_offset=TCP_OFFSET, instant=True)
    status, report = run_json(_config(tmp_path, ctl, "unchecked"), *_below_the_camera(ctl))
    assert status == 0, report
    assert report["status"] == "picked"
    (note,) = [c for c in report["checks"] if c["name"] == "arm collision"]
    assert note["passed"]
    assert note["detail"].startswith("the arm is not checked (scene.arm: unchecked)")


def test_plan_says_the_arm_is_not_checked(tmp_path: Path) -> None:
    # No controller listens on this address: the flange comes from the command line only.
    scene = "  arm: unchecked\n  clearance_mm: 5\n  floor_z_mm: 0\n"
    config = write_config(tmp_path, "127.0.0.254", scene=scene, tool=TOOL)
    flange_ur = ["-0.4919", "-0.1333", "0.4879", "2.2214", "2.2214", "0"]
    result = cli(
        "plan", "--config", str(config), "--xyz", "30", "-20", "380",
        "--robot-pose-ur", *flange_ur, "--plot", str(tmp_path / "plan.png"),
    )
    assert result.returncode == 0, result.stderr
    assert (
        "  scene: the arm is not checked (scene.arm: unchecked): only the tool and the held part "
        "are" in result.stdout.splitlines()
    )
