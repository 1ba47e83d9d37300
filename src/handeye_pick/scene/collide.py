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
"""Poses a refused piece is scanned at for the deepest point of the pair that stopped it."""
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
        # A point c in obstacle n's frame is R_n^T (c - t_n): for all n at once c @ [R_1 .. R_n]
        # less [t_1 @ R_1 .. t_n @ R_n].
        rotations = [o.T_base_box[:3, :3] for o in self.obstacles]
        self._to_local = np.hstack(rotations)  # (3, 3n)
        self._offset = np.concatenate(
            [o.T_base_box[:3, 3] @ R for o, R in zip(self.obstacles, rotations, strict=True)]
        )
        self._half = np.concatenate([o.size_m / 2.0 for o in self.obstacles])  # (3n,)

    def _lower_bounds(self, centres: NDArray[np.float64]) -> NDArray[np.float64]:
        """Distance from each solid centre (k, 3) to each obstacle box (n): shape (k, n)."""
        outside = np.abs(centres @ self._to_local - self._offset)  # (k, 3n), in each box's frame
        outside -= self._half
        np.maximum(outside, 0.0, out=outside)
        by_box = outside.reshape(len(centres), -1, 3)
        bounds: NDArray[np.float64] = np.sqrt(np.einsum("kni,kni->kn", by_box, by_box))
        return bounds

    def _distance(self, solid: Solid, obstacle: int) -> float:
        result = fcl.DistanceResult()
        return float(
            fcl.distance(solid.geometry, self.obstacles[obstacle].geometry, _REQUEST, result)
        )

    def margins(
        self, piece: Piece, group: Group, T_base_tcp: Transform
    ) -> tuple[NDArray[np.float64], _Nearest]:
        """Each solid's margin at ``T_base_tcp`` (a lower bound: exact for pairs within
        the group's ``near_m`` of what they must keep), and the pair with the smallest."""
        R, t = T_base_tcp[:3, :3], T_base_tcp[:3, 3]
        keep, threshold = group.keep(piece.contact)
        distance = self._lower_bounds(group.centres @ R.T + t) - group.radii[:, None]
        placed: set[int] = set()
        n = distance.shape[1]
        for i, j in (divmod(k, n) for k in np.flatnonzero(distance < threshold).tolist()):
            solid = group.solids[i]
            if i not in placed:
                T = T_base_tcp @ solid.T_tcp_solid
                solid.geometry.setRotation(T[:3, :3])
                solid.geometry.setTranslation(T[:3, 3])
                placed.add(i)
            distance[i, j] = self._distance(solid, j)
        margin = distance - keep[:, None]
        i, j = divmod(int(np.argmin(margin)), margin.shape[1])
        nearest = _Nearest(float(margin[i, j]), float(distance[i, j]), i, j)
        per_solid: NDArray[np.float64] = margin.min(axis=1)
        return per_solid, nearest

    def sweep(
        self,
        piece: Piece,
        group: Group,
        start: tuple[NDArray[np.float64], _Nearest] | None = None,
    ) -> tuple[float | None, _Nearest]:
        """Advance along ``piece``; (None, nearest pair seen) when it keeps clear, else
        (s, the pair) where a margin fell below ``PROOF_TOLERANCE_M``. ``start``: the margins
        at its start when they are known already. The end needs no look of its own: the last
        step's margins cover the rest of the piece."""
        rates = np.array([piece.rate_m(solid.reach_m) for solid in group.solids])
        moving = rates > 0.0
        s = 0.0
        closest = _Nearest(np.inf, np.inf, 0, 0)
        while True:
            margins, nearest = start or self.margins(piece, group, piece.pose(s))
            start = None
            if nearest.margin_m < closest.margin_m:
                closest = nearest
            if nearest.margin_m < PROOF_TOLERANCE_M:
                return s, nearest
            if not moving.any():
                return None, closest
            s += float(np.min(margins[moving] / rates[moving]))
            if s >= 1.0:
                return None, closest

    def deepest(self, piece: Piece, group: Group, found: tuple[float, _Nearest]) -> _Deepest:
        """Where along a refused piece the pair the sweep stopped at comes deepest into (or
        nearest to) each other, scanned at ``SCAN_SAMPLES`` poses and where the sweep stopped
        (exact distances)."""
        s_found, pair = found
        solid = group.solids[pair.solid]
        keep = pair.distance_m - pair.margin_m
        T_tcp_solid = solid.T_tcp_solid
        worst = _Deepest(s_found, pair.distance_m, keep)
        for s in np.linspace(0.0, 1.0, SCAN_SAMPLES).tolist():
            T = piece.pose(s) @ T_tcp_solid
            solid.geometry.setRotation(T[:3, :3])
            solid.geometry.setTranslation(T[:3, 3])
            distance = self._distance(solid, pair.obstacle)
            if distance < worst.distance_m:
                worst = _Deepest(s, distance, keep)
        return worst


@dataclass(frozen=True)
class _Deepest:
    s: float  # along the piece
    distance_m: float  # negative: how far in
    keep_m: float  # what the solid must keep from the obstacle


