"""Clouds of the simulated camera against ground truth worked out here from the geometry."""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from mocks.camera import DEFAULT_INTRINSICS, Intrinsics, Scene, SimulatedCamera
from mocks.ur_controller import SimulatedController
from tests.mock_camera.helpers import looking_down, pose, to_base_m

TABLE_M = 0.7
CAMERA_HEIGHT_M = 0.5  # above the table


def _scene_with_box(x: float = 0.02, y: float = -0.01, yaw: float = 0.3) -> Scene:
    scene = Scene(table_height_m=TABLE_M)
    scene.add_box("box", (0.08, 0.05, 0.06), scene.on_table(x, y, yaw))
    return scene


def test_the_cloud_is_zivids_layout_float32_rows_by_columns_in_millimetres() -> None:
    camera = SimulatedCamera(Scene(), T_base_cam=looking_down(0.0, 0.0, 1.0))
    cloud = camera.capture()
    assert cloud.shape == (120, 160, 3)
    assert cloud.dtype == np.float32
    # Straight down onto a table 1 m below: every depth is 1000 mm, x grows with the column
    # and y with the row (Zivid: x right, y down in the image).
    np.testing.assert_allclose(cloud[:, :, 2], 1000.0)
    assert (np.diff(cloud[:, :, 0], axis=1) > 0).all()
    assert (np.diff(cloud[:, :, 1], axis=0) > 0).all()


def test_the_table_is_where_its_height_says() -> None:
    camera = SimulatedCamera(Scene(table_height_m=TABLE_M),
                             T_base_cam=looking_down(0.1, 0.2, TABLE_M + CAMERA_HEIGHT_M, 0.7))
    cloud = camera.capture()
    np.testing.assert_allclose(cloud[:, :, 2], CAMERA_HEIGHT_M * 1000.0, rtol=1e-6)
    points = to_base_m(camera.T_base_cam(), cloud)
    np.testing.assert_allclose(points[:, :, 2], TABLE_M, atol=1e-6)


def test_the_box_top_centre_is_seen_at_its_pixel_at_its_depth() -> None:
    scene = _scene_with_box()
    T_base_cam = looking_down(0.0, 0.0, TABLE_M + CAMERA_HEIGHT_M)
    camera = SimulatedCamera(scene, T_base_cam=T_base_cam)
    top = scene.top_centre_m("box")
    p_cam = np.linalg.inv(T_base_cam) @ [*top, 1.0]
    col, row = DEFAULT_INTRINSICS.project(p_cam[:3])
    point = camera.capture()[round(row), round(col)]
    assert point[2] == pytest.approx((CAMERA_HEIGHT_M - 0.06) * 1000.0, rel=1e-6)
    # The pixel's centre is within half a pixel of the projection: its point is on the top face
    # within half a pixel's footprint (0.44 m * tan(30 deg) / 80 px / 2 = 1.6 mm) of the centre.
    assert np.linalg.norm(point[:2] - p_cam[:2] * 1000.0) < 2.3


def test_the_top_face_covers_exactly_the_pixels_whose_rays_pass_through_it() -> None:
    scene = _scene_with_box(yaw=0.9)
    T_base_cam = looking_down(0.03, 0.0, TABLE_M + CAMERA_HEIGHT_M, -0.4)
    cloud = SimulatedCamera(scene, T_base_cam=T_base_cam).capture()
    # Each pixel's ray meets the plane of the top face at (x, y); it hits the top face when
    # that point lies inside the face's rectangle (in the box's frame).
    rays = DEFAULT_INTRINSICS.rays()
    depth = CAMERA_HEIGHT_M - 0.06
    p_base = (T_base_cam[:3, :3] @ (rays * depth)).T + T_base_cam[:3, 3]
    T_box_base = np.linalg.inv(scene.boxes["box"].T_base_box)
    p_box = p_base @ T_box_base[:3, :3].T + T_box_base[:3, 3]
    inside = (np.abs(p_box[:, 0]) < 0.04) & (np.abs(p_box[:, 1]) < 0.025)
    on_top = np.abs(cloud[:, :, 2].ravel() - depth * 1000.0) < 1e-3
    assert inside.sum() > 100
    np.testing.assert_array_equal(on_top, inside)


