"""Speed along a path of pieces, each with its own length, speed cap and acceleration.

Units are the path's: m, m/s, m/s^2 for a linear path (rad, rad/s, rad/s^2 for a joint path or a
pure rotation). The path starts and ends at rest; `stops` are the piece boundaries where it must
also come to rest (a waypoint without a blend). At any other boundary the speed is at most the
lower cap of the two pieces, so the arm slows down before a slower piece and speeds up after.

The profile is the fastest one within the caps: a backward pass bounds each boundary speed by
what the following pieces can brake from, a forward pass by what the previous pieces can reach;
each piece then accelerates, cruises and decelerates (a trapezoid with non-zero end speeds).
A single piece between two stops is exactly kinematics.trapezoid.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Sequence
from dataclasses import dataclass


@dataclass(frozen=True)
class PieceLimits:
    """One piece: its length, speed cap and acceleration (path units, > 0)."""

    length: float
    speed: float
    accel: float


@dataclass(frozen=True)
class _Phases:
    """A piece run from speed u to w through a peak: times of the three phases and the peak."""

    u: float
    w: float
    peak: float
    accel: float
    t_up: float
    t_cruise: float
    t_down: float

    @property
    def duration(self) -> float:
        return self.t_up + self.t_cruise + self.t_down

    def at(self, t: float) -> tuple[float, float]:
        """(distance covered, speed) t seconds into the piece."""
        a = self.accel
        if t <= self.t_up:
            return self.u * t + 0.5 * a * t * t, self.u + a * t
        covered = self.u * self.t_up + 0.5 * a * self.t_up**2
        t -= self.t_up
        if t <= self.t_cruise:
            return covered + self.peak * t, self.peak
        covered += self.peak * self.t_cruise
        t = min(t - self.t_cruise, self.t_down)
        return covered + self.peak * t - 0.5 * a * t * t, self.peak - a * t


def _phases(piece: PieceLimits, u: float, w: float) -> _Phases:
    a, length = piece.accel, piece.length
    peak = min(piece.speed, math.sqrt(max(0.0, a * length + 0.5 * (u * u + w * w))))
    peak = max(peak, u, w)
    t_up, t_down = (peak - u) / a, (peak - w) / a
    cruise = length - (peak * peak - u * u) / (2 * a) - (peak * peak - w * w) / (2 * a)
    t_cruise = max(0.0, cruise) / peak if peak > 0.0 else 0.0
    return _Phases(u, w, peak, a, t_up, t_cruise, t_down)


class PathProfile:
    """Time along a path of `pieces`: distance and speed at motion time t, and the inverse.
    No pieces: a path of length 0 that takes no time."""

    def __init__(self, pieces: Sequence[PieceLimits], stops: frozenset[int] = frozenset()):
        """`stops` holds boundary indices k (between piece k-1 and piece k) where the speed is 0."""
        if any(p.length <= 0.0 or p.speed <= 0.0 or p.accel <= 0.0 for p in pieces):
            raise ValueError("a path profile needs pieces of positive length, speed and accel")
        n = len(pieces)
        caps = (
            [0.0]
            + [
                0.0 if k in stops else min(pieces[k - 1].speed, pieces[k].speed)
                for k in range(1, n)
            ]
            + [0.0]
        )
        backward = caps[:]
        for k in range(n - 1, -1, -1):
            reach = math.sqrt(backward[k + 1] ** 2 + 2 * pieces[k].accel * pieces[k].length)
            backward[k] = min(backward[k], reach)
        speeds = backward[:]
        for k in range(n):
            reach = math.sqrt(speeds[k] ** 2 + 2 * pieces[k].accel * pieces[k].length)
            speeds[k + 1] = min(backward[k + 1], reach)
        self._phases = [_phases(p, speeds[k], speeds[k + 1]) for k, p in enumerate(pieces)]
        self.boundary_speeds = tuple(speeds)
        self._starts_t = [0.0]
        self._starts_d = [0.0]
        for piece, phases in zip(pieces, self._phases, strict=True):
            self._starts_t.append(self._starts_t[-1] + phases.duration)
            self._starts_d.append(self._starts_d[-1] + piece.length)
        self.duration_s = self._starts_t[-1]
        self.length = self._starts_d[-1]

    def at(self, t: float) -> tuple[float, float]:
        """(distance from the start, speed) at motion time t (s); at rest at the end after it."""
        if t >= self.duration_s or not self._phases:
            return self.length, 0.0
        t = max(0.0, t)
        k = bisect.bisect_right(self._starts_t, t) - 1
        covered, speed = self._phases[k].at(t - self._starts_t[k])
        return min(self.length, self._starts_d[k] + covered), max(0.0, speed)

    def time_at(self, distance: float) -> float:
        """Motion time (s) at which the path has covered `distance` (bisection on `at`)."""
        if distance >= self.length:
            return self.duration_s
        low, high = 0.0, self.duration_s
        for _ in range(60):
            mid = 0.5 * (low + high)
            if self.at(mid)[0] < distance:
                low = mid
            else:
                high = mid
        return high
