"""The scene renderer: a real PNG of the promised size, frames drawn where the chain puts them."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import matplotlib.image
import numpy as np
import pytest

from handeye_pick.cell.plan import chain_plan
from handeye_pick.config.load import load_config
from handeye_pick.config.schema import PICK_MOVES, BinConfig, SceneConfig
from handeye_pick.detection import detection_from_point_mm
from handeye_pick.errors import InputError
from handeye_pick.geometry import invert, make_transform, rotation_from_rotvec, ur_pose_to_matrix
from handeye_pick.hand_eye.files import HandEyeCalibration, load_hand_eye
from handeye_pick.plot import (
    FIGURE_SIZE_PX,
    Scene,
    caption,
    cloud_to_base_m,
    label_places,
    render_scene,
    scene_frames,
    view_cube,
)
from handeye_pick.scene.layout import scene_boxes

ROOT = Path(__file__).resolve().parents[2]
DEMO_CONFIG = ROOT / "config" / "demo.yaml"
# The simulated UR5e's home flange pose (m, rad): tool pointing down over the table.
T_BASE_FLANGE = ur_pose_to_matrix([-0.4919, -0.1333, 0.4879, 2.2214, 2.2214, 0.0])
POINT_CAM_MM = (30.0, -20.0, 380.0)


def demo_scene(calibration: HandEyeCalibration, cloud_base_m: np.ndarray | None = None) -> Scene:
    """The demo cell's plan for one camera point, built the way ``plan --plot`` builds it."""
    config = load_config(DEMO_CONFIG)
    detection = detection_from_point_mm(POINT_CAM_MM, "test")
    plan = chain_plan(config, calibration, detection, T_BASE_FLANGE, config.robot.T_flange_tcp)
    return Scene(
        mode=calibration.mode.value,
        calibration_file=calibration.path,
        T_base_flange=plan.T_base_flange,
        T_base_tcp=plan.T_base_flange @ plan.T_flange_tcp,
        T_base_cam=plan.T_base_cam,
        T_base_obj=plan.T_base_obj,
        tcp_path=tuple((name, plan.target(name)) for name in PICK_MOVES),
        workspace_min_m=(-0.8, -0.8, 0.02),
        workspace_max_m=(0.8, 0.8, 0.7),
        cloud_base_m=cloud_base_m,
    )


def demo_calibration(invert_on_load: bool = False) -> HandEyeCalibration:
    config = load_config(DEMO_CONFIG)
    return load_hand_eye(config.hand_eye.file, config.hand_eye.mode, "mm", invert_on_load)


def test_png_is_a_real_image_of_the_promised_size(tmp_path: Path) -> None:
    calibration = demo_calibration()
    cloud_cam_mm = np.full((30, 40, 3), np.nan, dtype=np.float32)
    cloud_cam_mm[5:25, 5:35] = [0.0, 0.0, 380.0]
    cloud = cloud_to_base_m(cloud_cam_mm, calibration.T_base_cam(T_BASE_FLANGE))
    path = tmp_path / "scene.png"
    render_scene(demo_scene(calibration, cloud), path)
    image = matplotlib.image.imread(path)
    width, height = FIGURE_SIZE_PX
    assert image.shape[:2] == (height, width)
    rgb = image[:, :, :3]
    # The axis triads are drawn: strongly red, green and blue pixels exist on a white sheet.
    red = (rgb[:, :, 0] > 0.7) & (rgb[:, :, 1] < 0.4) & (rgb[:, :, 2] < 0.4)
    green = (rgb[:, :, 1] > 0.4) & (rgb[:, :, 0] < 0.4) & (rgb[:, :, 2] < 0.4)
    blue = (rgb[:, :, 2] > 0.6) & (rgb[:, :, 0] < 0.4) & (rgb[:, :, 1] < 0.6)
    assert red.sum() > 50
    assert green.sum() > 50
    assert blue.sum() > 50


def test_frames_are_drawn_where_the_chain_puts_them(tmp_path: Path) -> None:
    calibration = demo_calibration()
    scene = demo_scene(calibration)
    drawn = render_scene(scene, tmp_path / "scene.png")
    T_base_cam = T_BASE_FLANGE @ calibration.T_cal
    np.testing.assert_allclose(drawn["camera"], T_base_cam[:3, 3] * 1000.0, atol=1e-9)
    p_base_mm = (T_base_cam[:3, :3] @ np.array(POINT_CAM_MM) / 1000.0 + T_base_cam[:3, 3]) * 1e3
    np.testing.assert_allclose(drawn["object"], p_base_mm, atol=1e-9)
    np.testing.assert_allclose(drawn["grasp"], p_base_mm, atol=1e-9)
    above_mm = np.array([0.0, 0.0, 100.0])  # approach_mm straight up: the tool points down
    np.testing.assert_allclose(drawn["approach"], p_base_mm + above_mm, atol=1e-9)
    np.testing.assert_allclose(drawn["base"], [0.0, 0.0, 0.0])
    assert set(drawn) == {"base", "flange", "tcp", "camera", "object", *PICK_MOVES}


