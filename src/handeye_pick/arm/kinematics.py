"""Forward kinematics of an ``ArmModel`` for a batch of joint vectors at once (numpy).

Frames and units: ``Q`` is (N, 6) joint angles in radians, base joint first. ``T_base_*`` are
float64 (..., 4, 4) transforms in metres in the controller's base frame (DH frame 0). Frame
``i`` (1 to 6) is DH frame ``i``: it turns with joints 1 to ``i``; frame 6 is the tool flange.
The TCP is the flange moved by the TCP offset ``T_flange_tcp`` (m).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from handeye_pick.arm.models import ALPHA_RAD, ArmModel
from handeye_pick.geometry import Transform

Joints = NDArray[np.float64]
"""Joint angles (rad): (6,) for one arm pose, (N, 6) for a batch."""

_COS_ALPHA = np.round(np.cos(ALPHA_RAD))  # exactly 0 and +-1: the twists are right angles
_SIN_ALPHA = np.round(np.sin(ALPHA_RAD))


def joint_batch(Q: ArrayLike) -> Joints:
    """``Q`` as a float64 (N, 6) array (one joint vector becomes a batch of one); ValueError
    for another shape or a non-finite angle."""
    batch = np.asarray(Q, dtype=np.float64)
    if batch.ndim == 1:
        batch = batch[np.newaxis]
    if batch.ndim != 2 or batch.shape[1] != 6:
        raise ValueError(f"joint angles must be 6 per arm pose (rad), got shape {batch.shape}")
    if not np.all(np.isfinite(batch)):
        raise ValueError("joint angles must be finite (rad)")
    return batch


def dh_transforms(model: ArmModel, Q: ArrayLike) -> NDArray[np.float64]:
    """Each DH row's transform, frame ``i - 1`` to frame ``i``, for every joint vector:
    (N, 6, 4, 4). Standard DH: Rz(q) Tz(d) Tx(a) Rx(alpha)."""
    return dh_rows(model, joint_batch(Q))


def dh_rows(model: ArmModel, q: Joints) -> NDArray[np.float64]:
    """``dh_transforms`` of joint angles (..., 6) as they are: a NaN angle (a branch that does
    not reach) gives NaN transforms."""
    c, s = np.cos(q), np.sin(q)
    ca, sa = _COS_ALPHA, _SIN_ALPHA
    a, d = np.asarray(model.a), np.asarray(model.d)
    A = np.zeros((*q.shape, 4, 4))
    A[..., 0, 0] = c
    A[..., 0, 1] = -s * ca
    A[..., 0, 2] = s * sa
    A[..., 0, 3] = a * c
    A[..., 1, 0] = s
    A[..., 1, 1] = c * ca
    A[..., 1, 2] = -c * sa
    A[..., 1, 3] = a * s
    A[..., 2, 1] = sa
    A[..., 2, 2] = ca
    A[..., 2, 3] = d
    A[..., 3, 3] = 1.0
    return A


def frames(model: ArmModel, Q: ArrayLike) -> NDArray[np.float64]:
    """``T_base_frame`` of DH frames 0 to 6 for every joint vector: (N, 7, 4, 4); frame 0 is
    the base itself, frame 6 the flange."""
    A = dh_transforms(model, Q)
    out = np.empty((A.shape[0], 7, 4, 4))
    out[:, 0] = np.eye(4)
    out[:, 1] = A[:, 0]
    for i in range(1, 6):
        np.matmul(out[:, i], A[:, i], out=out[:, i + 1])
    return out


def flange_poses(model: ArmModel, Q: ArrayLike) -> NDArray[np.float64]:
    """``T_base_flange`` (N, 4, 4) for every joint vector."""
    A = dh_transforms(model, Q)
    T = A[:, 0]
    for i in range(1, 6):
        T = T @ A[:, i]
    return T


def tcp_poses(model: ArmModel, Q: ArrayLike, T_flange_tcp: Transform) -> NDArray[np.float64]:
    """``T_base_tcp`` (N, 4, 4) for every joint vector, with the TCP offset ``T_flange_tcp``."""
    result: NDArray[np.float64] = flange_poses(model, Q) @ T_flange_tcp
    return result


def link_poses(model: ArmModel, Q: ArrayLike) -> NDArray[np.float64]:
    """``T_base_solid`` of every link solid (``model.links`` order) for every joint vector:
    (N, L, 4, 4), each the solid's centre and axes (its axis along z)."""
    return solids_on(model, frames(model, Q))


def solids_on(model: ArmModel, F: NDArray[np.float64]) -> NDArray[np.float64]:
    """``link_poses`` from the frames ``F`` (N, 7, 4, 4) ``frames`` gives."""
    n = F.shape[0]
    out = np.empty((n, len(model.links), 4, 4))
    for index, link in enumerate(model.links):
        # (N, 4, 4) @ (4, 4) as one (4N, 4) @ (4, 4) product
        out[:, index] = (F[:, link.frame].reshape(4 * n, 4) @ link.T_frame_solid).reshape(n, 4, 4)
    return out
