"""The whole arm's swept check (docs/scene.md): every link solid from the upper arm to the last
wrist against every obstacle of the scene, the shoulder against the floor, and the tool's solids
and the held part against the arm's own base, shoulder and upper arm (not the links next to the
tool), at every look along the joint path of every move (``arm_legs``), keeping
``scene.clearance_mm``. The tool and the part against the scene are ``collide``'s sweep.

The proof. Between two looks of a move no point of a solid moves farther than ``B``
(``arm.bound``, from the joint steps; for a pair of moving solids the sum of theirs). With
margins ``m0`` and ``m1`` at the two looks (distance less the clearance), the pair's margin at
any moment between them is at least ``(m0 + m1 - B) / 2``: it has moved at most ``a`` from the
first look and ``B - a`` from the second. A step with ``m0 + m1 >= B`` keeps the clearance
throughout; a step that does not is halved (the look between on the move's own path) until it
does, at most ``MAX_SPLITS`` times. A look whose margin is below ``PROOF_TOLERANCE_M`` refuses.

The screen. Every solid lies within a segment swept by a ball (a link's capsule, which holds its
cylinder; a tool solid's or the part's bounding ball), and a segment is no nearer a box than its
bounding box in the box's frame: lower bounds of every look, solid and obstacle at once (numpy).
python-fcl measures a pair exactly only where that bound does not prove the step.

Frames and units: poses ``T_base_*`` float64 4x4 in metres; joints radians; messages in mm.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import fcl
import numpy as np
from numpy.typing import ArrayLike, NDArray

from handeye_pick.arm.bound import bound_from, carried_bound, distances_at
from handeye_pick.arm.kinematics import Joints, frames, solids_on
from handeye_pick.arm.models import ArmModel
from handeye_pick.arm.path import JointPath
from handeye_pick.geometry import Transform, make_transform
from handeye_pick.safety import CheckResult
from handeye_pick.scene.arm_legs import Leg, LegRefused, legs, start_joints
from handeye_pick.scene.collide import PROOF_TOLERANCE_M, refusal_detail
from handeye_pick.scene.path import Piece
from handeye_pick.scene.shapes import Obstacle, Solid
from handeye_pick.steps import Step

ARM_CHECK = "arm collision"
PATH_CHECK = "joint path"
MAX_SPLITS = 12
"""How often a step is halved before its pair counts as not proven clear: 1/4096 of a step."""
OWN_LINKS = ("shoulder", "upper arm")
"""The arm's links the tool and the part are checked against (with its base)."""
SWEEP_STRIDE = 4
"""The sweep looks first at every this many looks of a joint path (``arm.path``'s steps): far
from every obstacle those longer steps are proven already; inside a step they do not prove,
every look of the path is added."""
FLOOR_ONLY = "shoulder"
"""The link checked against the floor alone: it turns about the base, beside it."""

_REQUEST = fcl.DistanceRequest(enable_signed_distance=True)


def _base(model: ArmModel) -> Obstacle:
    """The arm's base: a cylinder of the shoulder's radius from the mounting plane (z 0) to
    the shoulder's axis (d1); its screen box bounds it."""
    radius, height = model.link("shoulder").radius_m, model.d[0]
    T = make_transform(np.eye(3), [0.0, 0.0, height / 2.0])
    geometry = fcl.CollisionObject(fcl.Cylinder(radius, height), fcl.Transform(T[:3, :3], T[:3, 3]))
    return Obstacle("the arm's base", np.array([2 * radius, 2 * radius, height]), T, geometry)


@dataclass(frozen=True)
class _Pairs:
    """The pairs one set of moving solids is checked on: solid ``body`` (links first, then
    the tool's solids and the part) against obstacle ``other`` (an index of ``ArmCheck.static``),
    or against the link ``other`` where ``moving``."""

    tool: list[Solid]
    body: NDArray[np.intp]
    other: NDArray[np.intp]
    moving: NDArray[np.bool_]


@dataclass(frozen=True)
class _Failure:
    s: float  # along the leg's piece
    pair: int
    distance_m: float
    proven: bool  # False: the margins never proved the step, though no look was too close


@dataclass(frozen=True)
class _Screened:
    """The pairs the coarse boxes leave near, their bounds (N - 1, P) for the steps between
    the looks and their margins (N, P) at the looks (m)."""

    pairs: _Pairs
    bounds: NDArray[np.float64]
    margins: NDArray[np.float64]


