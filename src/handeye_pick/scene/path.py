"""The path the TCP drives through a sequence's moveL targets, piece by piece: straight segments
(position linear, orientation turning at a constant rate about one axis, as moveL drives them)
and, at a blended target, the curve that rounds its corner.

A blend of radius r at a target leaves the incoming segment r before the target and joins the
outgoing one r after it, along the quadratic Bezier curve through the target as its control
point (a parabola tangent to both segments, inside the ball of radius r; docs/motion.md); the
orientation turns evenly from the leaving pose to the joining one. Each piece bounds how fast
any point of a solid moves with it: ``|dp/ds| + |dtheta/ds| * reach`` for a point ``reach`` from
the TCP, which lets the sweep step without missing a contact.

Frames and units: ``T_base_tcp`` float64 4x4 in metres in the base frame.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np
from numpy.typing import NDArray

from handeye_pick.geometry import Transform, rotation_to_rotvec
from handeye_pick.steps import Grip, JointMove, Move, Step

Vector = NDArray[np.float64]
_I3: Vector = np.eye(3)
_I4: Vector = np.eye(4)
_SAME_ORIENTATION = 1e-12  # rotation matrices this close are one orientation: no turn


@dataclass(frozen=True)
class Piece:
    """One straight part of a move (fractions ``f0`` to ``f1`` of its segment), or the blend
    around the target of ``move`` (``control_m`` set, ``f0``..``f1`` = 0..1 of the curve)."""

    move: str  # the move it belongs to (a blend: the move whose target it rounds)
    what: str  # how a refusal names it: "the grasp descent", "the blend at the approach"
    T_from: Transform  # the segment's start (a blend: where it leaves the incoming segment)
    T_to: Transform  # the segment's end (a blend: where it joins the outgoing one)
    f0: float
    f1: float
    held: bool  # the part is in the gripper
    contact: bool  # the held part lifts off or is set down: it may touch what it rests on
    control_m: Vector | None = None

    @cached_property
    def _turn(self) -> tuple[float, Vector, Vector]:
        """The turn from the start's orientation to the end's: its angle (rad) and the skew
        matrix of its unit axis and that matrix squared (in the start's frame), for Rodrigues'
        formula; zeros for no turn."""
        R = self.T_from[:3, :3].T @ self.T_to[:3, :3]
        if float(np.abs(R - _I3).max()) < _SAME_ORIENTATION:  # most moves of a pick do not turn
            return 0.0, np.zeros((3, 3)), np.zeros((3, 3))
        rotvec = rotation_to_rotvec(R)
        angle = float(np.linalg.norm(rotvec))
        x, y, z = rotvec / angle if angle > 0.0 else np.zeros(3)
        K = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
        return angle, K, K @ K

    def pose(self, s: float) -> Transform:
        """The TCP at ``s`` in [0, 1] along the piece (closed forms: this runs at every step
        of the sweep)."""
        f = self.f0 + s * (self.f1 - self.f0)
        start, end = self.T_from[:3, 3], self.T_to[:3, 3]
        T: Transform = _I4.copy()
        if self.control_m is None:
            T[:3, 3] = start + f * (end - start)
        else:
            T[:3, 3] = (1 - f) ** 2 * start + 2 * f * (1 - f) * self.control_m + f**2 * end
        angle, K, K2 = self._turn
        theta = f * angle
        if angle == 0.0:
            T[:3, :3] = self.T_from[:3, :3]
        else:
            T[:3, :3] = self.T_from[:3, :3] @ (
                _I3 + math.sin(theta) * K + (1 - math.cos(theta)) * K2
            )
        return T

    def poses(self, s: NDArray[np.float64]) -> NDArray[np.float64]:
        """``pose`` at every ``s`` of an array (n,) at once: (n, 4, 4)."""
        f = self.f0 + s * (self.f1 - self.f0)
        start, end = self.T_from[:3, 3], self.T_to[:3, 3]
        T = np.zeros((len(f), 4, 4))
        T[:, 3, 3] = 1.0
        if self.control_m is None:
            T[:, :3, 3] = start + f[:, None] * (end - start)
        else:
            T[:, :3, 3] = (
                ((1 - f) ** 2)[:, None] * start
                + (2 * f * (1 - f))[:, None] * self.control_m
                + (f**2)[:, None] * end
            )
        angle, K, K2 = self._turn
        theta = f * angle
        turn = (
            _I3
            + np.sin(theta)[:, None, None] * K
            + (1 - np.cos(theta))[:, None, None] * K2
        )
        T[:, :3, :3] = self.T_from[:3, :3] @ turn
        return T

    def fraction(self, s: float) -> float:
        """Where ``s`` lies along the whole move (a blend: along the curve), 0 to 1."""
        return self.f0 + s * (self.f1 - self.f0)

    def rate_m(self, reach_m: float) -> float:
        """The most any point within ``reach_m`` of the TCP moves per unit of ``s`` (m)."""
        angle = self._turn[0]
        start, end = self.T_from[:3, 3], self.T_to[:3, 3]
        if self.control_m is None:
            travel = float(np.linalg.norm(end - start))
        else:  # the derivative of a quadratic Bezier is largest at an end
            travel = 2.0 * max(
                float(np.linalg.norm(self.control_m - start)),
                float(np.linalg.norm(end - self.control_m)),
            )
        return (travel + angle * reach_m) * (self.f1 - self.f0)


_NAMES = {
    "approach": "the move to the approach",
    "grasp": "the grasp descent",
    "retreat": "the lift-off to the retreat",
    "place-approach": "the move to the place-approach",
    "place": "the place descent",
    "place-retreat": "the place retreat",
}


def describe_move(name: str) -> str:
    """How a refusal names a move: ``the grasp descent``, ``the move to via clear``."""
    return _NAMES.get(name, f"the move to {name}")


@dataclass(frozen=True)
class _Leg:
    move: Move
    T_from: Transform | None  # None: after a moveJ, where the arm comes from is not known
    held: bool
    contact: bool


def _legs(steps: Sequence[Step], T_base_tcp_start: Transform) -> list[_Leg]:
    """Each moveL with where it starts and whether the part is held (and touches) on it."""
    legs: list[_Leg] = []
    here: Transform | None = T_base_tcp_start
    holding = lifting = False
    for step in steps:
        if isinstance(step, Grip):
            holding = lifting = step.close
            continue
        if isinstance(step, JointMove):
            here = None  # a moveJ's TCP path is not a line: only its end is checked
            continue
        contact = holding and (lifting or step.slow)
        legs.append(_Leg(step, here, holding, contact))
        here, lifting = step.T_base_tcp, False
    return legs


def pieces(steps: Sequence[Step], T_base_tcp_start: Transform) -> list[Piece]:
    """The pieces the TCP drives through ``steps`` from ``T_base_tcp_start``, in order."""
    legs = _legs(steps, T_base_tcp_start)
    out: list[Piece] = []
    trim_start = 0.0  # the blend before this leg takes this fraction of its start
    for index, leg in enumerate(legs):
        T_to = leg.move.T_base_tcp
        T_from = leg.T_from if leg.T_from is not None else T_to
        length = float(np.linalg.norm(T_to[:3, 3] - T_from[:3, 3]))
        following = legs[index + 1] if index + 1 < len(legs) else None
        radius = leg.move.blend_m if following is not None and following.T_from is not None else 0.0
        trim_end = 1.0 - radius / length if radius > 0.0 and length > 0.0 else 1.0
        what = describe_move(leg.move.name)
        out.append(
            Piece(leg.move.name, what, T_from, T_to, trim_start, trim_end, leg.held, leg.contact)
        )
        trim_start = 0.0
        if following is not None and trim_end < 1.0:
            next_to = following.move.T_base_tcp
            next_length = float(np.linalg.norm(next_to[:3, 3] - T_to[:3, 3]))
            trim_start = min(1.0, radius / next_length) if next_length > 0.0 else 0.0
            leave = out[-1].pose(1.0)
            join = Piece("", "", T_to, next_to, trim_start, trim_start, False, False).pose(0.0)
            out.append(
                Piece(
                    leg.move.name,
                    f"the blend at the {leg.move.name}",
                    leave,
                    join,
                    0.0,
                    1.0,
                    leg.held,
                    False,
                    control_m=T_to[:3, 3].copy(),
                )
            )
    return out
