"""``plan --plot`` draws the arm (plot.py ``arm_at``): the link solids at each stop on the
branch of the model's IK nearest a typical home (elbow up, wrist down), a stop out of reach
left out, drawn in blue, and the caption says the joints come from our IK."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import matplotlib.image
import numpy as np

from handeye_pick.arm.kinematics import flange_poses, link_poses
from handeye_pick.arm.models import arm_model
from handeye_pick.geometry import make_transform
from handeye_pick.plot import ARM_HOME_RAD, arm_at, caption, render_scene
from tests.unit.test_plot import demo_calibration, demo_scene

MODEL = arm_model("ur5e")
NEAR_HOME = np.array(ARM_HOME_RAD) + np.array([0.3, 0.2, -0.3, 0.1, 0.2, 0.4])


def test_the_arm_is_drawn_on_the_branch_nearest_home() -> None:
    segments = arm_at(MODEL, flange_poses(MODEL, NEAR_HOME))
    assert len(segments) == len(MODEL.links)
    poses = link_poses(MODEL, NEAR_HOME)[0]
    for segment, pose, link in zip(segments, poses, MODEL.links, strict=True):
        assert np.allclose(segment.mean(axis=0), pose[:3, 3], atol=1e-9)
        assert np.isclose(np.linalg.norm(segment[1] - segment[0]), link.length_m)


def test_a_stop_out_of_reach_is_left_out() -> None:
    far = make_transform(np.eye(3), [3.0, 0.0, 0.0])[None]
    reached = flange_poses(MODEL, NEAR_HOME)
    assert arm_at(MODEL, far) == ()
    assert len(arm_at(MODEL, np.concatenate([far, reached]))) == len(MODEL.links)


def test_the_arm_is_drawn_in_blue_and_the_caption_says_it_is_our_ik(tmp_path: Path) -> None:
    scene = demo_scene(demo_calibration())
    plain, with_arm = tmp_path / "plain.png", tmp_path / "arm.png"
    render_scene(scene, plain)
    drawn = dataclasses.replace(
        scene,
        arm=arm_at(MODEL, scene.T_base_flange[None]),
        arm_source="drawn from our ur5e IK",
    )
    render_scene(drawn, with_arm)

    def blue(path: Path) -> int:
        rgb = matplotlib.image.imread(path)[:, :, :3]
        return int(((rgb[:, :, 2] > rgb[:, :, 0] + 0.15) & (rgb[:, :, 2] > 0.5)).sum())

    assert blue(with_arm) > blue(plain) + 200
    assert "blue: the arm's links at the stops, drawn from our ur5e IK" in caption(drawn)
    assert "blue:" not in caption(scene)
