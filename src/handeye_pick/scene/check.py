"""``SceneCheck``: the scene's obstacles and the tool's solids, built once per choice of a
candidate, checking whole sequences (``collide.check_path``) with the held part riding along."""

from __future__ import annotations

from collections.abc import Sequence

from handeye_pick.cell.steps import Step
from handeye_pick.config.schema import SceneConfig, ToolShape
from handeye_pick.geometry import Transform, invert
from handeye_pick.safety import CheckResult
from handeye_pick.scene.collide import Sweep, check_path
from handeye_pick.scene.path import pieces
from handeye_pick.scene.shapes import obstacles, part_solid, tool_solids


class SceneCheck:
    """The scene's obstacles and the tool's solids for the active TCP offset ``T_flange_tcp``
    (m), ready to check sequences."""

    def __init__(
        self, scene: SceneConfig, shape: tuple[ToolShape, ...], T_flange_tcp: Transform
    ) -> None:
        self.sweep = Sweep(obstacles(scene), scene.clearance_mm / 1000.0)
        self.tool = tool_solids(shape, T_flange_tcp)

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
        return check_path(self.sweep, pieces(steps, T_base_tcp_start), self.tool, part)
