"""``SceneCheck``: the scene's obstacles and the tool's solids, built once per choice of a
candidate, checking whole sequences (``collide.check_path``) with the held part riding along."""

from __future__ import annotations

from collections.abc import Sequence

from handeye_pick.config.schema import PICK_MOVES, SceneConfig, ToolShape
from handeye_pick.geometry import Transform, invert
from handeye_pick.safety import CheckResult
from handeye_pick.scene.collide import Group, Sweep, check_path, end_refusal
from handeye_pick.scene.path import Piece, describe_move, pieces
from handeye_pick.scene.shapes import obstacles, part_solid, tool_solids
from handeye_pick.steps import Step

GRASP = PICK_MOVES[1]


class SceneCheck:
    """The scene's obstacles and the tool's solids for the active TCP offset ``T_flange_tcp``
    (m), ready to check sequences."""

    def __init__(
        self, scene: SceneConfig, shape: tuple[ToolShape, ...], T_flange_tcp: Transform
    ) -> None:
        self.sweep = Sweep(obstacles(scene), scene.clearance_mm / 1000.0)
        self.tool = tool_solids(shape, T_flange_tcp)
        self._tool = Group(self.tool, self.sweep.clearance_m)

    def descent_refusal(
        self, T_base_tcp_approach: Transform, T_base_tcp_grasp: Transform
    ) -> CheckResult | None:
        """The refusal of a grasp whose tool, standing at ``T_base_tcp_grasp``, is too close
        to the scene already (None: it is not); the cheap first look at an alternative, before
        its whole sequence is built and swept."""
        descent = Piece(
            GRASP,
            describe_move(GRASP),
            T_base_tcp_approach,
            T_base_tcp_grasp,
            0.0,
            1.0,
            held=False,
            contact=False,
        )
        return end_refusal(self.sweep, descent, self._tool)

    def check(
        self,
        steps: Sequence[Step],
        T_base_tcp_start: Transform,
        part_size_mm: tuple[float, float, float] | None,
        T_base_obj: Transform,
        T_base_tcp_grasp: Transform,
    ) -> list[CheckResult]:
        """``collision`` results of ``steps`` driven from ``T_base_tcp_start``; the part (its
        box ``part_size_mm`` at ``T_base_obj``, None: not modelled) rides with the TCP from
        the grasp ``T_base_tcp_grasp`` on."""
        part = (
            part_solid(part_size_mm, invert(T_base_tcp_grasp) @ T_base_obj)
            if part_size_mm is not None
            else None
        )
        return check_path(self.sweep, pieces(steps, T_base_tcp_start), self._tool, part)

    def check_tool(self, steps: Sequence[Step], T_base_tcp_start: Transform) -> list[CheckResult]:
        """``collision`` results of a sequence of configured targets (a place, a named pose)
        driven from ``T_base_tcp_start``, the tool alone: a part carried since an earlier pick
        is not modelled."""
        return check_path(self.sweep, pieces(steps, T_base_tcp_start), self._tool, None)
