"""What starting a blended path costs on the connected controller: a running figure.

ur_rtde sends a path by stopping its control script, uploading all of it again with the path in
it and waiting until the controller runs it (docs/ur-rtde.md, "Blended paths"); a single moveL
goes through the running script's registers. The start cost is the difference: how much longer
the call that sends a path takes than the call that sends a single move. It is measured once
without motion (``URRtdeArm.measure_path_start``: the script stopped, uploaded again and waited
for), then on every path the session sends, each new figure weighed in with ``SMOOTHING``.

Units: seconds of wall-clock time on this machine.
"""

from __future__ import annotations

SMOOTHING = 0.3
"""The weight of the newest measurement in the running figures (the rest is their past)."""


def _weighed(past: float | None, new: float) -> float:
    return new if past is None else (1.0 - SMOOTHING) * past + SMOOTHING * new


class PathStartCost:
    """The running figures of one session: a single move's call, and a path's start beyond it."""

    def __init__(self) -> None:
        self._single_call_s: float | None = None
        self._start_s: float | None = None

    @property
    def seconds(self) -> float | None:
        """The path start cost (s); None before any path or measurement."""
        return self._start_s

    def restarted(self, seconds: float) -> None:
        """A program stop, upload and start took ``seconds`` (a measurement without motion)."""
        self._start_s = _weighed(self._start_s, max(0.0, seconds))

    def single_sent(self, seconds: float) -> None:
        """Sending a single moveL or moveJ took ``seconds`` (its call, start to answer)."""
        self._single_call_s = _weighed(self._single_call_s, seconds)

    def path_sent(self, seconds: float) -> None:
        """Sending a path took ``seconds`` (its call, start to answer)."""
        self.restarted(seconds - (self._single_call_s or 0.0))