class ArmCheck:
    """The arm ``model`` with the tool ``tool`` (solids in the TCP frame of ``T_flange_tcp``)
    against the scene's ``obstacles``, keeping ``clearance_m``."""

    def __init__(
        self,
        model: ArmModel,
        obstacles: Sequence[Obstacle],
        clearance_m: float,
        tool: Sequence[Solid],
        T_flange_tcp: Transform,
    ) -> None:
        self.model = model
        self.T_flange_tcp = T_flange_tcp
        self.clearance_m = clearance_m
        self.static = [*obstacles, _base(model)]
        # A point c in box o's frame is R_o^T (c - t_o): for all boxes at once c @ [R_1 .. R_O]
        # less [t_1 @ R_1 .. t_O @ R_O].
        rotations = [o.T_base_box[:3, :3] for o in self.static]
        self._to_local = np.hstack(rotations)  # (3, 3 O)
        self._offset = np.concatenate(
            [o.T_base_box[:3, 3] @ R for o, R in zip(self.static, rotations, strict=True)]
        )
        self._half_box = np.stack([o.size_m / 2.0 for o in self.static])  # (O, 3)
        extent = np.stack(  # each box's half extent along the base axes
            [np.abs(R) @ h for R, h in zip(rotations, self._half_box, strict=True)]
        )
        centres = np.stack([o.T_base_box[:3, 3] for o in self.static])
        self._box_low, self._box_high = centres - extent, centres + extent
        self._links = [
            fcl.CollisionObject(
                fcl.Capsule(link.radius_m, link.length_m)
                if link.kind == "capsule"
                else fcl.Cylinder(link.radius_m, link.length_m)
            )
            for link in model.links
        ]
        self._half_link = np.array([link.length_m / 2.0 for link in model.links])
        self._radius_link = np.array([link.radius_m for link in model.links])
        self._tool = list(tool)
        self._plain = self._pairs(self._tool)

    def _pairs(self, tool: list[Solid]) -> _Pairs:
        """Links (not the shoulder) against every scene obstacle, the shoulder against the
        floor, each tool solid (and the part) against the base and ``OWN_LINKS``: in the order
        of ``tool``, so the pairs of a tool with the part last begin with those without it."""
        links = [link.name for link in self.model.links]
        scene = range(len(self.static) - 1)
        base = len(self.static) - 1
        rows: list[tuple[int, int, bool]] = []
        for index, name in enumerate(links):
            rows += [
                (index, o, False)
                for o in scene
                if name != FLOOR_ONLY or self.static[o].label == "the floor"
            ]
        for k in range(len(tool)):
            body = len(links) + k
            rows.append((body, base, False))
            rows += [(body, links.index(name), True) for name in OWN_LINKS]
        bodies, others, moving = zip(*rows, strict=True)
        return _Pairs(
            tool, np.array(bodies, np.intp), np.array(others, np.intp), np.array(moving, bool)
        )

    def _labels(self, pairs: _Pairs, p: int) -> tuple[str, str]:
        """What a refusal calls pair ``p``'s solid and what it comes near."""
        names = [link.name for link in self.model.links] + [s.label for s in pairs.tool]
        body, other = int(pairs.body[p]), int(pairs.other[p])
        what = f"the arm's {names[other]}" if pairs.moving[p] else self.static[other].label
        return names[body], what

    def _place(
        self, Q: Joints, tool: list[Solid]
    ) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """The frames (N, 7, 4, 4) and every solid's pose (N, B, 4, 4): links, then tool."""
        F = frames(self.model, Q)
        tcp = F[:, 6] @ self.T_flange_tcp
        carried = np.stack([s.T_tcp_solid for s in tool])  # (K, 4, 4)
        poses = np.concatenate(
            [solids_on(self.model, F), np.einsum("nij,kjl->nkil", tcp, carried)], axis=1
        )
        return F, poses

    def _lower_bounds(self, poses: NDArray[np.float64], pairs: _Pairs) -> NDArray[np.float64]:
        """Each pair's distance lower bound (N, P) from the solids' segments and balls."""
        n, bodies = poses.shape[:2]
        half = np.concatenate([self._half_link, np.zeros(len(pairs.tool))])
        radius = np.concatenate([self._radius_link, [s.radius_m for s in pairs.tool]])
        centre, along = poses[..., :3, 3], poses[..., :3, 2]
        ends = np.stack([centre - half[:, None] * along, centre + half[:, None] * along])
        out = np.empty((n, len(pairs.body)))
        static = ~pairs.moving
        # Both ends of every segment in every box's frame, R^T (p - t), as one product; then
        # the gap on each axis between the segment's extent and the box's.
        local = (ends.reshape(-1, 3) @ self._to_local - self._offset).reshape(
            2, n, bodies, -1, 3
        )[:, :, pairs.body[static], pairs.other[static]]  # (2, N, P, 3)
        low, high = local.min(axis=0), local.max(axis=0)
        box = self._half_box[pairs.other[static]]
        gap = np.maximum(np.maximum(low - box, -box - high), 0.0)
        out[:, static] = np.sqrt((gap * gap).sum(axis=2)) - radius[pairs.body[static]]
        t, link = pairs.body[pairs.moving], pairs.other[pairs.moving]
        c, a = centre[:, t], ends[0][:, link]
        d = ends[1][:, link] - a
        along_d = ((c - a) * d).sum(axis=2) / np.maximum((d * d).sum(axis=2), 1e-12)
        nearest = a + np.clip(along_d, 0.0, 1.0)[..., None] * d
        out[:, pairs.moving] = np.linalg.norm(c - nearest, axis=2) - radius[t] - radius[link]
        return out

    def _exact(self, poses: NDArray[np.float64], pairs: _Pairs, n: int, p: int) -> float:
        """python-fcl's signed distance of pair ``p`` at look ``n`` (m)."""
        body, other = int(pairs.body[p]), int(pairs.other[p])
        a = self._object(poses[n, body], pairs, body)
        b = (
            self._object(poses[n, other], pairs, other)
            if pairs.moving[p]
            else self.static[other].geometry
        )
        return float(fcl.distance(a, b, _REQUEST, fcl.DistanceResult()))

    def _object(self, T: Transform, pairs: _Pairs, body: int) -> fcl.CollisionObject:
        L = len(self._links)
        geometry = self._links[body] if body < L else pairs.tool[body - L].geometry
        geometry.setRotation(T[:3, :3])
        geometry.setTranslation(T[:3, 3])
        return geometry

    def _margins(
        self,
        poses: NDArray[np.float64],
        pairs: _Pairs,
        need: NDArray[np.float64],
        lower: NDArray[np.float64] | None = None,
    ) -> NDArray[np.float64]:
        """Each pair's margin (N, P) at every look: its lower bound (``lower`` where known)
        less the clearance, the exact distance less the clearance where the bound is below
        ``need`` (N, P)."""
        if lower is None:
            lower = self._lower_bounds(poses, pairs)
        margin = lower - self.clearance_m
        for n, p in zip(*np.nonzero(margin < need + PROOF_TOLERANCE_M), strict=True):
            margin[n, p] = self._exact(poses, pairs, int(n), int(p)) - self.clearance_m
        return margin

    def _body_bounds(
        self, F: NDArray[np.float64], poses: NDArray[np.float64], dQ: Joints, tool: list[Solid]
    ) -> NDArray[np.float64]:
        """How far any point of each solid (N, B) can move while the joints take the steps
        ``dQ`` from where ``F`` and ``poses`` (``_place``) have them."""
        L = len(self._links)
        radii = np.array([s.radius_m for s in tool])
        return np.concatenate(
            [
                bound_from(distances_at(self.model, F, poses[:, :L]), dQ),
                carried_bound(F, poses[:, L:, :3, 3], radii, dQ),
            ],
            axis=1,
        )

    def _bounds(
        self, F: NDArray[np.float64], poses: NDArray[np.float64], dQ: Joints, pairs: _Pairs
    ) -> NDArray[np.float64]:
        """How far each pair's solids can come towards each other (N, P) for those steps: a
        solid's bound against an obstacle, the sum of both solids' against a moving link."""
        return _per_pair(self._body_bounds(F, poses, dQ, pairs.tool), pairs)

    def _coarse(self, poses: NDArray[np.float64], pairs: _Pairs) -> NDArray[np.float64]:
        """A lower bound of each pair's distance (P,) at every look of ``poses`` at once: the
        gap between the boxes (in base) that hold the solid at all the looks and the obstacle
        (or the other solid at all the looks)."""
        radius = np.concatenate([self._radius_link, [s.radius_m for s in pairs.tool]])
        half = np.concatenate([self._half_link, np.zeros(len(pairs.tool))])
        centre, along = poses[..., :3, 3], poses[..., :3, 2]
        reach = np.abs(along) * half[:, None]  # (N, B, 3): a segment's half extent per axis
        low = (centre - reach).min(axis=0) - radius[:, None]  # (B, 3)
        high = (centre + reach).max(axis=0) + radius[:, None]
        static = ~pairs.moving
        other_low = np.where(
            static[:, None], self._box_low[np.where(static, pairs.other, 0)], low[pairs.other]
        )
        other_high = np.where(
            static[:, None], self._box_high[np.where(static, pairs.other, 0)], high[pairs.other]
        )
        gap = np.maximum(
            np.maximum(other_low - high[pairs.body], low[pairs.body] - other_high), 0.0
        )
        result: NDArray[np.float64] = np.sqrt((gap * gap).sum(axis=1))
        return result

    def _screen(
        self, pairs: _Pairs, poses: NDArray[np.float64], by_body: NDArray[np.float64]
    ) -> _Screened | tuple[float, str, str]:
        """The margins at every look of ``poses`` (``_place``; solids beyond ``pairs``'
        ignored) of the pairs the coarse boxes do not prove clear, and their bounds for the
        steps between the looks (``by_body``: the solids' bounds, ``_body_bounds``); or, where
        the boxes prove every pair clear, the smallest box distance (m) and its pair's labels."""
        bodies = len(self._links) + len(pairs.tool)
        poses, by_body = poses[:, :bodies], by_body[:, :bodies]
        # Pairs whose boxes over the whole leg lie farther apart than any step can bring them
        # (with the clearance) are clear all along; the rest are screened look by look.
        coarse = self._coarse(poses, pairs) - self.clearance_m
        farthest = _per_pair(by_body.max(axis=0, initial=0.0)[None], pairs)[0]
        near = np.flatnonzero(coarse < farthest + PROOF_TOLERANCE_M)
        if near.size == 0:
            p = int(np.argmin(coarse))
            return float(coarse[p]) + self.clearance_m, *self._labels(pairs, p)
        pairs = _Pairs(pairs.tool, pairs.body[near], pairs.other[near], pairs.moving[near])
        bounds = _per_pair(by_body, pairs)
        need = np.zeros((len(poses), len(pairs.body)))
        need[:-1] = bounds
        need[1:] = np.maximum(need[1:], bounds)
        return _Screened(pairs, bounds, self._margins(poses, pairs, need))

    def _prove(
        self,
        leg: Leg,
        pairs: _Pairs,
        poses: NDArray[np.float64],
        by_body: NDArray[np.float64],
    ) -> CheckResult | tuple[float, str, str]:
        """The refusal of ``leg`` at its first look too close, or at a step never proven;
        else the smallest distance seen (m) and its pair's labels. ``poses``: every solid at
        every look of the leg (``_place``; solids beyond ``pairs``' ignored), ``by_body``: the
        solids' bounds of its steps (``_body_bounds``)."""
        Q, s = leg.path.q, leg.path.s
        screened = self._screen(pairs, poses, by_body)
        if not isinstance(screened, _Screened):
            return screened
        pairs, bounds, m = screened.pairs, screened.bounds, screened.margins
        n, p = divmod(int(np.argmin(m)), m.shape[1])
        closest = (float(m[n, p]) + self.clearance_m, *self._labels(pairs, p))
        if m[n, p] < PROOF_TOLERANCE_M:
            first = int(np.flatnonzero((m < PROOF_TOLERANCE_M).any(axis=1))[0])
            return self._refusal(leg, pairs, self._failure(s[first], m[first], True))
        k = np.flatnonzero((m[:-1] + m[1:] < bounds).any(axis=1))
        q0, q1, s0, s1, m0, m1 = Q[k], Q[k + 1], s[k], s[k + 1], m[k], m[k + 1]
        for _ in range(MAX_SPLITS):
            if len(k) == 0:
                return closest
            sm = (s0 + s1) / 2.0
            qm = leg.between(self.model, self.T_flange_tcp, sm, q0, q1)
            Fm, pm = self._place(qm, pairs.tool)
            b0 = self._bounds(*self._place(q0, pairs.tool), qm - q0, pairs)
            b1 = self._bounds(Fm, pm, q1 - qm, pairs)
            mm = self._margins(pm, pairs, np.maximum(b0, b1))
            bad = np.flatnonzero((mm < PROOF_TOLERANCE_M).any(axis=1))
            if bad.size:
                i = int(bad[np.argmin(sm[bad])])
                return self._refusal(leg, pairs, self._failure(sm[i], mm[i], True))
            left = (m0 + mm < b0).any(axis=1)
            right = (mm + m1 < b1).any(axis=1)
            k = np.concatenate([np.flatnonzero(left), np.flatnonzero(right)])
            q0, q1 = np.concatenate([q0[left], qm[right]]), np.concatenate([qm[left], q1[right]])
            s0, s1 = np.concatenate([s0[left], sm[right]]), np.concatenate([sm[left], s1[right]])
            m0, m1 = np.concatenate([m0[left], mm[right]]), np.concatenate([mm[left], m1[right]])
        if len(k) == 0:
            return closest
        i = int(np.argmin(s0))
        return self._refusal(leg, pairs, self._failure(s0[i], m0[i], False))

    def _failure(self, s: float, margins: NDArray[np.float64], proven: bool) -> _Failure:
        """The failure at ``s`` of the pair with the smallest of ``margins`` (P,)."""
        worst = int(np.argmin(margins))
        return _Failure(float(s), worst, float(margins[worst]) + self.clearance_m, proven)

    def _refusal(self, leg: Leg, pairs: _Pairs, failure: _Failure) -> CheckResult:
        """The refusal of ``leg``: the pair that stopped the proof where along the leg it comes
        deepest (exact distances at every look of the leg and where it stopped)."""
        _, poses = self._place(leg.path.q, pairs.tool)
        exact = [self._exact(poses, pairs, n, failure.pair) for n in range(len(poses))]
        n = int(np.argmin(exact))
        s, distance = (
            (float(leg.path.s[n]), exact[n])
            if exact[n] < failure.distance_m
            else (failure.s, failure.distance_m)
        )
        body, other = self._labels(pairs, failure.pair)
        where = f"at {float(leg.fraction(np.array([s]))[0]) * 100.0:.0f} % of {leg.what}"
        detail = refusal_detail(body, other, where, distance, self.clearance_m)
        if not failure.proven and distance >= self.clearance_m + PROOF_TOLERANCE_M:
            detail = (
                f"{body} could not be proven clear of {other} {where} (the nearest look "
                f"{distance * 1000.0:.1f} mm from it): take a path farther from it"
            )
        return CheckResult(ARM_CHECK, leg.move, False, detail)

    def _sweep(
        self,
        leg: Leg,
        looked: NDArray[np.intp],
        pairs: _Pairs,
        poses: NDArray[np.float64],
        lower: NDArray[np.float64],
        bounds: NDArray[np.float64],
    ) -> CheckResult | tuple[float, str, str]:
        """``_prove`` of ``leg`` from the looks ``looked`` (indices into its path) whose
        ``poses``, pair distance ``lower`` bounds (``_lower_bounds``) and pair bounds of the
        steps between them (``_per_pair``) are known: where the margins there prove every
        step, the leg is clear; else every look inside a step they do not prove is added and
        the leg proven from those (``_prove``, which halves a step where it must)."""
        need = np.zeros(lower.shape)
        need[:-1] = bounds
        need[1:] = np.maximum(need[1:], bounds)
        m = self._margins(poses, pairs, need, lower)
        low: NDArray[np.bool_] = np.any(m < PROOF_TOLERANCE_M, axis=1)
        open_steps = np.flatnonzero((m[:-1] + m[1:] < bounds).any(axis=1) | low[:-1] | low[1:])
        if open_steps.size == 0:
            n, p = divmod(int(np.argmin(m)), m.shape[1])
            return float(m[n, p]) + self.clearance_m, *self._labels(pairs, p)
        keep = np.zeros(len(leg.path.q), dtype=bool)
        keep[looked] = True
        for k in open_steps:
            keep[looked[k] : looked[k + 1]] = True
        fine = np.flatnonzero(keep)
        path = leg.path
        finer = replace(
            leg, path=JointPath(path.what, path.q[fine], path.fraction[fine], path.s[fine])
        )
        F, placed = self._place(finer.path.q, pairs.tool)
        bounds = self._body_bounds(F[:-1], placed[:-1], _turned(path.q, fine)[1:], pairs.tool)
        return self._prove(finer, pairs, placed, bounds)

    def check(
        self,
        steps: Sequence[Step],
        T_base_tcp_start: Transform,
        q_actual: ArrayLike,
        part: Solid | None,
        built: Sequence[Piece] | None = None,
    ) -> list[CheckResult]:
        """``arm collision`` results of ``steps`` driven from ``T_base_tcp_start`` with the
        controller's actual joints ``q_actual`` (rad), one per move, or the first refusal
        (a ``joint path`` refusal where the arm cannot follow a move). ``built``: the
        sequence's pieces when built already (``path.pieces``)."""
        q_start = start_joints(self.model, self.T_flange_tcp, T_base_tcp_start, q_actual)
        try:
            driven = legs(
                self.model, self.T_flange_tcp, steps, T_base_tcp_start, q_start, built
            )
        except LegRefused as refused:
            return [CheckResult(PATH_CHECK, refused.move, False, refused.reason)]
        if not driven:
            return []
        held = self._pairs([*self._tool, part]) if part is not None else self._plain
        # Every SWEEP_STRIDE-th look of every leg (and its last) placed, and every step
        # between them bounded by the joints' turns through it, as one batch.
        chosen = [_strided(len(leg.path.q)) for leg in driven]
        Q = np.concatenate([leg.path.q[i] for leg, i in zip(driven, chosen, strict=True)])
        turns = np.concatenate(
            [_turned(leg.path.q, i) for leg, i in zip(driven, chosen, strict=True)]
        )
        F, poses = self._place(Q, held.tool)
        by_body = self._body_bounds(F[:-1], poses[:-1], turns[1:], held.tool)
        lower = self._lower_bounds(poses, held)
        bounds = _per_pair(by_body, held)
        closest: dict[str, tuple[float, str, str]] = {}
        start = 0
        for leg, looked in zip(driven, chosen, strict=True):
            n = len(looked)
            pairs = held if leg.held else self._plain
            P = len(pairs.body)  # the part's pairs come last in ``held``
            # The steps of this leg only: not the one from its last look to the next leg's first.
            outcome = self._sweep(
                leg,
                looked,
                pairs,
                poses[start : start + n],
                lower[start : start + n, :P],
                bounds[start : start + n - 1, :P],
            )
            start += n
            if isinstance(outcome, CheckResult):
                return [outcome]
            if leg.move not in closest or outcome[0] < closest[leg.move][0]:
                closest[leg.move] = outcome
        return [
            CheckResult(
                ARM_CHECK,
                move,
                True,
                f"clear: closest {body} at least {round(distance * 1000.0, 1) + 0.0:.1f} mm "
                f"from {other} (clearance {self.clearance_m * 1000.0:g} mm)",
            )
            for move, (distance, body, other) in closest.items()
        ]


