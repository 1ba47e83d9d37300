"""The one skeleton every motion of a cell runs (a pick, a place, a named pose, a touch test):
halt guard, readiness, pre-flight, the plan on disk before the first motion command, the moves,
the outcome after, whatever the ending.

Frames and units: ``T_flange_tcp`` and ``T_base_tcp_start`` are float64 4x4 in metres.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import asdict, dataclass

from handeye_pick.audit import AuditLog
from handeye_pick.cell.records import (
    audited_outcome,
    blends_record,
    steps_record,
    stretches_record,
)
from handeye_pick.cell.sequence import Executed, execute
from handeye_pick.cell.state import CellState
from handeye_pick.config.schema import CellConfig
from handeye_pick.geometry import Transform
from handeye_pick.gripper import GraspState
from handeye_pick.safety import CheckResult
from handeye_pick.steps import Step


@dataclass(frozen=True)
class Planned:
    """A sequence ready to run: its steps, the checks they all passed, and the fields of its
    plan record beyond the context, the targets and the checks."""

    steps: list[Step]
    checks: list[CheckResult]
    record: dict[str, object]
    T_base_tcp_start: Transform | None = None  # where the TCP stands as it starts (m), if known
    path_start_s: float | None = None  # the path start cost corners were weighed against (s);
    # None: every target planned as a stop (no blending, a touch test)
    written: bool = False  # its plan record is on disk already (a pick checked ahead)
    replanned: str | None = None  # why a pick checked ahead was planned again, when it was


Prepare = Callable[[Transform, dict[str, object], dict[str, object]], Planned]
"""Plans and checks a sequence, given the active TCP offset ``T_flange_tcp`` (m), the context
of its records and its outcome record (both may gain fields: the capture, refused candidates)."""

Finish = Callable[[Executed | None], dict[str, object]]
"""The outcome's ``status`` and own fields once the steps ran (None: a dry run)."""


def run_operation(
    state: CellState,
    context: dict[str, object],
    prepare: Prepare,
    finish: Finish,
    *,
    outcome_fields: dict[str, object],
    dry_run: bool = False,
    before_move: Callable[[str], None] | None = None,
    holding: GraspState | None = None,
    audit: AuditLog | None = None,
) -> str:
    """Run one motion operation of the cell; returns its pick id.

    In order: a new pick id in the audit; the halt guard; readiness (the controller, the
    session's program, the active TCP offset); ``prepare`` (plan and pre-flight, which refuse
    before anything moved); the plan record on disk; the steps (none for a dry run); the outcome
    record with ``finish``'s status. The outcome is appended whatever the ending, and a robot
    error halts the cell (``CellState.halt_on_fault``). ``context`` goes into both records;
    ``holding`` is a part already carried, watched on every move. ``audit``: the log of an
    operation whose plan record was written ahead (``cell.ahead``), else a new one.
    """
    audit = state.next_operation() if audit is None else state.made_latest(audit)
    outcome: dict[str, object] = {"event": "outcome", **context, **outcome_fields}
    state.tell_status({"pick_id": audit.pick_id, **context, **outcome_fields})
    with state.told_after(), state.halt_on_fault(), audited_outcome(audit, outcome):
        state.ensure_not_halted()
        planned = prepare(state.ready_tcp_offset(), context, outcome)
        if not planned.written:
            replanned = {"replanned": planned.replanned} if planned.replanned else {}
            audit.append(plan_entry(state.config, context, planned) | replanned)
        if state.observer is not None:
            scene = state.config.scene
            arm_checked = scene is not None and scene.arm_checked
            q_actual = state.link.arm.joint_positions() if arm_checked else None
            state.observer.on_plan(planned.steps, planned.T_base_tcp_start, q_actual)
        done = None
        if not dry_run:
            state.running_steps = planned.steps
            try:
                done = execute(
                    state.config,
                    planned.steps,
                    state.link.arm,
                    state.progress,
                    outcome,
                    before_move,
                    state.link.gripper,
                    holding,
                    state.watch,
                )
            finally:  # the next pick checked ahead has its plan record before this outcome
                state.running_steps = []
                state.record_ahead(wait=True)
        outcome.update(finish(done))
    return audit.pick_id


def plan_entry(
    config: CellConfig, context: dict[str, object], planned: Planned
) -> dict[str, object]:
    """The plan record of ``planned`` (``event: plan``) with ``context``'s fields."""
    return {
        "event": "plan",
        **context,
        **planned.record,
        "targets": steps_record(planned.steps),
        **blends_record(planned.steps),
        **stretches_record(config, planned.steps, planned.T_base_tcp_start, planned.path_start_s),
        "checks": [asdict(check) for check in planned.checks],
    }