def test_rays_that_miss_everything_are_nan() -> None:
    # Tilted 60 deg from straight down, with a 60 deg field of view: the upper rows look above
    # the horizon and the table ends 1 m away.
    T_base_cam = looking_down(0.0, 0.0, 1.0) @ pose(0, 0, 0, math.radians(60), 0, 0)
    camera = SimulatedCamera(Scene(table_height_m=0.0, table_min_xy_m=(-1.0, -1.0),
                                   table_max_xy_m=(1.0, 1.0)), T_base_cam=T_base_cam)
    cloud = camera.capture()
    missed = np.isnan(cloud).all(axis=2)
    assert missed.any()
    assert not missed.all()
    assert (np.isnan(cloud).any(axis=2) == missed).all()  # a pixel is all NaN or all numbers
    points = to_base_m(T_base_cam, cloud)[~missed]
    assert (np.abs(points[:, :2]) <= 1.0 + 1e-6).all()
    # The rows without data are the upper rows (image y down), the rays above the table's edge.
    assert missed[0].all()
    assert not missed[-1].any()


def test_eye_in_hand_and_eye_to_hand_mounts_agree_with_the_chain() -> None:
    scene = _scene_with_box()
    T_flange_cam = pose(0.0, -0.075, 0.055, 0.02, -0.01, math.pi / 2)
    T_base_flange = pose(0.01, 0.02, TABLE_M + 0.55, math.pi, 0.0, 0.0)  # tool down
    in_hand = SimulatedCamera(scene, T_flange_cam=T_flange_cam)
    fixed = SimulatedCamera(scene, T_base_cam=T_base_flange @ T_flange_cam)
    np.testing.assert_allclose(in_hand.T_base_cam(T_base_flange), T_base_flange @ T_flange_cam)
    np.testing.assert_array_equal(in_hand.capture(T_base_flange), fixed.capture())


def test_the_mount_decides_whether_a_capture_needs_the_flange_pose() -> None:
    scene = Scene()
    with pytest.raises(ValueError, match="needs the flange pose"):
        SimulatedCamera(scene, T_flange_cam=np.eye(4)).capture()
    with pytest.raises(ValueError, match="does not move with the flange"):
        SimulatedCamera(scene, T_base_cam=np.eye(4)).capture(np.eye(4))
    with pytest.raises(ValueError, match="exactly one of"):
        SimulatedCamera(scene, T_flange_cam=np.eye(4), T_base_cam=np.eye(4))


def test_intrinsics_from_a_field_of_view() -> None:
    intrinsics = Intrinsics.from_fov(640, 480, 90.0)
    assert intrinsics.fx_px == pytest.approx(320.0)
    assert (intrinsics.cx_px, intrinsics.cy_px) == (319.5, 239.5)
    # The edge of the image (pixel edge -0.5) is 45 degrees off the optical axis.
    assert intrinsics.project([-1.0, 0.0, 1.0]) == pytest.approx((-0.5, 239.5))


_poses = st.tuples(
    st.floats(-0.1, 0.1), st.floats(-0.1, 0.1), st.floats(0.1, 0.8),  # camera above the table
    # yaw; tilt from straight down up to nearly horizontal (the box can then reach behind the
    # camera's image plane); the direction of the tilt
    st.floats(-math.pi, math.pi), st.floats(0.0, 1.4), st.floats(-math.pi, math.pi),
)


