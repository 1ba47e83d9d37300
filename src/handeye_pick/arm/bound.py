"""How far any point of a link solid can move while the joints take one step: the bound a sweep
needs to step along a joint path without missing a contact.

Joint ``j`` turning by ``dq_j`` moves a point at most ``|dq_j|`` times its distance from joint
``j``'s axis; summing over the joints that carry the link bounds the point's path. The distances
are those at the step's start; while the step runs they can grow by no more than the point
itself moves, which the factor ``1 / (1 - sum |dq_j|)`` covers (so a step must turn the joints
by less than 1 rad in all). It holds when every joint turns one way through the step, as along
a moveJ step and a moveL step (``path.py``'s steps are short next to a joint's turning point).

Frames and units: joint angles and steps (N, 6) in radians; distances in metres.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from handeye_pick.arm.kinematics import frames, joint_batch, solids_on
from handeye_pick.arm.models import ArmModel


def axis_distances(model: ArmModel, Q: ArrayLike) -> NDArray[np.float64]:
    """The largest distance (m) of any point of each link solid from each joint's axis, for
    every joint vector: (N, L, 6); 0 for a joint that does not carry the link (beyond its
    frame). A capsule's or cylinder's points lie within its radius of its axis segment, and a
    segment is farthest from a line at one of its ends."""
    F = frames(model, Q)
    return distances_at(model, F, solids_on(model, F))


def distances_at(
    model: ArmModel, F: NDArray[np.float64], solids: NDArray[np.float64]
) -> NDArray[np.float64]:
    """``axis_distances`` from the frames ``F`` (N, 7, 4, 4) and the link solids' poses
    ``solids`` (N, L, 4, 4) already computed."""
    half = np.array([link.length_m / 2.0 for link in model.links])
    radius = np.array([link.radius_m for link in model.links])
    centre, along = solids[..., :3, 3], solids[..., :3, 2]
    links = len(model.links)
    ends = np.concatenate(
        [centre - half[:, None] * along, centre + half[:, None] * along], axis=1
    )  # (N, 2L, 3): each solid's axis segment, first ends then second ends
    origin, axis = F[:, :6, :3, 3], F[:, :6, :3, 2]  # joint j turns about frame j - 1's z
    # |p - o|^2 - ((p - o) . a)^2 expanded, every product one batched matmul (its round-off,
    # some 1e-8 m near an axis, lies far inside the sweep's 0.5 mm tolerance)
    p_a = ends @ np.swapaxes(axis, 1, 2)  # (N, 2L, 6)
    p_o = ends @ np.swapaxes(origin, 1, 2)
    o_a = np.einsum("njk,njk->nj", origin, axis)[:, None, :]
    o_o = np.einsum("njk,njk->nj", origin, origin)[:, None, :]
    p_p = np.einsum("nek,nek->ne", ends, ends)[:, :, None]
    squared = p_p - 2.0 * p_o + o_o - (p_a - o_a) ** 2
    perpendicular = np.sqrt(np.maximum(squared, 0.0))
    perpendicular = np.maximum(perpendicular[:, :links], perpendicular[:, links:])
    distance = perpendicular + radius[None, :, None]
    carried = np.arange(6)[None, :] < model.solid_frames[:, None]  # (L, 6)
    result: NDArray[np.float64] = np.where(carried, distance, 0.0)
    return result


def motion_bound(model: ArmModel, Q: ArrayLike, dQ: ArrayLike) -> NDArray[np.float64]:
    """The farthest (m) any point of each link solid can move while the joints go from each
    row of ``Q`` by the step in the same row of ``dQ`` (rad): (N, L). Infinite for a link whose
    joints turn by 1 rad or more in all: take smaller steps."""
    return bound_from(axis_distances(model, Q), dQ)


def bound_from(distances: NDArray[np.float64], dQ: ArrayLike) -> NDArray[np.float64]:
    """``motion_bound`` from the links' ``axis_distances`` (N, L, 6) at the steps' starts."""
    turns = np.abs(joint_batch(dQ))[:, None, :] * (distances > 0.0)  # (N, L, 6)
    total = turns.sum(axis=2)
    moved = (turns * distances).sum(axis=2)
    with np.errstate(divide="ignore"):
        result: NDArray[np.float64] = np.where(total < 1.0, moved / (1.0 - total), np.inf)
    return result


def carried_bound(
    F: NDArray[np.float64],
    centres_m: NDArray[np.float64],
    radii_m: NDArray[np.float64],
    dQ: ArrayLike,
) -> NDArray[np.float64]:
    """``motion_bound`` of balls carried by the flange (all six joints: the tool's solids and
    the held part, each inside a ball of ``radii_m`` (K,) about ``centres_m`` (N, K, 3) in
    base): (N, K) m. ``F``: the frames (N, 7, 4, 4) at the step's start (``frames``)."""
    origin, axis = F[:, :6, :3, 3], F[:, :6, :3, 2]
    offset = centres_m[:, :, None, :] - origin[:, None]  # (N, K, 6, 3)
    along_axis = np.einsum("nkjc,njc->nkj", offset, axis)
    perpendicular = np.sqrt(
        np.maximum(np.einsum("nkjc,nkjc->nkj", offset, offset) - along_axis**2, 0.0)
    )
    turns = np.abs(joint_batch(dQ))  # (N, 6)
    total = turns.sum(axis=1)[:, None]
    moved = np.einsum("nkj,nj->nk", perpendicular + radii_m[None, :, None], turns)
    with np.errstate(divide="ignore"):
        result: NDArray[np.float64] = np.where(total < 1.0, moved / (1.0 - total), np.inf)
    return result
