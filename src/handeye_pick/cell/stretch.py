"""Blend only where it pays: each stretch of blended moveL targets is sent as one path only when
the time its corners save beats what the controller takes to start a path.

A stretch is the moves ``sequence.path_at`` would drive as one path: consecutive moveL targets
joined by corners (``blend.with_blends``). Sent stop-and-go, each move is one trapezoid from
rest to rest. Sent blended, the arm follows the straight pieces and the corner curves without
stopping, and ur_rtde first uploads and starts a new control program (docs/ur-rtde.md, "Blended
paths"): ``path_start_s``, the arm's running figure (``RobotArm.path_start_s``).

The motion-time model is ours (docs/motion.md, "Blend only where it pays"): every piece runs at
its speed cap as soon as acceleration allows; a corner's curve (the parabola of a blend of
radius r, its tightest bend ``r cos^3(a/2) / sin(a/2)`` for a turn of angle a) is driven no
faster than the slower of its two segments and than the speed at which the sideways
acceleration stays within the move's acceleration. The per-move costs of stop-and-go (a round
trip and a check per move) are left out, so the model never favours blending.

Frames and units: ``T_base_tcp`` float64 4x4 in metres (base frame), times in seconds, speeds
m/s, accelerations m/s^2; a segment's length is the larger of its translation (m) and its
rotation (rad), as the move timeout measures it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from handeye_pick.cell.motion_time import Piece, path_time_s, trapezoid_s
from handeye_pick.config.schema import MotionConfig
from handeye_pick.geometry import Transform, rotation_angle_between
from handeye_pick.steps import Grip, JointMove, Move, Step

STOP_AND_GO = "stop-and-go"
BLENDED = "blended"


@dataclass(frozen=True)
class Stretch:
    """One stretch of blended targets and the choice made for it (times in seconds)."""

    moves: tuple[str, ...]
    stop_and_go_s: float  # the moves one by one, each from rest to rest
    blended_s: float  # the same targets as one path, corners rounded (start cost not included)
    path_start_s: float  # what starting the path costs on this controller
    always: bool = False  # motion.blend_always: sent blended whatever it costs

    @property
    def pays(self) -> bool:
        """The time the corners save beats the path's start."""
        return self.stop_and_go_s - self.blended_s > self.path_start_s

    def record(self) -> dict[str, object]:
        """The plan record's entry: which way the stretch is sent, and why."""
        saved_ms = (self.stop_and_go_s - self.blended_s) * 1000.0
        costs = f"a path start costs {self.path_start_s * 1000.0:.0f} ms"
        if self.always:
            why = f"motion.blend_always (corners save {saved_ms:.0f} ms, {costs})"
        elif self.pays:
            why = f"corners save {saved_ms:.0f} ms, {costs}"
        else:
            why = f"corners would save {saved_ms:.0f} ms, {costs}"
        return {
            "moves": list(self.moves),
            "sent": BLENDED if self.always or self.pays else STOP_AND_GO,
            "stop_and_go_s": round(self.stop_and_go_s, 4),
            "blended_s": round(self.blended_s, 4),
            "path_start_s": round(self.path_start_s, 4),
            "why": why,
        }


def paying_blends(
    steps: Sequence[Step],
    T_base_tcp_start: Transform,
    motion: MotionConfig,
    path_start_s: float,
) -> tuple[list[Step], list[Stretch]]:
    """``steps`` (corners rounded by ``blend.with_blends``) with every corner of a stretch that
    does not pay turned back into a stop (none with ``motion.blend_always``), and every
    stretch's choice. ``T_base_tcp_start`` is
    where the TCP stands when the sequence starts."""
    out = list(steps)
    stretches: list[Stretch] = []
    for indexes, T_from in _stretches(steps, T_base_tcp_start):
        typed = [step for step in (out[i] for i in indexes) if isinstance(step, Move)]
        stretch = Stretch(
            tuple(m.name for m in typed),
            sum(_segment_time_s(motion, T_a, m) for T_a, m in _legs(T_from, typed)),
            _blended_time_s(motion, T_from, typed),
            path_start_s,
            motion.blend_always,
        )
        stretches.append(stretch)
        if not (stretch.always or stretch.pays):
            for i, move in zip(indexes, typed, strict=True):
                out[i] = replace(move, blend_m=0.0)
    return out, stretches