@settings(max_examples=30, deadline=None)
@given(camera=_poses, box_x=st.floats(-0.1, 0.1), box_yaw=st.floats(-math.pi, math.pi))
def test_every_point_is_the_first_surface_on_its_pixels_ray(
    camera: tuple[float, ...], box_x: float, box_yaw: float
) -> None:
    x, y, height, yaw, tilt, tilt_axis = camera
    scene = _scene_with_box(x=box_x, yaw=box_yaw)
    tilt_rotation = pose(0, 0, 0, tilt * math.cos(tilt_axis), tilt * math.sin(tilt_axis), 0)
    T_base_cam = looking_down(x, y, TABLE_M + height, yaw) @ tilt_rotation
    cloud = SimulatedCamera(scene, T_base_cam=T_base_cam).capture()
    valid = ~np.isnan(cloud).any(axis=2)
    assert valid.any()
    # On its pixel's ray: the point projects back onto its own pixel centre.
    rows, cols = np.nonzero(valid)
    points = cloud[valid].astype(np.float64)
    i = DEFAULT_INTRINSICS
    np.testing.assert_allclose(i.cx_px + i.fx_px * points[:, 0] / points[:, 2], cols, atol=1e-3)
    np.testing.assert_allclose(i.cy_px + i.fy_px * points[:, 1] / points[:, 2], rows, atol=1e-3)
    # On a surface: the table plane, or the boundary of the box (inside it, on one face).
    base = to_base_m(T_base_cam, cloud)[valid]
    T_box_base = np.linalg.inv(scene.boxes["box"].T_base_box)
    in_box = base @ T_box_base[:3, :3].T + T_box_base[:3, 3]
    half = np.array([0.04, 0.025])
    inside = (np.abs(in_box[:, :2]) <= half + 1e-6).all(axis=1) & (in_box[:, 2] > -1e-6) \
        & (in_box[:, 2] <= 0.06 + 1e-6)
    gap = np.minimum.reduce([np.abs(np.abs(in_box[:, 0]) - half[0]),
                             np.abs(np.abs(in_box[:, 1]) - half[1]),
                             np.abs(in_box[:, 2] - 0.06)])
    on_box = inside & (gap < 1e-6)
    on_table = np.abs(base[:, 2] - TABLE_M) < 1e-6
    assert (on_box | on_table).all()
    # The first surface: the nearer of table and box on every pixel's ray, all rays tested (the
    # camera tests only the rays near the box's image).
    directions = T_base_cam[:3, :3] @ i.rays()
    nearest = np.minimum(scene.table_distances(T_base_cam[:3, 3], directions),
                         scene.boxes["box"].hit_distances(T_base_cam[:3, 3], directions))
    depth_mm = np.where(np.isfinite(nearest), nearest * 1000.0, np.nan)
    np.testing.assert_allclose(cloud[:, :, 2].ravel(), depth_mm, rtol=1e-6)


def test_a_capture_from_the_simulated_controller_uses_its_flange_pose(
    sim_controller: Callable[..., SimulatedController],
) -> None:
    ctl = sim_controller(instant=True)
    flange_pose = ctl.snapshot().flange_pose
    T_base_flange = np.eye(4)
    T_base_flange[:3, :3] = Rotation.from_rotvec(flange_pose[3:]).as_matrix()
    T_base_flange[:3, 3] = flange_pose[:3]
    scene = Scene(table_height_m=0.0)
    scene.add_box("box", (0.1, 0.1, 0.1), scene.on_table(T_base_flange[0, 3], T_base_flange[1, 3]))
    camera = SimulatedCamera(scene, T_flange_cam=pose(0, 0, 0.05, 0, 0, 0))
    cloud = camera.capture_from(ctl)
    np.testing.assert_array_equal(cloud, camera.capture(T_base_flange))
    # The home pose points the tool down from 488 mm: the box top is 488 - 50 - 100 mm away.
    assert cloud[60, 80, 2] == pytest.approx((T_base_flange[2, 3] - 0.05 - 0.1) * 1000, rel=1e-6)


def test_a_box_reaching_behind_the_camera_is_seen_where_it_is_in_front() -> None:
    # A long box under a camera that looks nearly horizontally along it (towards base -y), 20 mm
    # above its top: half the box is behind the camera, the other half fills the lower part of
    # the image.
    scene = Scene(table_height_m=TABLE_M)
    scene.add_box("long", (0.1, 0.6, 0.05), scene.on_table(0.0, 0.0))
    T_base_cam = looking_down(0.0, 0.0, TABLE_M + 0.07, math.pi) \
        @ pose(0, 0, 0, math.radians(80), 0, 0)
    cloud = SimulatedCamera(scene, T_base_cam=T_base_cam).capture()
    points = to_base_m(T_base_cam, cloud)
    on_top = np.abs(points[:, :, 2] - (TABLE_M + 0.05)) < 1e-6
    assert on_top.sum() > 1000
    assert (points[on_top][:, 1] < 0.0).all()  # the part in front of the camera (-y)
    assert on_top[-1, 80]  # straight below the image centre, the box top
