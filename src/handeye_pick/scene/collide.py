"""The swept check: every solid of the tool (and the held part) along every piece of a sequence's
path, against every obstacle of the scene, keeping ``scene.clearance_mm`` (docs/scene.md).

The sweep steps by conservative advancement. At a pose, each solid's distance to the nearest
obstacle, less the distance it must keep, is its margin; no point of a solid within ``reach`` of
the TCP moves farther than ``rate * ds`` while the piece advances by ``ds``
(``path.Piece.rate_m``), so advancing by the smallest ``margin / rate`` cannot bring any solid
closer than it must keep. A margin below ``PROOF_TOLERANCE_M`` refuses: the path may pass
within the clearance there. Distances come from python-fcl; a cheap lower bound (a solid's
bounding ball against an obstacle's box) stands in for a pair farther apart than ``NEAR_M``,
which only makes the steps shorter.

The part being grasped is no obstacle; once held it is a solid of the tool, and on its lift-off
and its set-down (where it rests on a surface) it keeps no clearance but may not come more than
``PART_CONTACT_M`` into anything.

Frames and units: ``T_base_*`` float64 4x4 in metres in the base frame; messages in mm.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import fcl
import numpy as np
from numpy.typing import NDArray

from handeye_pick.geometry import Transform
from handeye_pick.safety import CheckResult
from handeye_pick.scene.path import Piece
from handeye_pick.scene.shapes import Obstacle, Solid

PROOF_TOLERANCE_M = 0.0005
"""A solid this close to what it must keep is refused: the sweep could only creep on."""
PART_CONTACT_M = 0.002
"""How far the held part may press into the surface it is lifted from or set down on: a
detection's and a place pose's error."""
NEAR_M = 0.03
"""Pairs whose lower bound is farther than this beyond what they must keep get no exact
distance."""
SCAN_SAMPLES = 11
"""Poses a refused piece is scanned at for the deepest point of its collision."""
CHECK = "collision"

_REQUEST = fcl.DistanceRequest(enable_signed_distance=True)


@dataclass(frozen=True)
class _Nearest:
    margin_m: float  # distance less what must be kept (negative: too close)
    distance_m: float
    solid: int
    obstacle: int


class Sweep:
    """The obstacles of a scene and the clearance, ready to sweep solids past them."""

    def __init__(self, obstacles: Sequence[Obstacle], clearance_m: float) -> None:
        self.obstacles = list(obstacles)
        self.clearance_m = clearance_m
        self._R = np.array([o.T_base_box[:3, :3] for o in self.obstacles])  # (n, 3, 3)
        self._centre = np.array([o.T_base_box[:3, 3] for o in self.obstacles])  # (n, 3)
        self._half = np.array([o.size_m / 2.0 for o in self.obstacles])  # (n, 3)

    def _lower_bounds(self, centres: NDArray[np.float64]) -> NDArray[np.float64]:
        """Distance from each solid centre (k, 3) to each obstacle box (n): shape (k, n)."""
        local = np.einsum("nji,knj->kni", self._R, centres[:, None, :] - self._centre[None])
        outside = np.maximum(np.abs(local) - self._half[None], 0.0)
        bounds: NDArray[np.float64] = np.sqrt(np.einsum("kni,kni->kn", outside, outside))
        return bounds

    def _distance(self, solid: Solid, obstacle: int) -> float:
        result = fcl.DistanceResult()
        return float(
            fcl.distance(solid.geometry, self.obstacles[obstacle].geometry, _REQUEST, result)
        )

    def margins(
        self, piece: Piece, group: Group, T_base_tcp: Transform, near_m: float = NEAR_M
    ) -> tuple[NDArray[np.float64], _Nearest]:
        """Each solid's margin at ``T_base_tcp`` (a lower bound: exact for pairs within
        ``near_m`` of what they must keep), and the pair with the smallest."""
        poses = T_base_tcp @ group.T_tcp_solids  # (k, 4, 4)
        keep = np.where(group.part & piece.contact, -PART_CONTACT_M, self.clearance_m)
        distance = self._lower_bounds(poses[:, :3, 3]) - group.radii[:, None]
        placed: set[int] = set()
        for i, j in zip(*np.nonzero(distance < (keep + near_m)[:, None]), strict=True):
            solid = group.solids[i]
            if i not in placed:
                solid.geometry.setRotation(poses[i, :3, :3])
                solid.geometry.setTranslation(poses[i, :3, 3])
                placed.add(i)
            distance[i, j] = self._distance(solid, j)
        margin = distance - keep[:, None]
        i, j = np.unravel_index(int(np.argmin(margin)), margin.shape)
        nearest = _Nearest(float(margin[i, j]), float(distance[i, j]), int(i), int(j))
        per_solid: NDArray[np.float64] = margin.min(axis=1)
        return per_solid, nearest

    def sweep(self, piece: Piece, group: Group) -> tuple[float | None, _Nearest]:
        """Advance along ``piece``; (None, nearest pair seen) when it keeps clear, else
        (s, the pair) where a margin fell below ``PROOF_TOLERANCE_M``."""
        rates = np.array([piece.rate_m(solid.reach_m) for solid in group.solids])
        moving = rates > 0.0
        s = 0.0
        closest = _Nearest(np.inf, np.inf, 0, 0)
        while True:
            margins, nearest = self.margins(piece, group, piece.pose(s))
            if nearest.margin_m < closest.margin_m:
                closest = nearest
            if nearest.margin_m < PROOF_TOLERANCE_M:
                return s, nearest
            if s >= 1.0 or not moving.any():
                return None, closest
            s = min(1.0, s + float(np.min(margins[moving] / rates[moving])))

    def deepest(self, piece: Piece, group: Group, s_found: float) -> tuple[float, _Nearest]:
        """Where along a refused piece a solid comes deepest into (or nearest to) an obstacle,
        scanned at ``SCAN_SAMPLES`` poses and where the sweep stopped."""
        samples = sorted({*np.linspace(0.0, 1.0, SCAN_SAMPLES).tolist(), s_found})
        found = [(s, self.margins(piece, group, piece.pose(s))[1]) for s in samples]
        return min(found, key=lambda item: item[1].margin_m)


class Group:
    """Solids that move together, with their poses in the TCP frame stacked for numpy."""

    def __init__(self, solids: Sequence[Solid]) -> None:
        self.solids = list(solids)
        self.T_tcp_solids = np.array([solid.T_tcp_solid for solid in self.solids])  # (k, 4, 4)
        self.radii = np.array([solid.radius_m for solid in self.solids])
        self.part = np.array([solid.part for solid in self.solids])


def _refusal(sweep: Sweep, piece: Piece, group: Group, s: float) -> CheckResult:
    s, worst = sweep.deepest(piece, group, s)
    solid, obstacle = group.solids[worst.solid], sweep.obstacles[worst.obstacle].label
    where = f"at {piece.fraction(s) * 100.0:.0f} % of {piece.what}"
    if worst.distance_m < 0.0:
        detail = (
            f"{solid.label} would come {-worst.distance_m * 1000.0:.0f} mm into {obstacle} {where}"
        )
    else:
        keep_mm = (worst.distance_m - worst.margin_m) * 1000.0
        detail = (
            f"{solid.label} would pass {worst.distance_m * 1000.0:.1f} mm from {obstacle} {where}"
        )
        if worst.margin_m < 0.0:
            detail += f", closer than the {keep_mm:g} mm it must keep"
        else:  # within the clearance's last fraction, where the sweep cannot prove it kept
            detail += (
                f", less than {PROOF_TOLERANCE_M * 1000.0:g} mm beyond the {keep_mm:g} mm "
                "it must keep"
            )
    return CheckResult(CHECK, piece.move, False, detail)


def check_path(
    sweep: Sweep, pieces: Sequence[Piece], tool: Sequence[Solid], part: Solid | None
) -> list[CheckResult]:
    """One ``collision`` result per move of ``pieces``; stops at the first move that fails.

    The end of every piece is looked at first (most collisions show there, at no cost of a
    sweep), then each piece is swept in order. ``part`` (None: none held) rides on the pieces
    that hold it."""
    empty, held = Group(tool), Group([*tool, part] if part is not None else tool)
    groups = [held if piece.held else empty for piece in pieces]
    for piece, group in zip(pieces, groups, strict=True):
        _, nearest = sweep.margins(piece, group, piece.pose(1.0))
        if nearest.margin_m < PROOF_TOLERANCE_M:
            return [_refusal(sweep, piece, group, 1.0)]
    closest: dict[str, tuple[_Nearest, Group]] = {}
    for piece, group in zip(pieces, groups, strict=True):
        s, nearest = sweep.sweep(piece, group)
        if s is not None:
            return [_refusal(sweep, piece, group, s)]
        if piece.move not in closest or nearest.distance_m < closest[piece.move][0].distance_m:
            closest[piece.move] = (nearest, group)
    results = []
    for move, (nearest, group) in closest.items():
        obstacle = sweep.obstacles[nearest.obstacle].label
        results.append(
            CheckResult(
                CHECK,
                move,
                True,
                f"clear: closest {group.solids[nearest.solid].label} at least "
                f"{nearest.distance_m * 1000.0:.1f} mm from {obstacle} "
                f"(clearance {sweep.clearance_m * 1000.0:g} mm)",
            )
        )
    return results
