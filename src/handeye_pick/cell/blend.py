"""Blended corners: the radius each moveL target of a sequence is rounded with, and the room the
TCP needs while it rounds one.

Consecutive moveL targets with no gripper action between them are driven as one path
(``RobotArm.move_path``). At a target with radius r the controller leaves the straight segment r
before the target and joins the next one r after it; the TCP stays within r of the target
(docs/motion.md, "Blended paths"). A radius is 0 (the arm stops) at the last target of a path,
at a grasp or a place (the end of a descent), before and after a moveJ, and wherever the rules
below leave no room.

Frames and units: ``T_base_tcp`` targets and positions in metres in the robot base frame.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from handeye_pick.geometry import Transform
from handeye_pick.steps import Grip, JointMove, Move, Step

BLEND_SHARE = 0.45
"""The largest share of either segment one corner may take: two corners on a segment then leave
a gap between them (UR skips blends that overlap and stops there instead)."""

MIN_BLEND_M = 0.0005
"""A radius below half a millimetre rounds nothing: the target becomes a stop."""

COLLINEAR_SINE = 1e-6
"""Two segments whose angle has a smaller sine span no plane that can be trusted."""

Vector = NDArray[np.float64]


@dataclass(frozen=True)
class Corner:
    """A blended target: where it is, its radius, and how far the TCP may stray from it along
    each base axis while rounding it (the disc of the radius in the plane of the two segments)."""

    name: str
    center_m: Vector
    radius_m: float
    extent_m: Vector  # half-size of the disc's bounding box along base x, y, z (m)


@dataclass(frozen=True)
class _Joint:
    """A move with the straight segments on either side of its target."""

    index: int
    move: Move
    incoming_m: Vector  # from the previous target (or the start) to this one
    outgoing_m: Vector  # from this target to the next
    ascent: bool  # the incoming segment rises from a grasp or a place
    descent: bool  # the outgoing segment descends onto one


def with_blends(
    steps: Sequence[Step], T_base_tcp_start: Transform, blend_m: float, straight_m: float
) -> list[Step]:
    """``steps`` with each move's ``blend_m`` set (all 0 when ``blend_m`` is 0).

    A corner's radius is at most ``blend_m``, at most ``BLEND_SHARE`` of either segment it joins,
    and leaves the last ``straight_m`` of a descent onto a grasp or a place, and the first
    ``straight_m`` of the ascent from one, straight along the tool axis. ``T_base_tcp_start`` is
    where the TCP stands when the sequence starts.
    """
    out = list(steps)
    if blend_m <= 0.0:
        return out
    for joint in _joints(steps, T_base_tcp_start):
        radius = corner_radius(joint, blend_m, straight_m)
        if radius > 0.0:
            out[joint.index] = replace(joint.move, blend_m=radius)
    return out


def corner_radius(joint: _Joint, blend_m: float, straight_m: float) -> float:
    """The radius one corner gets under the rules of ``with_blends`` (0: a stop)."""
    incoming = float(np.linalg.norm(joint.incoming_m))
    outgoing = float(np.linalg.norm(joint.outgoing_m))
    radius = min(blend_m, BLEND_SHARE * incoming, BLEND_SHARE * outgoing)
    if joint.ascent:
        radius = min(radius, incoming - straight_m)
    if joint.descent:
        radius = min(radius, outgoing - straight_m)
    return radius if radius >= MIN_BLEND_M else 0.0


def corners(steps: Sequence[Step], T_base_tcp_start: Transform) -> list[Corner]:
    """Every blended target of ``steps`` (``with_blends``' output) as a ``Corner``."""
    return [
        Corner(
            joint.move.name,
            joint.move.T_base_tcp[:3, 3].copy(),
            joint.move.blend_m,
            corner_extent_m(joint.incoming_m, joint.outgoing_m, joint.move.blend_m),
        )
        for joint in _joints(steps, T_base_tcp_start)
        if joint.move.blend_m > 0.0
    ]


def corner_extent_m(incoming: Vector, outgoing: Vector, radius_m: float) -> Vector:
    """Half-size along base x, y, z of the disc of ``radius_m`` spanned by two segments. Where
    the two are (nearly) in one line their plane is not known: the whole ball, to be safe."""
    scale = float(np.linalg.norm(incoming)) * float(np.linalg.norm(outgoing))
    normal = np.cross(incoming, outgoing)
    length = float(np.linalg.norm(normal))
    if scale == 0.0 or length <= COLLINEAR_SINE * scale:  # <=: the product may underflow to 0
        return np.full(3, radius_m, dtype=np.float64)
    unit_normal = normal / length
    return np.asarray(
        [radius_m * math.sqrt(max(0.0, 1.0 - float(n) ** 2)) for n in unit_normal],
        dtype=np.float64,
    )


def _joints(steps: Sequence[Step], T_base_tcp_start: Transform) -> Iterator[_Joint]:
    """Each move that could be a corner: a moveL target followed by another moveL, not itself
    the end of a descent, with a known position before it."""
    previous: Move | None = None
    position: Vector | None = T_base_tcp_start[:3, 3]
    for index, step in enumerate(steps):
        if isinstance(step, JointMove):
            previous, position = None, None  # where a moveJ ends is the controller's business
            continue
        if isinstance(step, Grip):
            continue
        following = steps[index + 1] if index + 1 < len(steps) else None
        here = step.T_base_tcp[:3, 3]
        if position is not None and isinstance(following, Move) and not step.slow:
            yield _Joint(
                index,
                step,
                here - position,
                following.T_base_tcp[:3, 3] - here,
                ascent=previous is not None and previous.slow,
                descent=following.slow,
            )
        previous, position = step, here