class Group:
    """Solids that move together, with their poses in the TCP frame stacked for numpy, what
    they must keep from every obstacle (m), and how near a pair gets an exact distance."""

    def __init__(self, solids: Sequence[Solid], clearance_m: float, near_m: float = NEAR_M) -> None:
        self.solids = list(solids)
        self.centres = np.array([solid.T_tcp_solid[:3, 3] for solid in self.solids])  # (k, 3)
        self.radii = np.array([solid.radius_m for solid in self.solids])
        clear = np.full(len(self.solids), clearance_m)
        # On a lift-off or a set-down the held part may rest on what it lies on (PART_CONTACT_M)
        touching = np.where([solid.part for solid in self.solids], -PART_CONTACT_M, clearance_m)
        self._keep = {
            contact: (keep, (keep + near_m)[:, None])
            for contact, keep in ((False, clear), (True, touching))
        }

    def keep(self, contact: bool) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """What each solid must keep (k,), and below which bound a pair is measured (k, 1)."""
        return self._keep[contact]


def refusal_detail(solid: str, obstacle: str, where: str, distance_m: float, keep_m: float) -> str:
    """How a refusal says that ``solid`` comes ``distance_m`` (negative: into) from
    ``obstacle`` ``where`` (``at 40 % of the grasp descent``), keeping ``keep_m``."""
    if distance_m < 0.0:
        return f"{solid} would come {-distance_m * 1000.0:.0f} mm into {obstacle} {where}"
    keep_mm = keep_m * 1000.0
    detail = f"{solid} would pass {distance_m * 1000.0:.1f} mm from {obstacle} {where}"
    if distance_m < keep_m:
        return detail + f", closer than the {keep_mm:g} mm it must keep"
    # within the clearance's last fraction, where the sweep cannot prove it kept
    return detail + (
        f", less than {PROOF_TOLERANCE_M * 1000.0:g} mm beyond the {keep_mm:g} mm it must keep"
    )


def _refusal(
    sweep: Sweep, piece: Piece, group: Group, found: tuple[float, _Nearest]
) -> CheckResult:
    worst = sweep.deepest(piece, group, found)
    solid = group.solids[found[1].solid]
    obstacle = sweep.obstacles[found[1].obstacle].label
    where = f"at {piece.fraction(worst.s) * 100.0:.0f} % of {piece.what}"
    detail = refusal_detail(solid.label, obstacle, where, worst.distance_m, worst.keep_m)
    return CheckResult(CHECK, piece.move, False, detail)


def end_refusal(sweep: Sweep, piece: Piece, group: Group) -> CheckResult | None:
    """The refusal of ``piece`` when its end is too close already, else None: one look, no
    sweep (most collisions of a grasp show there)."""
    _, nearest = sweep.margins(piece, group, piece.pose(1.0))
    if nearest.margin_m < PROOF_TOLERANCE_M:
        return _refusal(sweep, piece, group, (1.0, nearest))
    return None


def check_path(
    sweep: Sweep, pieces: Sequence[Piece], tool: Group, part: Solid | None
) -> list[CheckResult]:
    """One ``collision`` result per move of ``pieces``; stops at the first move that fails.

    The end of every piece is looked at first (most collisions show there, at no cost of a
    sweep), then each piece is swept in order, from the margins at the end of the one before
    when it carries the same solids the same way. ``part`` (None: none held) rides with the
    ``tool`` on the pieces that hold it."""
    held = Group([*tool.solids, part], sweep.clearance_m) if part is not None else tool
    groups = [held if piece.held else tool for piece in pieces]
    ends = []
    for piece, group in zip(pieces, groups, strict=True):
        end = sweep.margins(piece, group, piece.pose(1.0))
        if end[1].margin_m < PROOF_TOLERANCE_M:
            return [_refusal(sweep, piece, group, (1.0, end[1]))]
        ends.append(end)
    closest: dict[str, tuple[_Nearest, Group]] = {}
    for index, (piece, group) in enumerate(zip(pieces, groups, strict=True)):
        before = pieces[index - 1] if index > 0 else None
        same = before is not None and groups[index - 1] is group and before.contact == piece.contact
        s, nearest = sweep.sweep(piece, group, ends[index - 1] if same else None)
        if s is not None:
            return [_refusal(sweep, piece, group, (s, nearest))]
        for pair in (nearest, ends[index][1]):
            if piece.move not in closest or pair.distance_m < closest[piece.move][0].distance_m:
                closest[piece.move] = (pair, group)
    results = []
    for move, (nearest, group) in closest.items():
        obstacle = sweep.obstacles[nearest.obstacle].label
        results.append(
            CheckResult(
                CHECK,
                move,
                True,
                f"clear: closest {group.solids[nearest.solid].label} at least "
                f"{round(nearest.distance_m * 1000.0, 1) + 0.0:.1f} mm from {obstacle} "
                f"(clearance {sweep.clearance_m * 1000.0:g} mm)",
            )
        )
    return results
