"""Closed-form inverse kinematics of an ``ArmModel``, batched: the eight branches of every
flange pose at once, each labelled the same way along a path, and how near each pose is to the
arm's singularities.

A UR arm reaches a flange pose in up to eight ways: the shoulder on one side of the base or the
other, the wrist flipped or not, the elbow up or down. Away from a singularity each branch's
angles change continuously with the pose, so following a path on one branch is following the arm
(``path.py``). The singularities, where branches meet: the wrist centre on the cylinder of
radius d4 around joint 1's axis (shoulder), sin q5 = 0 (wrist: joints 4 and 6 in line) and
sin q3 = 0 (elbow: the arm stretched or folded).

Frames and units: ``T_base_flange`` (N, 4, 4) in metres in the base frame; angles in radians in
(-pi, pi].
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from handeye_pick.arm.kinematics import dh_rows
from handeye_pick.arm.models import ArmModel

ROUND_OFF = 1e-9
"""How far (m^2 for the shoulder's test, unitless for the elbow's cosine) a pose may lie beyond
a branch's reach and count as on its edge: round-off of an arm stretched or on the singular
cylinder."""
BRANCHES = 8
"""Branch ``b``: shoulder sign ``b // 4``, wrist sign ``b // 2 % 2``, elbow sign ``b % 2``
(0: +, 1: -)."""


@dataclass(frozen=True)
class Branches:
    """The solutions of N flange poses: ``q`` (N, 8, 6) rad, NaN where a branch does not reach;
    and per pose the distances from the singularities: ``shoulder_m`` (m, the wrist centre's
    from the singular cylinder), ``wrist`` (|sin q5|, per shoulder branch: (N, 2)) and
    ``elbow`` (|sin q3| per shoulder and wrist branch: (N, 4))."""

    q: NDArray[np.float64]
    shoulder_m: NDArray[np.float64]
    wrist: NDArray[np.float64]
    elbow: NDArray[np.float64]


def _invert(T: NDArray[np.float64]) -> NDArray[np.float64]:
    """The inverse of every rigid transform of a stack (..., 4, 4)."""
    R_t = np.swapaxes(T[..., :3, :3], -1, -2)
    out = np.zeros_like(T)
    out[..., :3, :3] = R_t
    out[..., :3, 3] = -np.einsum("...ij,...j->...i", R_t, T[..., :3, 3])
    out[..., 3, 3] = 1.0
    return out


_SIDES = np.array([1.0, -1.0])


def branches(
    model: ArmModel, T_base_flange: NDArray[np.float64], branch: int | None = None
) -> Branches:
    """All eight branches of every pose of ``T_base_flange`` (N, 4, 4); with ``branch``, that
    one alone (``q`` (N, 1, 6), ``wrist`` and ``elbow`` (N, 1): index 0 stands for it)."""
    T = np.asarray(T_base_flange, dtype=np.float64)
    if branch is None:
        shoulders = wrists = elbows = _SIDES
    else:
        shoulders = _SIDES[[branch // 4]]
        wrists, elbows = _SIDES[[branch // 2 % 2]], _SIDES[[branch % 2]]
    ns, nw, ne = len(shoulders), len(wrists), len(elbows)
    n = T.shape[0]
    d4, d6 = model.d[3], model.d[5]
    a2, a3 = model.a[1], model.a[2]
    R, p = T[:, :3, :3], T[:, :3, 3]

    # Joint 1: the wrist centre lies d4 from the vertical plane through joint 1's axis that
    # holds joint 2's axis.
    centre = p - d6 * R[:, :, 2]
    radius_sq = centre[:, 0] ** 2 + centre[:, 1] ** 2
    along = np.sqrt(_within(radius_sq - d4 * d4, 0.0, np.inf))
    phi = np.arctan2(centre[:, 1], centre[:, 0])
    q1 = phi[:, None] + np.arctan2(d4, shoulders[None, :] * along[:, None])  # (N, ns)

    # Joints 5 and 6: joint 2's axis [sin q1, -cos q1, 0] seen from the flange is
    # [s5 c6, -s5 s6, c5].
    axis2 = np.stack([np.sin(q1), -np.cos(q1), np.zeros_like(q1)], axis=-1)  # (N, ns, 3)
    seen = np.einsum("nji,nsj->nsi", R, axis2)  # R^T axis2, (N, ns, 3)
    s5_abs = np.hypot(seen[..., 0], seen[..., 1])  # (N, ns)
    flip = wrists[None, None, :]
    q5 = np.arctan2(flip * s5_abs[..., None], seen[..., 2, None])  # (N, ns, nw)
    q6 = np.arctan2(-flip * seen[..., 1, None], flip * seen[..., 0, None])

    # Joints 2 to 4: a planar arm in frame 1 reaching frame 4.
    q = np.zeros((n, ns, nw, 6))
    q[..., 0] = q1[:, :, None]
    q[..., 4] = q5
    q[..., 5] = q6
    A = dh_rows(model, q)  # (N, ns, nw, 6, 4, 4)
    T_1_4 = _invert(A[..., 0, :, :]) @ T[:, None, None] @ _invert(A[..., 4, :, :] @ A[..., 5, :, :])
    x, y = T_1_4[..., 0, 3], T_1_4[..., 1, 3]
    c3 = (x * x + y * y - a2 * a2 - a3 * a3) / (2.0 * a2 * a3)
    c3 = _within(c3, -1.0, 1.0)
    s3_abs = np.sqrt(1.0 - c3 * c3)  # (N, ns, nw)
    s3 = elbows * s3_abs[..., None]  # (N, ns, nw, ne): the elbow's sign last
    q3 = np.arctan2(s3, c3[..., None])
    q2 = np.arctan2(y, x)[..., None] - np.arctan2(a3 * s3, a2 + a3 * c3[..., None])
    q234 = np.arctan2(T_1_4[..., 1, 0], T_1_4[..., 0, 0])[..., None]
    out = np.empty((n, ns, nw, ne, 6))
    out[..., 0] = q1[:, :, None, None]
    out[..., 1] = q2
    out[..., 2] = q3
    out[..., 3] = q234 - q2 - q3
    out[..., 4] = q5[..., None]
    out[..., 5] = q6[..., None]
    return Branches(
        q=wrap(out.reshape(n, ns * nw * ne, 6)),
        shoulder_m=along,
        wrist=s5_abs,
        elbow=s3_abs.reshape(n, ns * nw),
    )


def _within(values: NDArray[np.float64], low: float, high: float) -> NDArray[np.float64]:
    """``values`` clipped to [low, high] where they lie outside by round-off only (``ROUND_OFF``),
    NaN where they lie farther out: a stretched arm or a wrist on the singular cylinder still
    solves, a pose out of reach does not."""
    clipped = np.clip(values, low, high)
    result: NDArray[np.float64] = np.where(np.abs(values - clipped) <= ROUND_OFF, clipped, np.nan)
    return result


def wrap(angles: NDArray[np.float64]) -> NDArray[np.float64]:
    """Angles (rad) in (-pi, pi]."""
    result: NDArray[np.float64] = np.pi - np.remainder(np.pi - angles, 2.0 * np.pi)
    return result
