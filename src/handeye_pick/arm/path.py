"""The joint angles along a move, step by step, and the refusal of a move the arm cannot follow.

- A moveL (a straight piece, or the curve of a blended corner): the TCP path is sampled in
  steps of at most ``LINEAR_STEP_M`` of travel and ``TURN_STEP_RAD`` of turn; at each step the
  closed-form IK (``ik.branches``) gives the eight branches, and the path stays on the branch
  the arm starts on (the one nearest the joints it starts with), each joint made continuous
  from its neighbour's angle. Every step is verified by forward kinematics: the TCP within
  ``FOLLOW_TOLERANCE_M`` of the path. Where the move ends at a target, the angles reached must
  lie on the branch of the controller's IK there (``BRANCH_TOLERANCE_RAD``).
- A moveJ: linear in joint angles, in steps of at most ``JOINT_STEP_RAD`` on any joint.

A move refuses (``JointPathRefused``, naming the move and where along it) where the path leaves
the arm's reach, comes near a singularity, makes a joint jump (more than ``MAX_JOINT_STEP_RAD``
in one step) or ends on another branch: the controller would stop the arm there, or drive it
another way than planned. docs/arm-model.md says why each bound is what it is.

Frames and units: ``T_base_tcp`` float64 4x4 in metres in the base frame; ``T_flange_tcp`` the
TCP offset (m); joint angles in radians, base joint first.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from handeye_pick.arm.ik import Branches, branches, wrap
from handeye_pick.arm.kinematics import Joints, tcp_poses
from handeye_pick.arm.models import ArmModel
from handeye_pick.errors import SafetyRefusal
from handeye_pick.geometry import Transform, invert

LINEAR_STEP_M = 0.005
"""The most the TCP travels in one step of a moveL (m)."""
TURN_STEP_RAD = math.radians(1.0)
"""The most the TCP turns in one step of a moveL (rad)."""
JOINT_STEP_RAD = math.radians(1.0)
"""The most any joint turns in one step of a moveJ (rad)."""
FOLLOW_TOLERANCE_M = 1e-5
"""Every step's TCP, by forward kinematics, lies this close to the path (m: 0.01 mm) ..."""
FOLLOW_TOLERANCE_RAD = 1e-5
"""... and turned this little from it (rad)."""
MAX_JOINT_STEP_RAD = 0.1
"""A joint turning more than this (5.7 deg) in one moveL step is a jump: twenty times the turn
of a TCP step, or 20 rad per metre of TCP travel."""
SHOULDER_SINGULAR_M = 0.01
"""The wrist centre this close (m) to the cylinder of radius d4 around joint 1's axis is near
the shoulder singularity."""
WRIST_SINGULAR = math.sin(math.radians(2.0))
"""|sin q5| below this (wrist 2 within 2 deg of 0 or 180): joints 4 and 6 nearly in line."""
ELBOW_SINGULAR = math.sin(math.radians(2.0))
"""|sin q3| below this (the elbow within 2 deg of straight or folded)."""
BRANCH_TOLERANCE_RAD = 0.1
"""Joint angles on one branch differ by at most this (rad, each joint, whole turns aside) from
the controller's IK at a target or the arm's joints at the start: a real arm's kinematic
calibration moves them by milliradians, another branch by far more."""


class JointPathRefused(SafetyRefusal):
    """The arm cannot follow a move as planned (``what``, at ``fraction`` 0 to 1 of it):
    nothing moved."""

    def __init__(self, what: str, fraction: float, reason: str) -> None:
        super().__init__(f"the arm cannot follow {what} at {fraction * 100:.0f} %: {reason}")
        self.what = what
        self.fraction = fraction


class TcpCurve(Protocol):
    """A piece of a move the TCP drives (``scene.path.Piece`` is one): ``poses(s)`` the TCP
    (``T_base_tcp``, m) at every ``s`` (n,) in [0, 1], ``fraction(s)`` where that lies along
    the whole move, and ``rate_m(reach_m)`` = travel + turn * reach_m per unit of ``s`` (m),
    which bounds how fast a point ``reach_m`` from the TCP moves."""

    @property
    def what(self) -> str: ...

    def poses(self, s: NDArray[np.float64]) -> NDArray[np.float64]: ...

    def fraction(self, s: float) -> float: ...

    def rate_m(self, reach_m: float) -> float: ...


