"""``SceneCheck``: the scene's obstacles, the tool's solids and the arm's model, built once per
choice of a candidate, checking whole sequences with the held part riding along: the tool and the
part (``collide.check_path``), then the arm's links and the tool against the arm
(``arm_collide.ArmCheck``) unless ``scene.arm: unchecked``."""

from __future__ import annotations

from collections.abc import Sequence

from handeye_pick.arm.models import ArmModel
from handeye_pick.config.schema import PICK_MOVES, SceneConfig, ToolShape
from handeye_pick.geometry import Transform, invert
from handeye_pick.safety import CheckResult
from handeye_pick.scene.arm_collide import ARM_CHECK, ArmCheck
from handeye_pick.scene.collide import Group, Sweep, check_path, end_refusal
from handeye_pick.scene.layout import arm_not_checked
from handeye_pick.scene.path import Piece, describe_move, pieces
from handeye_pick.scene.shapes import Solid, obstacles, part_solid, tool_solids
from handeye_pick.steps import Step

GRASP = PICK_MOVES[1]



class SceneCheck:
    """The scene's obstacles and the tool's solids for the active TCP offset ``T_flange_tcp``
    (m), and the arm ``model`` (``robot.model``; with ``scene.arm: unchecked`` the tool alone,
    and every result list says so first; None, as the config loader allows only with that:
    the tool alone), ready to check sequences."""

    def __init__(
        self,
        scene: SceneConfig,
        shape: tuple[ToolShape, ...],
        T_flange_tcp: Transform,
        model: ArmModel | None = None,
    ) -> None:
        self.sweep = Sweep(obstacles(scene), scene.clearance_mm / 1000.0)
        self.tool = tool_solids(shape, T_flange_tcp)
        self._tool = Group(self.tool, self.sweep.clearance_m)
        unchecked = arm_not_checked(scene)
        self.arm = (
            ArmCheck(model, self.sweep.obstacles, self.sweep.clearance_m, self.tool, T_flange_tcp)
            if unchecked is None and model is not None
            else None
        )
        self._unchecked = (
            [CheckResult(ARM_CHECK, "path", True, unchecked)] if unchecked is not None else []
        )

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
        q_actual: Sequence[float] | None = None,
    ) -> list[CheckResult]:
        """``collision`` results of ``steps`` driven from ``T_base_tcp_start``, then the arm's
        (``arm collision``, from the controller's actual joints ``q_actual``, rad); the part
        (its box ``part_size_mm`` at ``T_base_obj``, None: not modelled) rides with the TCP
        from the grasp ``T_base_tcp_grasp`` on."""
        part = (
            part_solid(part_size_mm, invert(T_base_tcp_grasp) @ T_base_obj)
            if part_size_mm is not None
            else None
        )
        built = pieces(steps, T_base_tcp_start)
        tool = check_path(self.sweep, built, self._tool, part)
        return self._with_arm(tool, steps, T_base_tcp_start, part, q_actual, built)

    def check_tool(
        self,
        steps: Sequence[Step],
        T_base_tcp_start: Transform,
        q_actual: Sequence[float] | None = None,
    ) -> list[CheckResult]:
        """``collision`` results of a sequence of configured targets (a place, a named pose)
        driven from ``T_base_tcp_start``, the tool alone (a part carried since an earlier pick
        is not modelled), then the arm's from the controller's actual joints ``q_actual``."""
        built = pieces(steps, T_base_tcp_start)
        tool = check_path(self.sweep, built, self._tool, None)
        return self._with_arm(tool, steps, T_base_tcp_start, None, q_actual, built)

    def _with_arm(
        self,
        tool: list[CheckResult],
        steps: Sequence[Step],
        T_base_tcp_start: Transform,
        part: Solid | None,
        q_actual: Sequence[float] | None,
        built: list[Piece],
    ) -> list[CheckResult]:
        """The tool's results and the arm's: the arm is swept once the tool is clear (along
        the pieces ``built`` for the tool's sweep)."""
        if self.arm is None or not all(r.passed for r in tool):
            return [*self._unchecked, *tool]
        if q_actual is None:
            return [
                *tool,
                CheckResult(ARM_CHECK, "path", False, "the arm's joints are not known"),
            ]
        return [*tool, *self.arm.check(steps, T_base_tcp_start, q_actual, part, built)]
