"""A blended path's geometry and timing: straight segments between waypoints, joined at each
blended waypoint by a parabolic blend, timed by path_profile.PathProfile.

Linear paths (movel) live in the base frame: TCP positions in m, orientations by slerp along
each segment. Joint paths (movej) live in joint space (rad), lengths measured as the largest
joint travel, as single moveJ measures them. Segment i runs from waypoint i-1 to waypoint i
(waypoint 0's segment starts where the arm is).

A blend at waypoint i with radius r leaves segment i at the point A where the TCP comes within r
of the waypoint and joins segment i+1 at the point B where the TCP is r past it. Between them
the arm follows the quadratic Bezier curve A -> waypoint -> B (a parabola, tangent to both
segments). For movel A, waypoint and B lie in the ball of radius r, and so does the whole
curve, since the curve stays in their triangle. For movej the curve is in joint space and the
TCP stays near, not provably inside, the ball.

Skipped blends (the arm stops at the waypoint; logged, and listed in `skipped`): a blend that
would overlap the previous waypoint's blend, one longer than the next segment, one at a pure
rotation segment (no translation to measure r on), and a reversal (the curve would have no
room to turn). The last waypoint is always a stop.
"""

from __future__ import annotations

import bisect
import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from mocks.ur_controller import kinematics as kin
from mocks.ur_controller.path_profile import PathProfile, PieceLimits
from mocks.ur_controller.path_script import Waypoint

Vector = NDArray[np.float64]

_MIN_TRANSLATION_M = 1e-6  # below this a movel segment is a pure rotation (length in rad)
_BLEND_SAMPLES = 32  # arc length and curvature of a blend are taken at this many points
_REVERSAL_COS = -0.999  # segments turning back on themselves this sharply cannot blend


@dataclass(frozen=True)
class _Segment:
    start: Vector  # movel: 4x4 T_base_tcp; movej: q
    end: Vector
    length: float  # path units (m, or rad for a pure rotation or a joint path)
    translation: float  # m, TCP (movel only; 0 for movej, unused)
    speed: float
    accel: float


@dataclass(frozen=True)
class _Piece:
    """A straight part of a segment (fractions f0..f1 of it) or a blend at `corner`.

    A blend keeps what every control cycle in it needs, computed once when the path is planned:
    its Bezier control points (TCP positions in m for movel, joints in rad for movej) and, for
    movel, the poses where it leaves and joins the segments (4x4 T_base_tcp)."""

    segment: int  # index into segments; a blend joins segment and segment + 1
    blend: bool
    f0: float
    f1: float
    table: tuple[float, ...] = ()  # blends: cumulative length at equally spaced u
    controls: tuple[Vector, Vector, Vector] | None = None  # blends: entry, corner, exit points
    ends: tuple[Vector, Vector] | None = None  # movel blends: T_base_tcp at entry and at exit


