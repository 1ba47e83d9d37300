"""Append-only records of dicts: the command record (what the robot was told: one dict per
motion, stop or payload command the script ran) and the motion record (one dict per motion once
it ended); README.md gives both formats. With a path, each entry is also appended to it as one
JSON line, flushed at once. A file that cannot be written (a full disk) ends with one error line
in the log; the record goes on in memory.
"""

from __future__ import annotations

import contextlib
import json
import logging
import threading
from pathlib import Path
from typing import Any, TextIO

log = logging.getLogger("mocks.ur_controller")


class CommandRecord:
    """Thread-safe, append-only list of dicts, mirrored to a JSON-lines file if given."""

    def __init__(self, path: str | Path | None = None):
        self._entries: list[dict[str, Any]] = []
        self._lock = threading.Lock()
        self._file: TextIO | None = None
        if path is not None:
            self._file = Path(path).open("a", encoding="utf-8")  # noqa: SIM115 (closed in close())

    def add(self, entry: dict[str, Any]) -> None:
        with self._lock:
            self._entries.append(entry)
            if self._file is not None:
                try:
                    self._file.write(json.dumps(entry) + "\n")
                    self._file.flush()
                except OSError as exc:
                    log.error("record file %s: cannot write (%s): it ends here; the controller "
                              "goes on", self._file.name, exc.strerror or exc)
                    self._close_file()

    def entries(self) -> list[dict[str, Any]]:
        """A copy of every entry so far, in order."""
        with self._lock:
            return [dict(entry) for entry in self._entries]

    def close(self) -> None:
        with self._lock:
            self._close_file()

    def _close_file(self) -> None:
        file, self._file = self._file, None
        if file is not None:
            with contextlib.suppress(OSError):  # what could not be written is said already
                file.close()