def test_inverted_calibration_draws_the_camera_where_it_cannot_be(tmp_path: Path) -> None:
    good = render_scene(demo_scene(demo_calibration()), tmp_path / "good.png")
    bad_calibration = demo_calibration(invert_on_load=True)
    bad = render_scene(demo_scene(bad_calibration), tmp_path / "bad.png")
    # The demo camera hangs 55 mm below the flange face, looking down past the tool. An
    # inverted T_flange_cam keeps its distance to the flange but puts it on the other side of
    # the flange face, inside the wrist, some 150 mm from where it is mounted ...
    T_flange_cam_bad = invert(T_BASE_FLANGE) @ bad_calibration.T_base_cam(T_BASE_FLANGE)
    assert T_flange_cam_bad[2, 3] < -0.05
    assert np.linalg.norm(bad["camera"] - good["camera"]) > 100.0
    # ... and the object (and every target with it) lands more than 100 mm off.
    assert np.linalg.norm(bad["object"] - good["object"]) > 100.0
    assert np.linalg.norm(bad["grasp"] - good["grasp"]) > 100.0


def test_cloud_subsample_drops_missing_points_and_lands_in_base() -> None:
    T_base_cam = make_transform(rotation_from_rotvec([np.pi, 0.0, 0.0]), [0.5, 0.1, 1.2])
    cloud_mm = np.full((100, 120, 3), np.nan, dtype=np.float32)
    cloud_mm[:, :60] = [10.0, 20.0, 1000.0]
    points = cloud_to_base_m(cloud_mm, T_base_cam, max_points=1000)
    assert 400 <= len(points) <= 1000
    assert np.all(np.isfinite(points))
    # camera looking down from 1.2 m: (10, 20, 1000) mm -> base (0.51, 0.08, 0.2) m
    np.testing.assert_allclose(points, np.tile([0.51, 0.08, 0.2], (len(points), 1)), atol=1e-6)
    assert cloud_to_base_m(np.full((4, 4, 3), np.nan), T_base_cam).shape == (0, 3)


def test_unwritable_path_is_an_input_error(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="scene picture"):
        render_scene(demo_scene(demo_calibration()), tmp_path / "missing" / "scene.png")


def test_the_scene_s_boxes_are_drawn_in_grey(tmp_path: Path) -> None:
    """A bin beside the plan is drawn: grey pixels appear that the plan alone has none of."""
    calibration = demo_calibration()
    bin_ = BinConfig("parts", ur_pose_to_matrix([-0.3, 0.2, 0.0, 0, 0, 0]), (300, 200, 150), 10, 10)
    plain, with_bin = tmp_path / "plain.png", tmp_path / "bin.png"
    render_scene(demo_scene(calibration), plain)
    scene = dataclasses.replace(
        demo_scene(calibration), obstacles=tuple(scene_boxes(SceneConfig(bins=(bin_,))))
    )
    render_scene(scene, with_bin)

    def grey(path: Path) -> int:
        rgb = matplotlib.image.imread(path)[:, :, :3]
        spread = rgb.max(axis=2) - rgb.min(axis=2)
        return int(((spread < 0.05) & (rgb[:, :, 0] > 0.35) & (rgb[:, :, 0] < 0.65)).sum())

    assert grey(with_bin) > grey(plain) + 500


def test_the_views_fit_the_frames_not_the_workspace() -> None:
    """A 1.6 m workspace must not shrink a pick's frames to one smear: the views are sized by the
    frames (the base included), and every frame lies inside them."""
    scene = demo_scene(demo_calibration())
    centre, half = view_cube(scene)
    assert half < 400.0  # the workspace is 1600 mm across
    for label, T in scene_frames(scene):
        assert np.all(np.abs(T[:3, 3] * 1000.0 - centre) <= half), label


def test_the_caption_names_the_workspace_and_a_scene_only_when_there_is_one() -> None:
    scene = demo_scene(demo_calibration())
    assert "orange: workspace (x -800..800, y -800..800, z 20..700)" in caption(scene)
    assert "grey: scene" not in caption(scene)
    bin_ = BinConfig("parts", ur_pose_to_matrix([-0.3, 0.2, 0.0, 0, 0, 0]), (300, 200, 150), 10, 10)
    with_bin = dataclasses.replace(scene, obstacles=tuple(scene_boxes(SceneConfig(bins=(bin_,)))))
    assert "grey: scene" in caption(with_bin)


def test_labels_of_frames_close_together_do_not_cover_each_other() -> None:
    labels = ["flange, tcp", "camera", "approach, retreat", "object, grasp", "base"]
    anchors = np.array([[0.10, 0.30], [0.14, 0.29], [0.12, 0.295], [0.13, 0.285], [0.9, 0.5]])
    places = label_places(anchors, labels)
    boxes = [(x, y, len(label) * 0.012) for (x, y), label in zip(places, labels, strict=True)]
    for i, (x1, y1, w1) in enumerate(boxes):
        for x2, y2, w2 in boxes[i + 1 :]:
            apart_across = x1 + w1 <= x2 or x2 + w2 <= x1
            assert apart_across or abs(y1 - y2) >= 0.03 - 1e-12
    assert places[4] == pytest.approx((0.91, 0.5))  # alone: right beside its frame
    assert places[0] == pytest.approx((0.11, 0.30))  # the highest of the cluster stays put