class BlendedPath:
    """A path from the arm's current point through `waypoints`; see the module docstring.

    `move` is "movel" (start is T_base_tcp, 4x4) or "movej" (start is q). `tcp_position(q)` gives
    the TCP position (m, base) at joints q, for movej blends. Path fractions run 0..1 over
    `length` (path units); `point(fraction)` is T_base_tcp for movel and q for movej.
    """

    def __init__(
        self,
        move: str,
        start: Vector,
        waypoints: Sequence[Waypoint],
        tcp_position: Callable[[Vector], Vector],
    ):
        self.move = move
        self.linear = move == "movel"
        self.waypoints = tuple(waypoints)
        self._tcp_position = tcp_position
        self._segments = self._build_segments(start, waypoints)
        exits = self._blend_exits(waypoints)
        self.skipped = tuple(
            i for i, w in enumerate(waypoints[:-1]) if w.blend > 0.0 and exits[i] is None
        )
        self._pieces: list[_Piece] = []
        limits: list[PieceLimits] = []
        stops: set[int] = set()
        done_at: list[float] = []
        covered = 0.0
        entry = 0.0
        for i, segment in enumerate(self._segments):
            blend = exits[i] if i < len(exits) else None
            leave = 1.0 if blend is None else blend[0]
            straight = (leave - entry) * segment.length
            if straight > 0.0:  # none left when a blend ends where the next one begins
                self._pieces.append(_Piece(i, False, entry, leave))
                limits.append(PieceLimits(straight, segment.speed, segment.accel))
                covered += straight
            done_at.append(covered)
            if blend is None:
                stops.add(len(limits))
                entry = 0.0
                continue
            piece = self._blend_piece(i, blend[0], blend[1])
            self._pieces.append(piece)
            nxt = self._segments[i + 1]
            speed = min(segment.speed, nxt.speed)
            accel = min(segment.accel, nxt.accel)
            if self.linear:
                speed = min(speed, math.sqrt(accel * self._min_radius(i, blend[0], blend[1])))
            limits.append(PieceLimits(piece.table[-1], speed, accel))
            covered += piece.table[-1]
            entry = blend[1]
        self.profile = PathProfile(limits, frozenset(stops) - {len(limits)})
        self.length = self.profile.length
        self.done_distance = tuple(done_at)  # where each waypoint's move is done (path units)
        self._starts = [0.0]
        for piece_limits in limits:
            self._starts.append(self._starts[-1] + piece_limits.length)

    # --- construction -----------------------------------------------------------------------

    def _build_segments(self, start: Vector, waypoints: Sequence[Waypoint]) -> list[_Segment]:
        segments: list[_Segment] = []
        here = start
        for w in waypoints:
            if self.linear:
                there = kin.pose_to_matrix(np.array(w.target))
                translation = float(np.linalg.norm(there[:3, 3] - here[:3, 3]))
                length = translation if translation >= _MIN_TRANSLATION_M else _angle(here, there)
            else:
                there = np.array(w.target, dtype=np.float64)
                translation = 0.0
                length = float(np.max(np.abs(there - here)))
            segments.append(_Segment(here, there, length, translation, w.speed, w.accel))
            here = there
        return segments

    def _blend_exits(self, waypoints: Sequence[Waypoint]) -> list[tuple[float, float] | None]:
        """Per waypoint but the last: (fraction of its segment where the blend starts, fraction of
        the next segment where it ends), or None for a stop."""
        exits: list[tuple[float, float] | None] = []
        previous_end = 0.0
        for i, w in enumerate(waypoints[:-1]):
            fit = self._blend_fractions(i, w.blend) if w.blend > 0.0 else None
            if fit is not None and fit[0] < previous_end:
                fit = None  # it would overlap the previous blend: the arm stops here instead
            exits.append(fit)
            previous_end = 0.0 if fit is None else fit[1]
        return exits

    def _blend_fractions(self, i: int, radius: float) -> tuple[float, float] | None:
        incoming, outgoing = self._segments[i], self._segments[i + 1]
        if self.linear:
            if min(incoming.translation, outgoing.translation) < _MIN_TRANSLATION_M:
                return None
            if radius > incoming.translation or radius > outgoing.translation:
                return None
            leave, join = 1.0 - radius / incoming.translation, radius / outgoing.translation
        else:
            corner = self._tcp_position(incoming.end)
            leave_found = self._fraction_at_distance(incoming, corner, radius, from_end=True)
            join_found = self._fraction_at_distance(outgoing, corner, radius, from_end=False)
            if leave_found is None or join_found is None:
                return None
            leave, join = leave_found, join_found
        a, b = self._position(i, leave), self._position(i + 1, join)
        corner_point = self._position(i, 1.0)
        d_in, d_out = corner_point - a, b - corner_point
        norms = float(np.linalg.norm(d_in) * np.linalg.norm(d_out))
        if norms == 0.0 or float(np.dot(d_in, d_out)) / norms < _REVERSAL_COS:
            return None
        return leave, join

    def _fraction_at_distance(
        self, segment: _Segment, corner: Vector, radius: float, from_end: bool
    ) -> float | None:
        """movej: the fraction of `segment` nearest its corner end where the TCP is `radius`
        from `corner`; None when the whole segment is within the radius."""

        def outside(f: float) -> bool:
            q = segment.start + f * (segment.end - segment.start)
            return float(np.linalg.norm(self._tcp_position(q) - corner)) >= radius

        steps = 64
        for k in range(1, steps + 1):
            f = 1.0 - k / steps if from_end else k / steps
            if outside(f):
                inside = f + 1.0 / steps if from_end else f - 1.0 / steps
                for _ in range(40):
                    mid = 0.5 * (f + inside)
                    if outside(mid):
                        f = mid
                    else:
                        inside = mid
                return f
        return None

    def _blend_piece(self, i: int, leave: float, join: float) -> _Piece:
        controls = (self._position(i, leave), self._position(i, 1.0), self._position(i + 1, join))
        points = [_bezier(controls, u / _BLEND_SAMPLES) for u in range(_BLEND_SAMPLES + 1)]
        table = [0.0]
        for p0, p1 in itertools.pairwise(points):
            step = p1 - p0
            table.append(
                table[-1] + float(np.linalg.norm(step) if self.linear else np.max(np.abs(step)))
            )
        ends = ((self._on_segment(i, leave), self._on_segment(i + 1, join)) if self.linear
                else None)
        return _Piece(i, True, leave, join, tuple(table), controls, ends)

    def _min_radius(self, i: int, leave: float, join: float) -> float:
        """Smallest radius of curvature (m) of the blend at waypoint i (movel)."""
        a, c, b = self._position(i, leave), self._position(i, 1.0), self._position(i + 1, join)
        second = 2.0 * (a - 2.0 * c + b)
        radius = math.inf
        for k in range(_BLEND_SAMPLES + 1):
            u = k / _BLEND_SAMPLES
            first = 2.0 * ((1.0 - u) * (c - a) + u * (b - c))
            speed = float(np.linalg.norm(first))
            bend = float(np.linalg.norm(np.cross(first, second)))
            if bend > 0.0:
                radius = min(radius, speed**3 / bend)
        return radius

    # --- evaluation -------------------------------------------------------------------------

    def _on_segment(self, i: int, f: float) -> Vector:
        """movel: T_base_tcp, movej: q, a fraction f along segment i."""
        segment = self._segments[i]
        if self.linear:
            return kin.interpolate_pose(segment.start, segment.end, min(1.0, max(0.0, f)))
        return segment.start + f * (segment.end - segment.start)

    def _position(self, i: int, f: float) -> Vector:
        """The point blends are built on: TCP position (movel; on the straight line, so no
        orientation is interpolated) or joints (movej), a fraction f along segment i."""
        if not self.linear:
            return self._on_segment(i, f)
        segment = self._segments[i]
        f = min(1.0, max(0.0, f))
        return (1.0 - f) * segment.start[:3, 3] + f * segment.end[:3, 3]

    def point(self, fraction: float) -> Vector:
        """T_base_tcp (movel) or q (movej) at a path fraction in 0..1."""
        if not self._pieces:  # every waypoint is where the arm already is
            return self._segments[-1].end
        distance = min(1.0, max(0.0, fraction)) * self.length
        k = min(bisect.bisect_right(self._starts, distance) - 1, len(self._pieces) - 1)
        piece = self._pieces[k]
        local = distance - self._starts[k]
        if not piece.blend:
            span = self._starts[k + 1] - self._starts[k]
            f = piece.f0 + (piece.f1 - piece.f0) * (local / span if span > 0.0 else 1.0)
            return self._on_segment(piece.segment, f)
        u = _inverse_table(piece.table, local)
        assert piece.controls is not None
        position = _bezier(piece.controls, u)
        if piece.ends is None:
            return position
        T = kin.interpolate_pose(piece.ends[0], piece.ends[1], u)
        T[:3, 3] = position
        return T

    def waypoint_in_progress(self, fraction: float) -> int:
        """The index of the waypoint the arm is heading for, as signal_async_progress(i) marks
        it: i from the moment waypoint i-1's move is done (its blend began, or it stopped)."""
        distance = fraction * self.length
        done = bisect.bisect_right(self.done_distance, distance + 1e-12)
        return min(done, len(self._segments) - 1)


def _bezier(controls: tuple[Vector, Vector, Vector], u: float) -> Vector:
    """The quadratic Bezier curve through entry a, control point c (the corner) and exit b."""
    a, c, b = controls
    return (1.0 - u) ** 2 * a + 2.0 * u * (1.0 - u) * c + u * u * b


def _angle(T0: Vector, T1: Vector) -> float:
    """Rotation angle (rad) between two poses' orientations."""
    cos = (float(np.trace(T0[:3, :3].T @ T1[:3, :3])) - 1.0) / 2.0
    return math.acos(min(1.0, max(-1.0, cos)))


def _inverse_table(table: Sequence[float], length: float) -> float:
    """The curve parameter u in 0..1 at which the cumulative `table` reaches `length`."""
    steps = len(table) - 1
    k = min(max(bisect.bisect_right(table, length) - 1, 0), steps - 1)
    span = table[k + 1] - table[k]
    within = (length - table[k]) / span if span > 0.0 else 0.0
    return min(1.0, (k + min(1.0, max(0.0, within))) / steps)