@dataclass(frozen=True)
class JointPath:
    """The joint angles ``q`` (n + 1, 6) rad at the n + 1 looks along a move ``what``, where
    each lies along the whole move (``fraction``, 0 to 1) and along its piece (``s``, 0 to 1)."""

    what: str
    q: Joints
    fraction: NDArray[np.float64]
    s: NDArray[np.float64]

    @property
    def dq(self) -> Joints:
        """The joint step from each look to the next: (n, 6) rad."""
        steps: Joints = np.diff(self.q, axis=0)
        return steps


def steps_for(curve: TcpCurve) -> int:
    """How many steps a moveL piece takes: enough that no step travels farther than
    ``LINEAR_STEP_M`` or turns more than ``TURN_STEP_RAD``; at least one."""
    travel = curve.rate_m(0.0)
    turn = curve.rate_m(1.0) - travel
    return max(1, math.ceil(travel / LINEAR_STEP_M), math.ceil(turn / TURN_STEP_RAD))


@dataclass(frozen=True)
class Looks:
    """Where a moveL piece is looked at: ``s`` (n + 1,) along it, the TCP there
    (``T_base_tcp``, (n + 1, 4, 4), m) and the model's eight branches at each."""

    s: NDArray[np.float64]
    T_base_tcp: NDArray[np.float64]
    solved: Branches


def looks(
    model: ArmModel,
    T_flange_tcp: Transform,
    curves: Sequence[TcpCurve],
    q_start: ArrayLike | None = None,
) -> list[Looks]:
    """The looks of every piece of ``curves`` (``steps_for`` steps each), their IK solved as
    one batch: every branch, or with the joints ``q_start`` the arm starts the first piece
    with, the branch nearest them alone (a path stays on its branch: leaving it is a
    singularity, which ``follow`` refuses)."""
    if not curves:
        return []
    s_all = [np.linspace(0.0, 1.0, steps_for(curve) + 1) for curve in curves]
    T_all = [curve.poses(s) for curve, s in zip(curves, s_all, strict=True)]
    T_base_flange = np.concatenate(T_all) @ invert(T_flange_tcp)
    branch = None
    if q_start is not None:
        first = branches(model, T_base_flange[:1]).q[0]
        gaps = np.abs(wrap(first - np.asarray(q_start, dtype=np.float64))).max(axis=1)
        branch = None if np.all(np.isnan(gaps)) else int(np.nanargmin(gaps))
    solved = branches(model, T_base_flange, branch)
    out: list[Looks] = []
    start = 0
    for s, T in zip(s_all, T_all, strict=True):
        part = slice(start, start + len(s))
        start += len(s)
        out.append(
            Looks(
                s,
                T,
                Branches(
                    solved.q[part], solved.shoulder_m[part], solved.wrist[part],
                    solved.elbow[part],
                ),
            )
        )
    return out


def follow(
    model: ArmModel,
    T_flange_tcp: Transform,
    curve: TcpCurve,
    q_start: ArrayLike,
    q_end: ArrayLike | None = None,
    seen: Looks | None = None,
) -> JointPath:
    """The joint path of a moveL piece from the joints ``q_start`` (rad: where the arm stands,
    or where the piece before ended). ``q_end``: the controller's IK at the piece's end when it
    ends at a target (its branch must be the one followed). ``seen``: the piece's ``looks``
    when they are solved already. ``JointPathRefused`` where the arm cannot follow."""
    start = np.asarray(q_start, dtype=np.float64)
    if seen is None:
        seen = looks(model, T_flange_tcp, [curve])[0]
    fraction = _fractions(curve, seen.s)
    q, steps, near = _on_branch(model, curve, seen, start, fraction)
    problem = _first_problem(model, T_flange_tcp, seen.T_base_tcp, q, steps, near)
    if problem is not None:
        index, reason = problem
        raise JointPathRefused(curve.what, fraction[index], reason)
    if q_end is not None:
        apart = np.abs(wrap(q[-1] - np.asarray(q_end, dtype=np.float64)))
        joint = int(np.argmax(apart))
        if not apart[joint] <= BRANCH_TOLERANCE_RAD:
            raise JointPathRefused(
                curve.what,
                fraction[-1],
                f"it ends on another branch than the controller's IK at the target (joint "
                f"{joint + 1} {_degrees(apart[joint])} apart): the arm would turn another way",
            )
    return JointPath(curve.what, q, fraction, seen.s)


