"""The one hook through which a session shows what it does: ``CellObserver``.

The cell, its sequence runner, its audit log and the ur_rtde arm call an observer as things
happen (a recording or a live view implements it, ``handeye_pick.record``); nothing in the cell
knows what the observer does with it. ``Contained`` wraps an observer so that it can never break
a cycle: the first exception it raises is logged as one warning line and the observer is
switched off for the rest of the session (the audit file, not an observer, is the record of
truth).

Frames and units: ``T_base_tcp`` and ``T_base_flange`` float64 4x4 in metres; UR pose vectors
(m, rad); ``controller_time_s`` the controller's RTDE ``timestamp`` (s since it started).
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Protocol

from handeye_pick.cell.captures import Capture
from handeye_pick.cell.plan import CandidateRefusal, PickPlan
from handeye_pick.geometry import Transform
from handeye_pick.steps import Step

log = logging.getLogger(__name__)


class CellObserver(Protocol):
    """What a session tells an observer; every method returns quickly (it runs inside the
    cycle, on the thread that runs it)."""

    def on_sample(self, tcp_pose: Sequence[float], controller_time_s: float) -> None:
        """An RTDE sample was read: ``actual_TCP_pose`` (UR vector, m and rad, base frame)."""
        ...

    def on_capture(self, capture: Capture) -> None:
        """A capture was latched (``T_base_flange`` None for eye-to-hand)."""
        ...

    def on_cloud(self, path: Path, capture: Capture | None) -> None:
        """The vision program named the point cloud (camera frame, mm) of ``capture``."""
        ...

    def on_candidates(
        self,
        plans: Sequence[PickPlan],
        chosen: int | None,
        refused: Sequence[CandidateRefusal],
    ) -> None:
        """Every candidate's plan (in request order, as far as planned), the index of the one
        chosen (None: none passed) and why the others were refused."""
        ...

    def on_plan(
        self,
        steps: Sequence[Step],
        T_base_tcp_start: Transform | None,
        q_actual: Sequence[float] | None = None,
    ) -> None:
        """A sequence passed its checks and is about to run from ``T_base_tcp_start`` (None:
        where the arm stands was not read), the arm's joints ``q_actual`` (rad; None: not
        read)."""
        ...

    def on_reached(self, name: str, T_target: Transform | None, T_reached: Transform) -> None:
        """A move ended at ``T_reached`` (``T_target`` None for a moveJ)."""
        ...

    def on_status(self, status: dict[str, object]) -> None:
        """The session's state changed (``state``: idle, running or halted, and why)."""
        ...

    def on_audit(self, line: str) -> None:
        """An audit record was written (the JSON line, without its newline)."""
        ...


class Contained:
    """An observer whose failures never reach the cell: the first exception is logged as one
    warning and switches the observer off for the rest of the session."""

    def __init__(self, observer: CellObserver, name: str) -> None:
        self._observer: CellObserver | None = observer
        self._name = name

    @property
    def active(self) -> bool:
        return self._observer is not None

    def call(self, method: Callable[[CellObserver], None]) -> None:
        """``method(observer)``, contained."""
        observer = self._observer
        if observer is None:
            return
        try:
            method(observer)
        except Exception as exc:  # an observer must never end a cycle
            self._observer = None
            log.warning(
                "%s stopped (the cell goes on): %s: %s", self._name, type(exc).__name__, exc
            )

    def on_sample(self, tcp_pose: Sequence[float], controller_time_s: float) -> None:
        self.call(lambda o: o.on_sample(tcp_pose, controller_time_s))

    def on_capture(self, capture: Capture) -> None:
        self.call(lambda o: o.on_capture(capture))

    def on_cloud(self, path: Path, capture: Capture | None) -> None:
        self.call(lambda o: o.on_cloud(path, capture))

    def on_candidates(
        self,
        plans: Sequence[PickPlan],
        chosen: int | None,
        refused: Sequence[CandidateRefusal],
    ) -> None:
        self.call(lambda o: o.on_candidates(plans, chosen, refused))

    def on_plan(
        self,
        steps: Sequence[Step],
        T_base_tcp_start: Transform | None,
        q_actual: Sequence[float] | None = None,
    ) -> None:
        self.call(lambda o: o.on_plan(steps, T_base_tcp_start, q_actual))

    def on_reached(self, name: str, T_target: Transform | None, T_reached: Transform) -> None:
        self.call(lambda o: o.on_reached(name, T_target, T_reached))

    def on_status(self, status: dict[str, object]) -> None:
        self.call(lambda o: o.on_status(status))

    def on_audit(self, line: str) -> None:
        self.call(lambda o: o.on_audit(line))
