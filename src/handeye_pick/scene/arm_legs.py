"""The arm's joints along a whole sequence, move by move (docs/arm-model.md): each moveL piece
(``path.pieces``: straight parts and blended corners) followed from where the one before ended
(``arm.path.follow``), and each moveJ linear in joint angles (``arm.path.joint_move``), from
the joints the arm starts with.

The branch the arm takes is fixed by the joints it starts with: ``start_joints`` picks the
branch of the model's IK at the sequence's start nearest the controller's actual joints, and
every move follows on from there, as the controller's moveL does from the joints it stands at.

Frames and units: ``T_base_tcp`` float64 4x4 in metres in the base frame; ``T_flange_tcp``
the TCP offset (m); joint angles in radians, base joint first.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from handeye_pick.arm.ik import branches, wrap
from handeye_pick.arm.kinematics import Joints, tcp_poses
from handeye_pick.arm.models import ArmModel
from handeye_pick.arm.path import JointPath, JointPathRefused, follow_looks, joint_move, looks
from handeye_pick.geometry import Transform, invert
from handeye_pick.scene.path import Piece, describe_move, pieces
from handeye_pick.steps import Grip, JointMove, Step


class LegRefused(Exception):
    """The arm cannot follow the move ``move`` (``reason``: ``JointPathRefused``'s message)."""

    def __init__(self, move: str, reason: str) -> None:
        super().__init__(reason)
        self.move = move
        self.reason = reason


@dataclass(frozen=True)
class Leg:
    """One move of a sequence as the arm drives it: a moveL piece (``piece``) or a moveJ
    (``piece`` None), its joint path, and whether the part is held on it."""

    move: str  # the move's name ("grasp", "capture")
    what: str  # how a refusal names it ("the grasp descent")
    path: JointPath
    held: bool
    piece: Piece | None

    def fraction(self, s: NDArray[np.float64]) -> NDArray[np.float64]:
        """Where ``s`` (along the piece) lies along the whole move, 0 to 1."""
        if self.piece is None:
            return s
        result: NDArray[np.float64] = self.piece.f0 + s * (self.piece.f1 - self.piece.f0)
        return result

    def between(
        self,
        model: ArmModel,
        T_flange_tcp: Transform,
        s: NDArray[np.float64],
        q0: Joints,
        q1: Joints,
    ) -> Joints:
        """The joints (F, 6) at ``s`` (F,) between two looks ``q0`` and ``q1`` (F, 6) of this
        leg: on a moveL the model's IK of the TCP there on the branch nearest ``q0``, on a
        moveJ the joints' linear interpolation."""
        t = (s - self.path.s[0]) / max(float(self.path.s[-1] - self.path.s[0]), 1e-12)
        linear: Joints = self.path.q[0] + t[:, None] * (self.path.q[-1] - self.path.q[0])
        if self.piece is None:
            return linear
        solved = branches(model, self.piece.poses(s) @ invert(T_flange_tcp)).q  # (F, 8, 6)
        gaps = np.abs(wrap(solved - q0[:, None])).max(axis=2)
        nearest = np.argmin(np.where(np.isnan(gaps), np.inf, gaps), axis=1)
        on_branch = solved[np.arange(len(s)), nearest]
        q: Joints = q0 + wrap(on_branch - q0)
        # A look the path was followed through always solves; the middle of two such looks too.
        midway: Joints = (q0 + q1) / 2.0
        result: Joints = np.where(np.isnan(q), midway, q)
        return result


def start_joints(
    model: ArmModel, T_flange_tcp: Transform, T_base_tcp_start: Transform, q_actual: ArrayLike
) -> Joints:
    """The model's joints (6,) at ``T_base_tcp_start`` on the branch nearest the controller's
    actual joints ``q_actual`` (rad), each joint within half a turn of its actual angle; the
    actual joints themselves where no branch reaches (the first move then refuses)."""
    actual = np.asarray(q_actual, dtype=np.float64)
    solved = branches(model, (T_base_tcp_start @ invert(T_flange_tcp))[None]).q[0]  # (8, 6)
    gaps = np.abs(wrap(solved - actual)).max(axis=1)
    if np.all(np.isnan(gaps)):
        return actual
    nearest = solved[int(np.nanargmin(gaps))]
    result: Joints = actual + wrap(nearest - actual)
    return result


def legs(
    model: ArmModel,
    T_flange_tcp: Transform,
    steps: Sequence[Step],
    T_base_tcp_start: Transform,
    q_start: ArrayLike,
    built: Sequence[Piece] | None = None,
) -> list[Leg]:
    """Every move of ``steps`` driven from ``T_base_tcp_start`` with the joints ``q_start``,
    in order; ``LegRefused`` at the first the arm cannot follow. The held part is known
    for the moveL pieces of a pick (a pick's sequence has no moveJ): a moveJ counts as
    holding when a grip closed before it. ``built``: ``pieces(steps, T_base_tcp_start)``
    when the caller has them already (used for a sequence without a moveJ)."""
    out: list[Leg] = []
    here_q = np.asarray(q_start, dtype=np.float64)
    here_T = T_base_tcp_start
    segment: list[Step] = []
    holding = False

    reuse = built is not None and not any(isinstance(step, JointMove) for step in steps)

    def flush() -> None:
        nonlocal here_q
        moves = list(built) if reuse and built is not None else pieces(segment, here_T)
        seen_all = looks(model, T_flange_tcp, moves, here_q)
        try:
            paths = follow_looks(model, T_flange_tcp, moves, seen_all, here_q)
        except JointPathRefused as refused:
            move = next(piece.move for piece in moves if piece.what == refused.what)
            raise LegRefused(move, str(refused)) from None
        for piece, path in zip(moves, paths, strict=True):
            out.append(Leg(piece.move, piece.what, path, piece.held, piece))
        if paths:
            here_q = paths[-1].q[-1]
        segment.clear()

    for step in steps:
        if isinstance(step, Grip):
            holding = step.close
        if not isinstance(step, JointMove):
            segment.append(step)
            continue
        flush()
        what = describe_move(step.name)
        path = joint_move(what, here_q, step.q_rad)
        out.append(Leg(step.name, what, path, holding, None))
        here_q = path.q[-1]
        here_T = tcp_poses(model, here_q, T_flange_tcp)[0]
    flush()
    return out

