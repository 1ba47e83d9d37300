"""The next pick checked while the arm still moves (docs/motion.md, "The next pick checked
under motion").

A pick request waiting behind a running place is planned and checked on a second thread while
the place moves, from the pose the place ends at. ur_rtde's control script answers the
controller's verdicts (IK, safety limits) while an asynchronous move runs, and the session's
pipe to its ur_rtde process serialises those calls with the watch of the move. The thread only
plans: the audit record, the observer and every sample read stay on the session's thread.

Before the pick's first motion the session confirms the arm stands where the plan started
(``start_problem``); anything else and the pick is planned again from where the arm stands.

Frames and units: ``T_base_tcp`` float64 4x4 in metres in the robot base frame, joints rad.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from handeye_pick.audit import AuditError, AuditLog
from handeye_pick.cell.captures import Capture
from handeye_pick.cell.plan import CandidateRefusal, Chosen, PickPlan
from handeye_pick.detection import Detection
from handeye_pick.geometry import Transform, rotation_angle_between

START_TOLERANCE_M = 0.001
"""How far (m) the TCP may stand from where a pick checked ahead starts: 1 mm."""
START_TOLERANCE_RAD = math.radians(0.1)
"""How far the tool may be turned from it, and each joint from the joints it was checked with:
0.1 deg."""


@dataclass(frozen=True)
class AheadRequest:
    """A pick request waiting behind the running one, as the session would run it; ``key`` is
    what the request is known by when its turn comes (its request line)."""

    key: str
    detections: tuple[Detection, ...]
    capture: Capture | None
    place: bool
    request_id: str | None


@dataclass(frozen=True)
class AheadStart:
    """What a pick checked ahead assumed: the TCP where the running sequence ends
    (``T_base_tcp``, m), the joints there (rad; None when no check needs them), the active TCP
    offset ``T_flange_tcp`` (m) and the place pose it took (``T_base_tcp``, m; None: no place)."""

    T_base_tcp: Transform
    q_rad: tuple[float, ...] | None
    T_flange_tcp: Transform
    T_base_tcp_place: Transform | None


Checked = tuple[Chosen, list[CandidateRefusal], list[PickPlan]]
"""The candidate chosen, the refusals before it and every candidate's plan."""

Plan = Callable[[], tuple[Checked, dict[str, object]]]
"""Plans and checks a pick ahead: what it chose and its plan record."""


def start_problem(
    start: AheadStart, T_base_tcp: Transform, q_rad: Sequence[float]
) -> str | None:
    """Why the arm (TCP at ``T_base_tcp``, m; joints ``q_rad``) is not where a pick checked
    ahead starts, or None: the TCP within ``START_TOLERANCE_M`` and ``START_TOLERANCE_RAD``,
    and every joint within ``START_TOLERANCE_RAD`` when the check knew its joints."""
    off_m = float(np.linalg.norm(T_base_tcp[:3, 3] - start.T_base_tcp[:3, 3]))
    off_rad = rotation_angle_between(T_base_tcp[:3, :3], start.T_base_tcp[:3, :3])
    if off_m > START_TOLERANCE_M or off_rad > START_TOLERANCE_RAD:
        return (
            f"the arm stands {off_m * 1000:.2f} mm and {math.degrees(off_rad):.2f} deg from where "
            f"the pick was checked to start (tolerance {START_TOLERANCE_M * 1000:g} mm, "
            f"{math.degrees(START_TOLERANCE_RAD):g} deg)"
        )
    if start.q_rad is not None:
        gap = max(abs(a - b) for a, b in zip(q_rad, start.q_rad, strict=True))
        if gap > START_TOLERANCE_RAD:
            return (
                f"a joint stands {math.degrees(gap):.2f} deg from the joints the pick was checked "
                f"with (tolerance {math.degrees(START_TOLERANCE_RAD):g} deg)"
            )
    return None


class Ahead:
    """One pick checked ahead: its request, what it assumed, the capture and cycle it took, and
    once its thread ended the plan it made (``checked``, and ``entry`` its plan record) or why
    it has none (``failed``). ``audit`` is the log its plan record went to, once written."""

    def __init__(
        self,
        request: AheadRequest,
        start: AheadStart,
        capture: Capture,
        cycle: int,
        path_start_s: float,
        plan: Plan,
    ) -> None:
        self.request = request
        self.start = start
        self.capture = capture
        self.cycle = cycle
        self.path_start_s = path_start_s
        self.checked: Checked | None = None
        self.entry: dict[str, object] | None = None
        self.failed: str | None = None
        self.audit: AuditLog | None = None
        self._plan = plan
        self._thread = threading.Thread(target=self._run, name="check-ahead", daemon=True)
        self._thread.start()

    def _run(self) -> None:
        try:
            self.checked, self.entry = self._plan()
        except Exception as exc:  # a refusal, a lost link: the pick is planned again in turn
            self.failed = f"{type(exc).__name__}: {exc}"

    def done(self) -> bool:
        """Whether the thread has ended."""
        return not self._thread.is_alive()

    def wait(self) -> None:
        """Until the thread has ended (every controller call it makes is bounded)."""
        self._thread.join()

    def record(self, next_audit: Callable[[], AuditLog], wait: bool) -> None:
        """Once the check is done (``wait``: wait for it), its plan record into a new
        operation's log from ``next_audit``; an audit that fails leaves the pick to be planned
        in its turn (where the audit fails again, as its own refusal). Never raises."""
        if self.audit is not None or (not wait and not self.done()):
            return
        self.wait()
        if self.entry is None:
            return
        try:
            audit = next_audit()
            audit.append(self.entry)
        except AuditError as exc:
            self.failed = f"{type(exc).__name__}: {exc}"
            return
        self.audit = audit
