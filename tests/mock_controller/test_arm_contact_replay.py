"""mocks/contact_check.py replays the arm's links: the simulator's own forward kinematics of the
traced joints places the package's link solids (given as data), and a cycle at which a link
touches a box counts; one at which it does not, does not."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from handeye_pick.arm.kinematics import link_poses
from handeye_pick.arm.models import arm_model
from mocks.contact_check import count_contacts, main
from mocks.ur_controller.kinematics import MODELS, forward, matrix_to_pose

MODEL = arm_model("ur5e")
Q0 = np.array([0.0, -1.63039, 1.338517, -1.278923, -1.570796, 0.0])
TCP = [0.0, 0.0, 0.15, 0.0, 0.0, 0.0]


def _links() -> list[dict[str, object]]:
    return [
        {"name": link.name, "kind": link.kind, "frame": link.frame, "radius_m": link.radius_m,
         "length_m": link.length_m, "T_frame_solid": link.T_frame_solid.tolist()}
        for link in MODEL.links
    ]


def _config(tmp_path: Path, box_centre: np.ndarray) -> Path:
    x, y, z = box_centre
    (tmp_path / "cell.yaml").write_text(
        f"robot: {{tcp_offset: {TCP}, model: ur5e}}\n"
        "scene:\n  boxes:\n"
        f"    - {{name: post, pose: [{x}, {y}, {z}, 0, 0, 0], size_mm: [40, 40, 40]}}\n"
        "tool:\n  shape:\n"
        "    - {name: probe, box: {size_mm: [10, 10, 10], pose: [0, 0, 0.15, 0, 0, 0]}}\n"
    )
    return tmp_path / "cell.yaml"


def _motion(turn_rad: float) -> dict[str, object]:
    """Joint 1 turning from Q0 by up to ``turn_rad`` in 20 cycles, traced as the simulator
    records it."""
    qs = [Q0 + np.array([t, 0, 0, 0, 0, 0]) for t in np.linspace(0.0, turn_rad, 21)]
    sim = MODELS["ur5e"]
    offset = np.eye(4)
    offset[2, 3] = 0.15
    tcp = [matrix_to_pose(forward(sim, q) @ offset).tolist() for q in qs]
    return {"motion": 1, "tcp_trace": tcp, "q_trace": [q.tolist() for q in qs]}


def test_a_forearm_turning_through_a_post_is_counted(tmp_path: Path) -> None:
    forearm = [link.name for link in MODEL.links].index("forearm")
    # The post stands where the forearm is at the end of the turn, 0.5 rad from the start.
    post = link_poses(MODEL, Q0 + np.array([0.5, 0, 0, 0, 0, 0]))[0, forearm, :3, 3]
    config = _config(tmp_path, post)
    hit = count_contacts(config, [_motion(0.5)], _links())
    assert hit.samples == 21
    assert 0 < hit.link_contacts < 21
    assert hit.contacts == 0  # the probe at the TCP never comes near it
    clear = count_contacts(config, [_motion(-0.5)], _links())  # turning away from it
    assert (clear.samples, clear.contacts, clear.link_contacts) == (21, 0, 0)
    assert count_contacts(config, [_motion(0.5)]).link_contacts == 0  # no links: not replayed
    (tmp_path / "motions.jsonl").write_text(json.dumps(_motion(0.5)) + "\n")
    (tmp_path / "links.json").write_text(json.dumps(_links()))
    args = ["--config", str(config), "--motions", str(tmp_path / "motions.jsonl")]
    assert main([*args, "--links", str(tmp_path / "links.json")]) == 1