def _stretches(
    steps: Sequence[Step], T_base_tcp_start: Transform
) -> list[tuple[list[int], Transform]]:
    """The indexes of each stretch (two or more moveL targets joined by corners) and the pose
    it starts from."""
    found: list[tuple[list[int], Transform]] = []
    current: list[int] = []
    T_from: Transform | None = T_base_tcp_start
    T_stretch_from: Transform | None = T_from
    for index, step in enumerate(steps):
        if isinstance(step, Grip):
            continue
        if isinstance(step, JointMove):
            T_from = T_stretch_from = None  # no moveL path starts from a moveJ's unknown end
            current = []
            continue
        if not current:
            T_stretch_from = T_from
        current.append(index)
        T_from = step.T_base_tcp
        if step.blend_m == 0.0:
            if len(current) > 1 and T_stretch_from is not None:
                found.append((current, T_stretch_from))
            current = []
    return found


def _legs(T_from: Transform, moves: Sequence[Move]) -> list[tuple[Transform, Move]]:
    """Each move with the pose its segment starts from."""
    starts = [T_from, *(m.T_base_tcp for m in moves[:-1])]
    return list(zip(starts, moves, strict=True))


def _speed_mps(motion: MotionConfig, move: Move) -> float:
    return motion.grasp_speed_mps if move.slow else motion.speed_mps


def _length(T_a: Transform, T_b: Transform) -> float:
    """A segment's length as a move's time counts it: translation (m) or rotation (rad)."""
    return max(
        float(np.linalg.norm(T_b[:3, 3] - T_a[:3, 3])),
        rotation_angle_between(T_a[:3, :3], T_b[:3, :3]),
    )


def _segment_time_s(motion: MotionConfig, T_a: Transform, move: Move) -> float:
    return trapezoid_s(_length(T_a, move.T_base_tcp), _speed_mps(motion, move), motion.accel_mps2)


def _blended_time_s(motion: MotionConfig, T_from: Transform, moves: Sequence[Move]) -> float:
    """The stretch as one path: straight pieces shortened by the corners' radii, and each
    corner's curve at its own speed cap; from rest to rest."""
    accel = motion.accel_mps2
    legs = _legs(T_from, moves)
    pieces: list[Piece] = []
    radius_before = 0.0
    for k, (T_a, move) in enumerate(legs):
        speed = _speed_mps(motion, move)
        straight = max(0.0, _length(T_a, move.T_base_tcp) - radius_before - move.blend_m)
        pieces.append(Piece(straight, speed))
        radius_before = move.blend_m
        if move.blend_m > 0.0 and k + 1 < len(legs):
            following = legs[k + 1][1]
            incoming = move.T_base_tcp[:3, 3] - T_a[:3, 3]
            outgoing = following.T_base_tcp[:3, 3] - move.T_base_tcp[:3, 3]
            turn = _angle(incoming, outgoing)
            cap = min(speed, _speed_mps(motion, following), _bend_speed(move.blend_m, turn, accel))
            pieces.append(Piece(_curve_length(move.blend_m, turn), cap))
    return path_time_s(pieces, accel)


def _angle(a: np.ndarray, b: np.ndarray) -> float:
    """The angle (rad) between two segments' directions; 0 when either has no length."""
    scale = float(np.linalg.norm(a)) * float(np.linalg.norm(b))
    if scale == 0.0:
        return 0.0
    return math.acos(max(-1.0, min(1.0, float(np.dot(a, b)) / scale)))


def _bend_speed(radius_m: float, turn_rad: float, accel_mps2: float) -> float:
    """The speed through a corner's curve whose sideways acceleration at its tightest bend is
    ``accel_mps2`` (unbounded for a straight corner)."""
    half = turn_rad / 2.0
    if math.sin(half) <= 0.0:
        return math.inf
    tightest_m = radius_m * math.cos(half) ** 3 / math.sin(half)
    return math.sqrt(accel_mps2 * tightest_m)


def _curve_length(radius_m: float, turn_rad: float) -> float:
    """Arc length of the parabola from r before the corner to r after it (Simpson's rule on its
    speed, which is smooth): between the chord and the two legs of length r."""
    half = turn_rad / 2.0
    # B'(t) for legs of length r meeting at the turn: |B'| = 2r |(1-t) u + t w|.
    speeds = [
        2.0 * radius_m * math.sqrt((1 - t) ** 2 + t**2 + 2 * t * (1 - t) * math.cos(2 * half))
        for t in (i / 8 for i in range(9))
    ]
    weights = [1, 4, 2, 4, 2, 4, 2, 4, 1]
    return sum(w * s for w, s in zip(weights, speeds, strict=True)) / 24.0
