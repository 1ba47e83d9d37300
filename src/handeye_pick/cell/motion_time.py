"""How long the arm takes along straight moves and blended paths: the session's own
motion-time model (docs/motion.md, "Blend only where it pays").

A path is a chain of pieces, each with a length and a speed cap, driven from rest to rest at one
acceleration: as fast as the caps allow, speeding up and slowing down at that acceleration, and
passing from one piece to the next no faster than the lower of their two caps. A single piece is
a trapezoid (a triangle when it is too short to reach its cap).

Units: whatever the caller's are, consistently (m, m/s, m/s^2 for a TCP path); times in seconds.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass


@dataclass(frozen=True)
class Piece:
    """A part of a path: its length and the speed it may not exceed (> 0)."""

    length: float
    speed: float


def trapezoid_s(distance: float, speed: float, accel: float) -> float:
    """Duration of a trapezoid (or triangle) velocity profile over ``distance`` (any unit)."""
    if distance >= speed**2 / accel:
        return distance / speed + speed / accel
    return 2.0 * math.sqrt(distance / accel)


def path_time_s(pieces: Sequence[Piece], accel: float) -> float:
    """Time along ``pieces`` from rest to rest at ``accel``: the speed at each boundary is the
    highest the caps allow and the arm can brake from before the end (a backward pass) and
    reach from the start (a forward pass)."""
    ends = [0.0] + [min(a.speed, b.speed) for a, b in itertools.pairwise(pieces)] + [0.0]
    for k in range(len(pieces) - 1, -1, -1):
        ends[k] = min(ends[k], math.sqrt(ends[k + 1] ** 2 + 2.0 * accel * pieces[k].length))
    for k, piece in enumerate(pieces):
        ends[k + 1] = min(ends[k + 1], math.sqrt(ends[k] ** 2 + 2.0 * accel * piece.length))
    return sum(_piece_time_s(piece, ends[k], ends[k + 1], accel) for k, piece in enumerate(pieces))


def _piece_time_s(piece: Piece, start: float, end: float, accel: float) -> float:
    """One piece from speed ``start`` to ``end`` through the highest peak its cap and its
    length allow."""
    if piece.length <= 0.0:
        return 0.0
    reachable = math.sqrt(accel * piece.length + (start**2 + end**2) / 2.0)
    peak = min(piece.speed, reachable)
    ramps = (2.0 * peak**2 - start**2 - end**2) / (2.0 * accel)
    cruise = max(0.0, piece.length - ramps)
    return (2.0 * peak - start - end) / accel + cruise / peak
