"""The line state of one ``run``: one fact in one place, read and commanded through every door.

The state is derived, never copied: ``NotAvailable`` while the robot session is closed (a lost
link), ``OutOfService`` while the cell is halted (``Cell.halted``: a fault or a stop, until a
resume), ``Executing`` while a motion request runs (``Runner.running``), ``NotExecuting``
otherwise (OPC 40001-1 ``MachineryItemState``). ``held`` is the one fact this module owns: a
cycle stop in force; the running request finishes, later motion requests are answered ``held``.

Commands come from the vision program's requests, the OPC UA server and the wired inputs, each
with who gave it, and each is audited as a ``line`` record (docs/line.md):

- ``cycle_stop``: hold after the running request; ``release``: end the hold;
- ``stop``: exactly the ``stop`` request (brake now, the request ends ``stopped``, the cell
  halts);
- ``resume``: exactly the ``resume`` request; it needs the thread that runs the cell, so the
  other doors hand it over (``run_pending``, called by that thread between requests) and wait.

A hold or a halt from any door holds or halts for every door; nothing recovers by itself.
"""

from __future__ import annotations

import enum
import logging
import queue
import threading
import time
from concurrent.futures import Future
from concurrent.futures import TimeoutError as FutureTimeout
from dataclasses import dataclass

from handeye_pick.audit import AuditLog
from handeye_pick.cell.session import Cell
from handeye_pick.errors import HandEyePickError, Status
from handeye_pick.line.counters import AuditCounters, Counters
from handeye_pick.runner import Runner

log = logging.getLogger(__name__)

RESUME_WAIT_S = 60.0
"""How long a door waits for the cell's thread to take and finish a resume it handed over."""


class ItemState(enum.IntEnum):
    """OPC 40001-1 ``MachineryItemState`` (the numbers are this package's, docs/line.md)."""

    NOT_AVAILABLE = 0
    OUT_OF_SERVICE = 1
    NOT_EXECUTING = 2
    EXECUTING = 3

    @property
    def title(self) -> str:
        """The state's name as OPC 40001-1 writes it: ``NotExecuting``."""
        return "".join(word.capitalize() for word in self.name.split("_"))


class OperationMode(enum.IntEnum):
    """OPC 40001-1 ``MachineryOperationMode``; ``run`` serves production: ``Processing``."""

    NONE = 0
    MAINTENANCE = 1
    SETUP = 2
    PROCESSING = 3

    @property
    def title(self) -> str:
        return self.name.capitalize()


@dataclass(frozen=True)
class CommandResult:
    """What a line command did: ``ok`` and one line saying what or why not."""

    ok: bool
    text: str


@dataclass(frozen=True)
class LineView:
    """The line state at one instant, for a panel, a PLC or a reply."""

    state: ItemState
    held: bool
    held_by: str | None  # who gave the cycle stop in force
    halted_reason: str | None
    mode: OperationMode
    request: dict[str, object] | None  # the running request: id, op, step
    heartbeat_s: int  # whole seconds since run started: a client sees the cell is alive

    @property
    def ready(self) -> bool:
        """No motion runs and one may start: connected, not halted, not held."""
        return self.state is ItemState.NOT_EXECUTING and not self.held


