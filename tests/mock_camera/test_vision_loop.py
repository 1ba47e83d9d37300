"""examples/vision_loop.py and config/loop.yaml without `handeye-pick run`: the example's box
finding against the simulated camera's ground truth, its scene bookkeeping over five cycles with
the grasp computed by handeye-pick's own config and hand-eye loaders, and poses the simulated
UR5e reaches inside the workspace box."""

from __future__ import annotations

import importlib.util
import math
import sys
from pathlib import Path
from types import ModuleType
from typing import Any

import numpy as np
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from handeye_pick.config.load import load_config
from handeye_pick.hand_eye.files import load_hand_eye
from mocks.ur_controller.kinematics import MODELS, forward, pose_to_matrix, reachable

ROOT = Path(__file__).resolve().parents[2]
CONFIG = ROOT / "config" / "loop.yaml"
UR5E = MODELS["ur5e"]


def _load_example() -> ModuleType:
    path = ROOT / "examples" / "vision_loop.py"
    spec = importlib.util.spec_from_file_location("vision_loop", path)
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules["vision_loop"] = module  # dataclasses look their module up while defining
    spec.loader.exec_module(module)
    return module


loop = _load_example()
DOC: dict[str, Any] = yaml.safe_load(CONFIG.read_text())


def _tool_down(T: np.ndarray) -> bool:
    return bool(np.allclose(T[:3, 2], [0.0, 0.0, -1.0], atol=1e-5))


def _T_flange_tcp() -> np.ndarray:
    return pose_to_matrix(DOC["robot"]["tcp_offset"])


def _capture_flange() -> np.ndarray:
    return forward(UR5E, DOC["poses"]["capture"]["joints_rad"])


def test_the_config_loads_and_its_hand_eye_file_is_the_true_camera_mount() -> None:
    config = load_config(CONFIG)
    calibration = load_hand_eye(config.hand_eye.file, config.hand_eye.mode, config.hand_eye.units)
    camera = loop.build_camera(loop.build_scene(), loop.read_cell(CONFIG))
    np.testing.assert_allclose(calibration.T_cal, camera.T_mount_cam, atol=1e-12)
    assert config.robot.host == loop.read_cell(CONFIG).host


def test_every_fixed_pose_is_reachable_tool_down_and_inside_the_workspace() -> None:
    config = load_config(CONFIG)
    lo, hi = np.array(config.workspace.min_mm), np.array(config.workspace.max_mm)
    T_capture_tcp = _capture_flange() @ _T_flange_tcp()
    place = DOC["place"]
    targets = [T_capture_tcp, pose_to_matrix(DOC["poses"]["home"]["tcp_pose"])]
    for vector in place["poses"]:
        T = pose_to_matrix(vector)
        for up_mm in (0.0, place["approach_mm"], place["retreat_mm"]):
            T_up = T.copy()
            T_up[2, 3] += up_mm / 1000.0
            targets.append(T_up)
    for T_base_tcp in targets:
        assert _tool_down(T_base_tcp)
        assert reachable(UR5E, T_base_tcp @ np.linalg.inv(_T_flange_tcp()))
        position_mm = T_base_tcp[:3, 3] * 1000.0
        assert (lo <= position_mm).all(), position_mm
        assert (position_mm <= hi).all(), position_mm


def test_five_cycles_find_every_box_and_put_it_out_of_view() -> None:
    """The loop's cycles with `run` done by hand: grasp = T_base_flange (capture) @ T_flange_cam
    (the hand-eye file, read by handeye-pick) @ the detection, tool down at the capture's yaw."""
    config = load_config(CONFIG)
    calibration = load_hand_eye(config.hand_eye.file, config.hand_eye.mode, config.hand_eye.units)
    lo, hi = np.array(config.workspace.min_mm), np.array(config.workspace.max_mm)
    scene = loop.build_scene()
    camera = loop.build_camera(scene, loop.read_cell(CONFIG))
    T_base_flange = _capture_flange()
    T_base_cam = calibration.T_base_cam(T_base_flange)
    R_tool = (T_base_flange @ _T_flange_tcp())[:3, :3]
    picked = []
    for cycle, place in enumerate(DOC["place"]["poses"]):
        found = loop.find_boxes(camera.capture(T_base_flange))
        assert len(found) == len(loop.BOXES) - cycle
        T_grasp = np.eye(4)
        T_grasp[:3, :3] = R_tool
        T_grasp[:3, 3] = T_base_cam[:3, :3] @ (found[0] / 1000.0) + T_base_cam[:3, 3]
        name, error_mm = loop.nearest_box(scene, T_grasp[:3, 3])
        assert error_mm < 0.5
        for up_mm in (0.0, config.grasp.approach_mm, config.grasp.retreat_mm):
            T = T_grasp.copy()
            T[2, 3] += up_mm / 1000.0
            assert reachable(UR5E, T @ np.linalg.inv(_T_flange_tcp()))
            assert (lo <= T[:3, 3] * 1000.0).all()
            assert (T[:3, 3] * 1000.0 <= hi).all()
        T_box_before = scene.boxes[name].T_base_box
        loop.place_box(scene, name, T_grasp, pose_to_matrix(place))
        T_box = scene.boxes[name].T_base_box
        np.testing.assert_allclose(T_box[:2, 3], np.array(place[:2]) + T_box_before[:2, 3]
                                   - T_grasp[:2, 3], atol=1e-9)  # carried with the tool
        assert T_box[2, 3] == scene.table_height_m  # dropped onto the table
        picked.append(name)
    assert sorted(picked) == sorted(loop.BOXES)
    assert loop.find_boxes(camera.capture(T_base_flange)) == []


@settings(max_examples=6, deadline=None)
@given(
    shifts=st.lists(st.tuples(st.floats(-0.005, 0.005), st.floats(-0.005, 0.005)),
                    min_size=5, max_size=5),
    yaws=st.lists(st.sampled_from([0.0, 90.0]) | st.floats(-180.0, 180.0), min_size=5,
                  max_size=5),
)
def test_boxes_are_found_within_half_a_millimetre_wherever_they_stand(
    shifts: list[tuple[float, float]], yaws: list[float]
) -> None:
    scene = loop.build_scene()
    for (name, box), (dx, dy), yaw in zip(scene.boxes.items(), shifts, yaws, strict=True):
        x, y = box.T_base_box[0, 3] + dx, box.T_base_box[1, 3] + dy
        scene.move_box(name, scene.on_table(x, y, math.radians(yaw)))
    camera = loop.build_camera(scene, loop.read_cell(CONFIG))
    T_base_cam = camera.T_base_cam(_capture_flange())
    found = loop.find_boxes(camera.capture(_capture_flange()))
    matched = [loop.nearest_box(scene, T_base_cam[:3, :3] @ (p / 1000.0) + T_base_cam[:3, 3])
               for p in found]
    assert sorted(name for name, _ in matched) == sorted(loop.BOXES)
    assert max(error for _, error in matched) < 0.5
