"""The simulated camera's world: a table and boxes in the robot base frame, and where rays meet
them (the camera decides which rays to ask about).

Frames and units: every pose is ``T_base_x`` (the box in the robot base frame), a float64 4x4 in
metres, as the simulated controller's base frame (z up). A box's own frame has its origin at the
centre of its bottom face, x and y along its edges and z up through its top face, so a box resting
on the table has ``T_base_box[2, 3] == table_height_m`` and its top face centre is
``T_base_box @ [0, 0, height, 1]``.

Never imports ``handeye_pick``: the simulator must not share maths with the code under test.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike

from mocks.camera.frames import Matrix, checked_transform


@dataclass(frozen=True)
class Box:
    """A box: edge lengths ``size_m`` (m, along its own x, y, z) at ``T_base_box``."""

    size_m: tuple[float, float, float]
    T_base_box: Matrix  # origin at the bottom face centre, z up through the top face (m)

    def top_centre_m(self) -> Matrix:
        """The centre of the top face in the base frame, shape (3,), metres."""
        centre: Matrix = self.T_base_box[:3, :3] @ [0.0, 0.0, self.size_m[2]]
        return centre + self.T_base_box[:3, 3]

    def corners_m(self) -> Matrix:
        """The eight corners in the base frame, shape (8, 3), metres."""
        x, y, z = self.size_m[0] / 2.0, self.size_m[1] / 2.0, self.size_m[2]
        corners = np.array([[sx * x, sy * y, h] for sx in (-1, 1) for sy in (-1, 1)
                            for h in (0.0, z)])
        result: Matrix = corners @ self.T_base_box[:3, :3].T + self.T_base_box[:3, 3]
        return result

    def hit_distances(self, origin_base_m: Matrix, directions_base: Matrix) -> Matrix:
        """Ray parameter ``t`` of the first hit of each ray ``origin + t * direction`` (inf: none).

        ``origin_base_m`` shape (3,), ``directions_base`` shape (3, N), base frame. Slab test in
        the box's own frame, one axis at a time on contiguous rows (fast for large N). A ray that
        starts inside the box sees nothing of it.
        """
        R = self.T_base_box[:3, :3]
        origin = R.T @ (origin_base_m - self.T_base_box[:3, 3])
        directions = R.T @ directions_base
        half_x, half_y = self.size_m[0] / 2.0, self.size_m[1] / 2.0
        low = (-half_x, -half_y, 0.0)
        high = (half_x, half_y, self.size_m[2])
        t_enter = np.full(directions.shape[1], -np.inf)
        t_leave = np.full(directions.shape[1], np.inf)
        for axis in range(3):
            # A direction component of 0 gives +-inf (parallel to the slab) or NaN (0 * inf: a
            # ray in a face's plane); fmin/fmax skip the NaN, so grazing rays miss.
            with np.errstate(divide="ignore", invalid="ignore"):
                inverse = 1.0 / directions[axis]
                t_low = (low[axis] - origin[axis]) * inverse
                t_high = (high[axis] - origin[axis]) * inverse
            np.fmax(t_enter, np.fmin(t_low, t_high), out=t_enter)
            np.fmin(t_leave, np.fmax(t_low, t_high), out=t_leave)
        hit = (t_enter <= t_leave) & (t_enter > 0.0)
        return np.where(hit, t_enter, np.inf)


class Scene:
    """A horizontal table (a rectangle at ``table_height_m``) and named boxes, in the base frame.

    Tests and examples add, move and remove boxes between captures; the camera renders whatever
    the scene holds at the time of the capture. Metres throughout.
    """

    def __init__(
        self,
        table_height_m: float = 0.0,
        table_min_xy_m: tuple[float, float] = (-1.0, -1.0),
        table_max_xy_m: tuple[float, float] = (1.0, 1.0),
    ):
        if not all(lo < hi for lo, hi in zip(table_min_xy_m, table_max_xy_m, strict=True)):
            raise ValueError(
                f"table_min_xy_m {table_min_xy_m} must be below table_max_xy_m {table_max_xy_m}"
            )
        self.table_height_m = float(table_height_m)
        self.table_min_xy_m = (float(table_min_xy_m[0]), float(table_min_xy_m[1]))
        self.table_max_xy_m = (float(table_max_xy_m[0]), float(table_max_xy_m[1]))
        self._boxes: dict[str, Box] = {}

    # --- the boxes ------------------------------------------------------------------------------

    @property
    def boxes(self) -> dict[str, Box]:
        """A copy of the boxes by name."""
        return dict(self._boxes)

    def on_table(self, x_m: float, y_m: float, yaw_rad: float = 0.0) -> Matrix:
        """``T_base_box`` of a box standing on the table at (x, y), turned ``yaw_rad`` about z."""
        c, s = math.cos(yaw_rad), math.sin(yaw_rad)
        T = np.eye(4)
        T[:3, :3] = [[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]
        T[:3, 3] = [x_m, y_m, self.table_height_m]
        return T

    def add_box(self, name: str, size_m: tuple[float, float, float], T_base_box: ArrayLike) -> Box:
        """Add a box (edge lengths in m, pose in base); ValueError if the name is taken."""
        if name in self._boxes:
            raise ValueError(f"the scene already has a box named {name!r}")
        if len(size_m) != 3 or not all(math.isfinite(s) and s > 0.0 for s in size_m):
            raise ValueError(f"box {name!r}: size_m must be 3 positive lengths, got {size_m}")
        box = Box((float(size_m[0]), float(size_m[1]), float(size_m[2])),
                  checked_transform(T_base_box, f"box {name!r}: T_base_box"))
        self._boxes[name] = box
        return box

    def add_bin(
        self,
        name: str,
        floor_centre_m: tuple[float, float, float],
        inner_m: tuple[float, float, float],
        wall_m: float,
        floor_m: float,
    ) -> list[str]:
        """Add an open bin, its sides along base x and y: a floor and four walls, each a box
        named ``"<name> floor"``, ``"<name> wall east"`` (+x), west, north (+y), south.
        ``floor_centre_m`` is the centre of its inner floor (the top of the floor box),
        ``inner_m`` the inside length (x), width (y) and wall height (z). Returns the names."""
        x, y, z = inner_m
        cx, cy, cz = floor_centre_m
        outer_x, outer_y = x + 2.0 * wall_m, y + 2.0 * wall_m
        # (name, size, bottom face centre): east and west span the outer width (closed corners)
        parts = [
            ("floor", (outer_x, outer_y, floor_m), (cx, cy, cz - floor_m)),
            ("wall east", (wall_m, outer_y, z), (cx + (x + wall_m) / 2.0, cy, cz)),
            ("wall west", (wall_m, outer_y, z), (cx - (x + wall_m) / 2.0, cy, cz)),
            ("wall north", (x, wall_m, z), (cx, cy + (y + wall_m) / 2.0, cz)),
            ("wall south", (x, wall_m, z), (cx, cy - (y + wall_m) / 2.0, cz)),
        ]
        names = []
        for part, size, (bx, by, bz) in parts:
            T = np.eye(4)
            T[:3, 3] = [bx, by, bz]
            self.add_box(f"{name} {part}", size, T)
            names.append(f"{name} {part}")
        return names

    def move_box(self, name: str, T_base_box: ArrayLike) -> Box:
        """Put box ``name`` at a new pose (m); KeyError if there is no such box."""
        T = checked_transform(T_base_box, f"box {name!r}: T_base_box")
        box = Box(self._box(name).size_m, T)
        self._boxes[name] = box
        return box

    def remove_box(self, name: str) -> None:
        """Take box ``name`` out of the scene; KeyError if there is no such box."""
        self._box(name)
        del self._boxes[name]

    def top_centre_m(self, name: str) -> Matrix:
        """Ground truth: the centre of box ``name``'s top face in the base frame (m)."""
        return self._box(name).top_centre_m()

    def _box(self, name: str) -> Box:
        if name not in self._boxes:
            raise KeyError(f"the scene has no box named {name!r} (boxes: {sorted(self._boxes)})")
        return self._boxes[name]

    # --- ray casting --------------------------------------------------------------------------

    def table_distances(self, origin_base_m: Matrix, directions_base: Matrix) -> Matrix:
        """Ray parameter ``t`` where each ray ``origin + t * direction`` meets the table, inf
        where it misses (it runs off the table's rectangle, parallel to it, or away from it).

        ``origin_base_m`` shape (3,), ``directions_base`` shape (3, N), base frame, metres.
        """
        with np.errstate(divide="ignore", invalid="ignore"):  # horizontal rays: inf or NaN
            t = (self.table_height_m - origin_base_m[2]) / directions_base[2]
            x = origin_base_m[0] + t * directions_base[0]
            y = origin_base_m[1] + t * directions_base[1]
        (x_min, y_min), (x_max, y_max) = self.table_min_xy_m, self.table_max_xy_m
        hit = (t > 0.0) & (x >= x_min) & (x <= x_max) & (y >= y_min) & (y <= y_max)
        return np.where(hit, t, np.inf)
