"""Controller time mapped to wall time, for the stamps of a recording.

An RTDE sample carries the controller's ``timestamp`` (s since the controller started). Its
wall time is ``controller_time_s + offset``; the offset is the smallest ``wall - controller``
seen, since the sample read with the least delay after the controller wrote it gives the
closest bound. The two clocks drift apart (crystals, NTP steps on the PC): the offset may grow
by ``DRIFT_S_PER_S`` per second of wall time, so a later, larger true offset is followed; a
smaller one is taken at once. A controller that restarts (its time goes back) starts afresh.
"""

from __future__ import annotations

import threading
import time

DRIFT_S_PER_S = 1e-4
"""How fast the offset may grow (100 ppm: well above a crystal's drift)."""


class ControllerClock:
    """Maps controller time (s) to wall time (ns since the Unix epoch); thread-safe."""

    def __init__(self) -> None:
        self._offset_s: float | None = None
        self._seen_wall_s = 0.0  # when the offset was last set
        self._last_controller_s = 0.0
        self._lock = threading.Lock()

    def wall_ns(self, controller_time_s: float, read_wall_s: float | None = None) -> int:
        """The wall time of a sample stamped ``controller_time_s`` that was read at
        ``read_wall_s`` (default now); the offset is brought up to date with it."""
        wall_s = time.time() if read_wall_s is None else read_wall_s
        with self._lock:
            seen = wall_s - controller_time_s
            if self._offset_s is None or controller_time_s < self._last_controller_s:
                self._offset_s = seen
            else:
                allowed = self._offset_s + DRIFT_S_PER_S * (wall_s - self._seen_wall_s)
                self._offset_s = min(seen, allowed)
            self._seen_wall_s = wall_s
            self._last_controller_s = controller_time_s
            return int((controller_time_s + self._offset_s) * 1e9)