def follow_looks(
    model: ArmModel,
    T_flange_tcp: Transform,
    curves: Sequence[TcpCurve],
    seen_all: Sequence[Looks],
    q_start: ArrayLike,
) -> list[JointPath]:
    """The joint paths of consecutive moveL pieces ``curves`` whose ``looks`` are solved
    already (``seen_all``), each from where the one before ended: what ``follow`` gives piece
    by piece, with every look of all the pieces checked at once (one batched forward
    kinematics). Where a check fails, ``follow`` piece by piece names the refusal."""
    here = np.asarray(q_start, dtype=np.float64)
    paths: list[JointPath] = []
    checked: list[tuple[Joints, Joints, _Singular]] = []
    for curve, seen in zip(curves, seen_all, strict=True):
        fraction = _fractions(curve, seen.s)
        q, steps, near = _on_branch(model, curve, seen, here, fraction)
        paths.append(JointPath(curve.what, q, fraction, seen.s))
        checked.append((q, steps, near))
        here = q[-1]
    if not paths:
        return paths
    problem = _first_problem(
        model,
        T_flange_tcp,
        np.concatenate([seen.T_base_tcp for seen in seen_all]),
        np.concatenate([q for q, _, _ in checked]),
        np.concatenate([steps for _, steps, _ in checked]),
        _Singular(
            np.concatenate([near.shoulder_m for _, _, near in checked]),
            np.concatenate([near.wrist for _, _, near in checked]),
            np.concatenate([near.elbow for _, _, near in checked]),
        ),
    )
    if problem is None:
        return paths
    here = np.asarray(q_start, dtype=np.float64)
    for curve, seen in zip(curves, seen_all, strict=True):
        here = follow(model, T_flange_tcp, curve, here, seen=seen).q[-1]  # raises
    return paths


@dataclass(frozen=True)
class _Singular:
    """How near each look (n + 1,) of a path on one branch is to the singularities
    (``ik.Branches``' measures for that branch)."""

    shoulder_m: NDArray[np.float64]
    wrist: NDArray[np.float64]
    elbow: NDArray[np.float64]


def _fractions(curve: TcpCurve, s: NDArray[np.float64]) -> NDArray[np.float64]:
    """Where the looks ``s`` along ``curve`` lie along its whole move, 0 to 1."""
    result: NDArray[np.float64] = curve.fraction(0.0) + s * (
        curve.fraction(1.0) - curve.fraction(0.0)
    )
    return result


