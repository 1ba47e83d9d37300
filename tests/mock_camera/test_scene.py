"""The scene: boxes added, moved and removed, their top-face centres and corners, and where rays
meet the table and the boxes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mocks.camera import Scene


def test_a_box_on_the_table_has_its_top_centre_above_its_footprint() -> None:
    scene = Scene(table_height_m=0.75)
    scene.add_box("a", (0.08, 0.06, 0.05), scene.on_table(0.3, -0.2, 0.4))
    np.testing.assert_allclose(scene.top_centre_m("a"), [0.3, -0.2, 0.80], atol=1e-12)


def test_a_tilted_box_has_its_top_centre_along_its_own_z() -> None:
    scene = Scene()
    T = np.eye(4)
    T[:3, :3] = [[1, 0, 0], [0, 0, -1], [0, 1, 0]]  # turned 90 deg about x: its z is base -y
    T[:3, 3] = [0.1, 0.2, 0.3]
    scene.add_box("a", (0.02, 0.04, 0.10), T)
    np.testing.assert_allclose(scene.top_centre_m("a"), [0.1, 0.1, 0.3], atol=1e-12)


def test_boxes_are_added_moved_and_removed_by_name() -> None:
    scene = Scene()
    scene.add_box("a", (0.1, 0.1, 0.1), scene.on_table(0.0, 0.0))
    scene.move_box("a", scene.on_table(0.5, 0.5))
    np.testing.assert_allclose(scene.top_centre_m("a"), [0.5, 0.5, 0.1])
    scene.remove_box("a")
    assert scene.boxes == {}
    with pytest.raises(KeyError, match="no box named 'a'"):
        scene.move_box("a", np.eye(4))


def test_a_second_box_of_the_same_name_is_refused() -> None:
    scene = Scene()
    scene.add_box("a", (0.1, 0.1, 0.1), np.eye(4))
    with pytest.raises(ValueError, match="already has a box named 'a'"):
        scene.add_box("a", (0.1, 0.1, 0.1), np.eye(4))


@pytest.mark.parametrize("size", [(0.1, 0.0, 0.1), (0.1, -0.1, 0.1), (0.1, math.nan, 0.1)])
def test_a_box_without_volume_is_refused(size: tuple[float, float, float]) -> None:
    with pytest.raises(ValueError, match="3 positive lengths"):
        Scene().add_box("a", size, np.eye(4))


def test_a_scaled_box_pose_is_refused() -> None:
    T = np.eye(4)
    T[:3, :3] *= 1000.0
    with pytest.raises(ValueError, match="not a rigid transform"):
        Scene().add_box("a", (0.1, 0.1, 0.1), T)


def test_rays_meet_the_table_in_front_and_on_its_rectangle_only() -> None:
    scene = Scene(table_height_m=0.0, table_min_xy_m=(-1.0, -1.0), table_max_xy_m=(1.0, 1.0))
    directions = np.array([
        [0.0, 0.0, -1.0],  # straight down: 1 m
        [0.5, 0.0, -1.0],  # slanted: lands at x = 0.5
        [0.0, 0.0, 1.0],  # up: away from the table
        [1.0, 0.0, 0.0],  # horizontal: parallel to it
        [2.0, 0.0, -1.0],  # would land at x = 2, off the table's edge at x = 1
    ]).T
    t = scene.table_distances(np.array([0.0, 0.0, 1.0]), directions)
    np.testing.assert_allclose(t[:2], [1.0, 1.0])
    assert np.isinf(t[2:]).all()


def test_rays_meet_a_box_where_they_enter_it() -> None:
    scene = Scene()
    box = scene.add_box("a", (0.2, 0.4, 0.1), scene.on_table(0.0, 0.0, math.pi / 2))
    directions = np.array([
        [0.0, 0.0, -1.0],  # onto the top face (z = 0.1) from z = 1
        [0.19, 0.0, -1.0],  # turned 90 deg the box is 0.4 long along x: the top face at x = 0.171
        [0.0, 0.12, -1.0],  # beside it: it is 0.2 wide along y, the ray is at y = 0.108 there
    ]).T
    t = box.hit_distances(np.array([0.0, 0.0, 1.0]), directions)
    np.testing.assert_allclose(t[:2], [0.9, 0.9])
    assert np.isinf(t[2])
    side = box.hit_distances(np.array([0.5, 0.0, 0.05]), np.array([[-1.0], [0.0], [0.0]]))
    np.testing.assert_allclose(side, [0.3])  # horizontally onto the side face at x = 0.2


def test_a_ray_along_a_box_face_misses_it_and_a_ray_from_inside_sees_nothing_of_it() -> None:
    box = Scene().add_box("a", (0.2, 0.2, 0.2), np.eye(4))  # x, y in [-0.1, 0.1], z in [0, 0.2]
    grazing = box.hit_distances(np.array([0.1, -1.0, 0.1]), np.array([[0.0], [1.0], [0.0]]))
    inside = box.hit_distances(np.array([0.0, 0.0, 0.1]), np.array([[0.0], [0.0], [1.0]]))
    assert np.isinf(grazing).all()
    assert np.isinf(inside).all()


def test_a_box_has_its_corners_where_its_pose_puts_them() -> None:
    box = Scene().add_box("a", (0.2, 0.4, 0.1), Scene().on_table(1.0, 2.0, math.pi / 2))
    corners = box.corners_m()
    np.testing.assert_allclose(corners.min(axis=0), [0.8, 1.9, 0.0], atol=1e-12)
    np.testing.assert_allclose(corners.max(axis=0), [1.2, 2.1, 0.1], atol=1e-12)


def test_a_bin_is_a_floor_and_four_walls_around_its_inner_floor() -> None:
    scene = Scene()
    names = scene.add_bin("b", (0.5, 0.0, 0.01), (0.26, 0.18, 0.10), 0.01, 0.01)
    assert names == ["b floor", "b wall east", "b wall west", "b wall north", "b wall south"]
    np.testing.assert_allclose(scene.top_centre_m("b floor"), [0.5, 0.0, 0.01], atol=1e-12)
    np.testing.assert_allclose(scene.top_centre_m("b wall east"), [0.635, 0.0, 0.11], atol=1e-12)
    np.testing.assert_allclose(scene.top_centre_m("b wall south"), [0.5, -0.095, 0.11],
                               atol=1e-12)
    # A ray straight down through the middle meets the inner floor, one beside it a wall's top.
    down = np.array([[0.0], [0.0], [-1.0]])
    floor = scene.boxes["b floor"].hit_distances(np.array([0.5, 0.0, 1.0]), down)
    wall = scene.boxes["b wall east"].hit_distances(np.array([0.635, 0.0, 1.0]), down)
    assert floor[0] == pytest.approx(0.99)
    assert wall[0] == pytest.approx(0.89)