class Line:
    """The line state of ``cell`` served by ``runner``; the doors share this one object."""

    def __init__(self, cell: Cell, runner: Runner, counters: AuditCounters) -> None:
        self.cell = cell
        self.runner = runner
        self.counters = counters
        self.mode = OperationMode.PROCESSING
        self._started = time.monotonic()
        self._held_by: str | None = None
        self._lock = threading.Lock()
        self._resumes: queue.Queue[tuple[str, Future[CommandResult]]] = queue.Queue(maxsize=4)
        self._held_since: float | None = None
        self._held_s = 0.0

    # --- facts -----------------------------------------------------------------------------

    def held(self) -> str | None:
        """Who gave the cycle stop in force, or None: the runner's door (``runner.LineDoor``)."""
        return self._held_by

    def view(self) -> LineView:
        """The state now (reads no controller)."""
        running = self.runner.running
        if not self.cell.connected:
            state = ItemState.NOT_AVAILABLE
        elif self.cell.halted is not None:
            state = ItemState.OUT_OF_SERVICE
        elif running is not None and running.get("op") != "resume":
            state = ItemState.EXECUTING
        else:
            state = ItemState.NOT_EXECUTING
        return LineView(
            state=state,
            held=self._held_by is not None,
            held_by=self._held_by,
            halted_reason=self.cell.halted,
            mode=self.mode,
            request=running,
            heartbeat_s=int(time.monotonic() - self._started),
        )

    def held_s(self) -> float:
        """Seconds the cell was held since run started (the line's own count: the report
        does not know holds)."""
        with self._lock:
            since = self._held_since
            return self._held_s + (time.monotonic() - since if since is not None else 0.0)

    def counts(self) -> Counters:
        """The counters since run started (``line.counters``)."""
        return self.counters.snapshot()

    def status_fields(self) -> dict[str, object]:
        """What a ``status`` reply adds: the line state and the hold (``runner.LineDoor``)."""
        view = self.view()
        return {"held": view.held, "held_by": view.held_by, "line_state": view.state.title}

    # --- commands (any thread) -----------------------------------------------------------------

    def command(self, name: str, by: str) -> dict[str, object]:
        """A command from the vision program's requests (``runner.LineDoor``): reply fields."""
        result = self.cycle_stop(by) if name == "cycle-stop" else self.release(by)
        held = self._held_by is not None
        return {"ok": result.ok, "status": Status.HELD if held else Status.READY,
                "held": held, "message": result.text}

    def cycle_stop(self, by: str) -> CommandResult:
        """Hold after the running request: later motion requests are answered ``held``."""
        with self._lock:
            already = self._held_by
            if already is None:
                self._held_by = by
                self._held_since = time.monotonic()
        if already is not None:
            result = CommandResult(True, f"held already by {already}")
            return self._audited("cycle-stop", by, result)
        running = self.runner.running
        text = (f"holding after request {running.get('id')} ({running.get('op')})"
                if running is not None else "held: no request runs")
        return self._audited("cycle-stop", by, CommandResult(True, text))

    def release(self, by: str) -> CommandResult:
        """End the hold: motion requests run again."""
        with self._lock:
            was = self._held_by
            self._held_by = None
            if self._held_since is not None:
                self._held_s += time.monotonic() - self._held_since
                self._held_since = None
        text = "released: not held" if was is None else f"released (held by {was})"
        return self._audited("release", by, CommandResult(True, text))

    def stop(self, by: str) -> CommandResult:
        """An immediate stop: exactly the ``stop`` request (brake, halt until resume)."""
        running = self.runner.running
        during = (f" while request {running.get('id')} ran {running.get('op')}"
                  if running is not None else "")
        self.cell.request_stop(f"stopped by {by}{during}")
        return self._audited("stop", by, CommandResult(True, f"stopped{during}"))

    def noted_stop(self, by: str) -> None:
        """A ``stop`` request the runner gave the cell itself: audited here with who gave it."""
        self._audited("stop", by, CommandResult(True, "stopped"))

    def resume(self, by: str, wait_s: float = RESUME_WAIT_S) -> CommandResult:
        """Exactly the ``resume`` request, run by the cell's thread; waits up to ``wait_s``
        for it (0: hand it over and return at once)."""
        future: Future[CommandResult] = Future()
        try:
            self._resumes.put_nowait((by, future))
        except queue.Full:
            return CommandResult(False, "resumes are waiting already: this one was not taken")
        if wait_s <= 0:
            return CommandResult(True, "handed to the cell")
        try:
            return future.result(timeout=wait_s)
        except FutureTimeout:
            return CommandResult(False, f"the cell did not finish the resume within {wait_s:g} s")

    def run_pending(self) -> None:
        """The cell's thread, between requests: run the resumes other doors handed over."""
        while True:
            try:
                by, future = self._resumes.get_nowait()
            except queue.Empty:
                return
            future.set_result(self._resume_now(by))

    def _resume_now(self, by: str) -> CommandResult:
        try:
            self.cell.resume()
        except HandEyePickError as exc:  # not ready, no link, an audit file gone: said, not raised
            result = CommandResult(False, str(exc))
        else:
            result = CommandResult(True, "resumed: the cell is ready")
        return self._audited("resume", by, result)

    def _audited(self, command: str, by: str, result: CommandResult) -> CommandResult:
        """Append the command's ``line`` record; a failed write is logged, never raised (the
        command took effect: a stop must never be undone by a full disk)."""
        record: dict[str, object] = {
            "event": "line",
            "command": command,
            "by": by,
            "ok": result.ok,
            "message": result.text,
            "held": self._held_by is not None,
            "halted": self.cell.halted,
        }
        try:
            AuditLog(self.counters.path).append(record)
        except HandEyePickError as exc:
            log.warning("line %s by %s: %s", command, by, exc)
        log.info("line %s by %s: %s", command, by, result.text)
        return result