def _on_branch(
    model: ArmModel,
    curve: TcpCurve,
    seen: Looks,
    start: Joints,
    fraction: NDArray[np.float64],
) -> tuple[Joints, Joints, _Singular]:
    """The joints ``q`` (n + 1, 6) at the looks on the branch nearest ``start`` (each joint
    continuous from ``start``), their steps (n, 6) and the branch's nearness to the
    singularities; ``JointPathRefused`` where no branch starts near ``start``."""
    solved = seen.solved
    gaps = np.abs(wrap(solved.q[0] - start)).max(axis=1)
    branch = int(np.argmin(np.where(np.isnan(gaps), np.inf, gaps)))
    if np.isnan(gaps[branch]):
        raise JointPathRefused(curve.what, fraction[0], f"the {model.name} cannot reach its start")
    if not gaps[branch] <= BRANCH_TOLERANCE_RAD:
        raise JointPathRefused(
            curve.what,
            fraction[0],
            "the arm's joints are on no branch that reaches the move's start "
            f"({_degrees(gaps[branch])} from the nearest): check robot.model",
        )
    on_branch = solved.q[:, branch]
    steps = wrap(np.diff(on_branch, axis=0))
    q = start + wrap(on_branch[0] - start) + np.concatenate([np.zeros((1, 6)), np.cumsum(steps, 0)])
    near = _Singular(
        solved.shoulder_m, solved.wrist[:, branch // 4], solved.elbow[:, branch // 2]
    )
    return q, steps, near


def _first_problem(
    model: ArmModel,
    T_flange_tcp: Transform,
    T_base_tcp: NDArray[np.float64],
    q: Joints,
    steps: Joints,
    near: _Singular,
) -> tuple[int, str] | None:
    """The first look along the path the arm cannot take, and why; None when it can take all."""
    found: list[tuple[int, str]] = []

    def first(bad: ArrayLike, reason: str) -> None:
        hits = np.flatnonzero(bad)
        if hits.size:
            found.append((int(hits[0]), reason))

    first(
        near.shoulder_m < SHOULDER_SINGULAR_M,
        "the wrist passes near joint 1's axis (the shoulder singularity)",
    )
    first(
        near.wrist < WRIST_SINGULAR,
        "wrist 2 comes within 2 deg of lining up joints 4 and 6 (the wrist singularity)",
    )
    first(
        near.elbow < ELBOW_SINGULAR,
        "the elbow comes within 2 deg of straight or folded (the elbow singularity)",
    )
    jumps = np.abs(steps).max(axis=1)
    hits = np.flatnonzero(jumps > MAX_JOINT_STEP_RAD)
    if hits.size:
        k = int(hits[0])
        joint = int(np.argmax(np.abs(steps[k])))
        found.append(
            (
                k + 1,
                f"joint {joint + 1} would turn {_degrees(abs(steps[k, joint]))} in one step "
                f"(at most {_degrees(MAX_JOINT_STEP_RAD)}): a singularity is near",
            )
        )
    first(np.isnan(q).any(axis=1), f"the {model.name} cannot reach the path there")
    if not found:
        reached = tcp_poses(model, q, T_flange_tcp)
        off_m = np.linalg.norm(reached[:, :3, 3] - T_base_tcp[:, :3, 3], axis=1)
        relative = np.swapaxes(reached[:, :3, :3], 1, 2) @ T_base_tcp[:, :3, :3]
        # atan2(sin, cos) of the turn between them: well conditioned near 0, where arccos of
        # the cosine alone turns a target's round-off (1e-7 off orthonormal) into 4e-4 rad.
        cos_turn = (np.trace(relative, axis1=1, axis2=2) - 1.0) / 2.0
        skew = relative - np.swapaxes(relative, 1, 2)
        sin_turn = np.linalg.norm(skew[:, [2, 0, 1], [1, 2, 0]], axis=1) / 2.0
        off_rad = np.arctan2(sin_turn, cos_turn)
        first(
            (off_m > FOLLOW_TOLERANCE_M) | (off_rad > FOLLOW_TOLERANCE_RAD),
            "the joints found miss the TCP path by more than 0.01 mm (a defect: report it)",
        )
    # The earliest look; at one look, a singularity before the reach it spoils.
    return min(found, key=lambda problem: problem[0]) if found else None


def follow_all(
    model: ArmModel,
    T_flange_tcp: Transform,
    curves: Sequence[TcpCurve],
    q_start: ArrayLike,
    q_ends: Sequence[ArrayLike | None],
) -> list[JointPath]:
    """The joint paths of consecutive moveL pieces (a blended path: straight pieces and the
    curves of their corners), each from where the one before ended; ``q_ends[i]``: the
    controller's IK where piece ``i`` ends at a target, None where it does not (a blend)."""
    paths: list[JointPath] = []
    here = np.asarray(q_start, dtype=np.float64)
    for curve, q_end in zip(curves, q_ends, strict=True):
        paths.append(follow(model, T_flange_tcp, curve, here, q_end))
        here = paths[-1].q[-1]
    return paths


def joint_move(what: str, q_from: ArrayLike, q_to: ArrayLike) -> JointPath:
    """The joint path of a moveJ from ``q_from`` to ``q_to`` (rad): linear in joint angles (as
    the controller drives it), no joint turning more than ``JOINT_STEP_RAD`` in a step."""
    start = np.asarray(q_from, dtype=np.float64)
    span = np.asarray(q_to, dtype=np.float64) - start
    n = max(1, math.ceil(float(np.abs(span).max()) / JOINT_STEP_RAD))
    fraction = np.linspace(0.0, 1.0, n + 1)
    return JointPath(what, start + fraction[:, None] * span, fraction, fraction)


def _degrees(angle_rad: float) -> str:
    return f"{math.degrees(float(angle_rad)):.1f} deg"
