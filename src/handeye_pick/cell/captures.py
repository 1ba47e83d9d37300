"""Latched captures: the flange pose at image acquisition, numbered and kept for the picks that
name them.

Frames and units: ``T_base_flange`` is a float64 4x4 in metres in the robot base frame, None for
eye-to-hand (the camera does not move with the arm).
"""

from __future__ import annotations

import itertools
from collections import OrderedDict
from dataclasses import dataclass
from datetime import datetime, timezone

from handeye_pick.errors import InputError
from handeye_pick.geometry import Transform, ur_pose_list

MAX_CAPTURES_KEPT = 64
"""Latched captures a session remembers (oldest forgotten first): a pick names a recent one."""


@dataclass(frozen=True)
class Capture:
    """A latched capture: the flange pose at image acquisition, carried with its detections.

    ``T_base_flange`` (m) is None for eye-to-hand (the camera does not move with the arm).
    ``source`` says where the pose came from: ``latched`` (read steady at capture), ``live``
    (read steady right before a one-shot pick), or a file/flag name.
    """

    capture_id: str
    T_base_flange: Transform | None
    source: str
    timestamp: datetime
    cycle: int

    def record(self, request_id: str | None) -> dict[str, object]:
        """The audit record of this capture."""
        record: dict[str, object] = {
            "event": "capture",
            "cycle": self.cycle,
            "capture_id": self.capture_id,
            "flange_pose_source": self.source,
            "flange_pose": (
                ur_pose_list(self.T_base_flange) if self.T_base_flange is not None else None
            ),
        }
        if request_id is not None:
            record["request_id"] = request_id
        return record


class CaptureBook:
    """A session's captures by id (``c1``, ``c2``, ...), the last ``MAX_CAPTURES_KEPT`` kept."""

    def __init__(self) -> None:
        self._captures: OrderedDict[str, Capture] = OrderedDict()
        self._numbers = itertools.count(1)

    def register(self, T_base_flange: Transform | None, source: str, cycle: int) -> Capture:
        """A new capture of the flange pose ``T_base_flange`` (m) in ``cycle``, taken now."""
        capture = Capture(
            capture_id=f"c{next(self._numbers)}",
            T_base_flange=T_base_flange,
            source=source,
            timestamp=datetime.now(timezone.utc),
            cycle=cycle,
        )
        self._captures[capture.capture_id] = capture
        while len(self._captures) > MAX_CAPTURES_KEPT:
            self._captures.popitem(last=False)
        return capture

    def find(self, capture_id: str) -> Capture:
        """A capture by id; InputError when unknown or forgotten."""
        try:
            return self._captures[capture_id]
        except KeyError:
            raise InputError(
                f"unknown capture_id {capture_id!r}: capture first (this session keeps the "
                f"last {MAX_CAPTURES_KEPT})"
            ) from None
