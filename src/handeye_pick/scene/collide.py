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
SCAN_SAMPLES = 21
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

    def _keep(self, piece: Piece, solid: Solid) -> float:
        if piece.contact and solid.part:
            return -PART_CONTACT_M
        return self.clearance_m

    def _lower_bounds(self, centres: NDArray[np.float64]) -> NDArray[np.float64]:
        """Distance from each solid centre (k, 3) to each obstacle box (n): shape (k, n)."""
        local = np.einsum("nji,knj->kni", self._R, centres[:, None, :] - self._centre[None])
        outside = np.maximum(np.abs(local) - self._half[None], 0.0)
        bounds: NDArray[np.float64] = np.sqrt(np.einsum("kni,kni->kn", outside, outside))
        return bounds

    def _place(self, solids: Sequence[Solid], T_base_tcp: Transform) -> NDArray[np.float64]:
        """Put every solid where the TCP pose puts it; their centres (k, 3) in base."""
        centres = np.empty((len(solids), 3))
        for i, solid in enumerate(solids):
            T = T_base_tcp @ solid.T_tcp_solid
            solid.geometry.setRotation(T[:3, :3])
            solid.geometry.setTranslation(T[:3, 3])
            centres[i] = T[:3, 3]
        return centres

    def _distance(self, solid: Solid, obstacle: int) -> float:
        result = fcl.DistanceResult()
        return float(
            fcl.distance(solid.geometry, self.obstacles[obstacle].geometry, _REQUEST, result)
        )

    def margins(
        self, piece: Piece, solids: Sequence[Solid], T_base_tcp: Transform
    ) -> tuple[list[float], _Nearest]:
        """Each solid's margin at ``T_base_tcp`` (a lower bound), and the nearest pair."""
        centres = self._place(solids, T_base_tcp)
        bounds = self._lower_bounds(centres)
        margins = []
        nearest = _Nearest(np.inf, np.inf, 0, 0)
        for i, solid in enumerate(solids):
            keep = self._keep(piece, solid)
            best = np.inf
            for j, bound in enumerate(bounds[i]):
                distance = float(bound) - solid.radius_m
                if distance < keep + NEAR_M:
                    distance = self._distance(solid, j)
                if distance - keep < best:
                    best = distance - keep
                    if best < nearest.margin_m:
                        nearest = _Nearest(best, distance, i, j)
            margins.append(best)
        return margins, nearest

    def sweep(
        self, piece: Piece, solids: Sequence[Solid]
    ) -> tuple[float, _Nearest] | tuple[None, _Nearest]:
        """Advance along ``piece``; (None, nearest pair seen) when it keeps clear, else
        (s, the pair) where a margin fell below ``PROOF_TOLERANCE_M``."""
        rates = [piece.rate_m(solid.reach_m) for solid in solids]
        s = 0.0
        closest = _Nearest(np.inf, np.inf, 0, 0)
        while True:
            margins, nearest = self.margins(piece, solids, piece.pose(s))
            if nearest.margin_m < closest.margin_m:
                closest = nearest
            if nearest.margin_m < PROOF_TOLERANCE_M:
                return s, nearest
            steps = [m / r for m, r in zip(margins, rates, strict=True) if r > 0.0]
            if s >= 1.0 or not steps:
                return None, closest
            s = min(1.0, s + min(steps))

    def exact_nearest(
        self, piece: Piece, solids: Sequence[Solid], T_base_tcp: Transform
    ) -> _Nearest:
        """The pair with the smallest margin at ``T_base_tcp``, every distance exact."""
        self._place(solids, T_base_tcp)
        nearest = _Nearest(np.inf, np.inf, 0, 0)
        for i, solid in enumerate(solids):
            keep = self._keep(piece, solid)
            for j in range(len(self.obstacles)):
                distance = self._distance(solid, j)
                if distance - keep < nearest.margin_m:
                    nearest = _Nearest(distance - keep, distance, i, j)
        return nearest

    def deepest(
        self, piece: Piece, solids: Sequence[Solid], s_found: float
    ) -> tuple[float, _Nearest]:
        """Where along a refused piece a solid comes deepest into (or nearest to) an obstacle,
        scanned at ``SCAN_SAMPLES`` poses and where the sweep stopped."""
        samples = sorted({*np.linspace(0.0, 1.0, SCAN_SAMPLES).tolist(), s_found})
        found = [(s, self.exact_nearest(piece, solids, piece.pose(s))) for s in samples]
        return min(found, key=lambda item: item[1].margin_m)


def _refusal(sweep: Sweep, piece: Piece, solids: Sequence[Solid], s: float) -> CheckResult:
    s, worst = sweep.deepest(piece, solids, s)
    solid, obstacle = solids[worst.solid], sweep.obstacles[worst.obstacle].label
    where = f"at {piece.fraction(s) * 100.0:.0f} % of {piece.what}"
    if worst.distance_m < 0.0:
        detail = (
            f"{solid.label} would come {-worst.distance_m * 1000.0:.0f} mm into {obstacle} {where}"
        )
    else:
        keep = worst.distance_m - worst.margin_m
        detail = (
            f"{solid.label} would pass {worst.distance_m * 1000.0:.1f} mm from {obstacle} {where}, "
            f"closer than the {keep * 1000.0:g} mm it must keep"
        )
    return CheckResult(CHECK, piece.move, False, detail)


def check_path(
    sweep: Sweep, pieces: Sequence[Piece], tool: Sequence[Solid], part: Solid | None
) -> list[CheckResult]:
    """One ``collision`` result per move of ``pieces``; stops at the first move that fails.

    The end of every piece is looked at first (most collisions show there, at no cost of a
    sweep), then each piece is swept in order. ``part`` (None: none held) rides on the pieces
    that hold it."""

    def solids_of(piece: Piece) -> list[Solid]:
        return [*tool, part] if piece.held and part is not None else list(tool)

    for piece in pieces:
        solids = solids_of(piece)
        _, nearest = sweep.margins(piece, solids, piece.pose(1.0))
        if nearest.margin_m < PROOF_TOLERANCE_M:
            return [_refusal(sweep, piece, solids, 1.0)]
    closest: dict[str, tuple[_Nearest, list[Solid]]] = {}
    for piece in pieces:
        solids = solids_of(piece)
        s, nearest = sweep.sweep(piece, solids)
        if s is not None:
            return [_refusal(sweep, piece, solids, s)]
        if piece.move not in closest or nearest.distance_m < closest[piece.move][0].distance_m:
            closest[piece.move] = (nearest, solids)
    results = []
    for move, (nearest, solids) in closest.items():
        obstacle = sweep.obstacles[nearest.obstacle].label
        results.append(
            CheckResult(
                CHECK,
                move,
                True,
                f"clear: closest {solids[nearest.solid].label} at least "
                f"{nearest.distance_m * 1000.0:.1f} mm from {obstacle} "
                f"(clearance {sweep.clearance_m * 1000.0:g} mm)",
            )
        )
    return results