def _per_pair(by_body: NDArray[np.float64], pairs: _Pairs) -> NDArray[np.float64]:
    """Each pair's bound (N, P) from its solids' (N, B): one solid's against an obstacle, the
    sum of both against a moving link."""
    out = by_body[:, pairs.body]
    out[:, pairs.moving] += by_body[:, pairs.other[pairs.moving]]
    result: NDArray[np.float64] = out
    return result


def _strided(looks: int) -> NDArray[np.intp]:
    """Every ``SWEEP_STRIDE``-th of ``looks`` looks of a path, and its last."""
    every = np.arange(0, looks, SWEEP_STRIDE)
    result: NDArray[np.intp] = every if every[-1] == looks - 1 else np.append(every, looks - 1)
    return result


def _turned(q: Joints, looked: NDArray[np.intp]) -> Joints:
    """How far each joint turns in all (rad, the sum of its turns either way over the path's
    looks ``q`` (n, 6)) from each of the looks ``looked`` to the next: (len(looked), 6), the
    first row zero."""
    travelled = np.concatenate([np.zeros((1, 6)), np.cumsum(np.abs(np.diff(q, axis=0)), axis=0)])
    at = travelled[looked]
    result: Joints = np.concatenate([np.zeros((1, 6)), np.diff(at, axis=0)])
    return result
