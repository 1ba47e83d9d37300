"""MCAP files written through the Foxglove SDK from a logging context.

``--record FILE`` writes one file (it must not exist yet); ``--record FOLDER`` (an existing
folder, or a path ending in ``/``) gets one file per hour of wall time, and a new one whenever a
file passes ``MAX_FILE_BYTES``, each named by its start time (UTC): ``20250114T030000Z.mcap``.
Chunks are small (``CHUNK_BYTES``) and flushed at every audit record and once a second, so a
killed process leaves a file that reads back up to its last complete chunk; a clean ending
(``close``) writes the index. A file that cannot be written (a full disk, a read-only folder)
ends the recording with one warning; the cell goes on.
"""

from __future__ import annotations

import logging
import threading
import time
from collections.abc import Callable
from datetime import datetime, timezone
from pathlib import Path

import foxglove
from foxglove.mcap import MCAPCompression, MCAPWriteOptions, MCAPWriter

from handeye_pick.errors import InputError

log = logging.getLogger(__name__)

MAX_FILE_BYTES = 1 << 30
"""A folder's file is closed and a new one started past this size (1 GiB)."""
CHUNK_BYTES = 32 * 1024
"""Target uncompressed size of a chunk: what a SIGKILL can cost at most, besides a flush."""


def check_record_path(path: Path) -> None:
    """Refuse a ``--record`` path that cannot be recorded to, before the robot is contacted."""
    if is_folder(path):
        if not path.is_dir():
            raise InputError(f"--record {path}: no such folder")
        return
    if path.exists():
        raise InputError(f"--record {path}: exists already: give a new file name or a folder")
    if not path.parent.is_dir():
        raise InputError(f"--record {path}: no folder {path.parent}")


def is_folder(path: Path) -> bool:
    return path.is_dir() or str(path).endswith("/")


class _Written:
    """One file the SDK writes (it owns the file: a Python file object under the SDK would make
    its writer need the interpreter while it holds its own lock, and threads deadlock); a write
    error shows as a ``RuntimeError`` at the next flush or close."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.error: OSError | None = None

    @property
    def written(self) -> int:
        try:
            return self.path.stat().st_size
        except OSError:
            return 0


class McapFiles:
    """The recording's files for ``context``; ``on_new_file`` runs right after each file is
    opened (to write again what a viewer needs from its start: fixed frames, the scene)."""

    def __init__(
        self,
        path: Path,
        context: foxglove.Context,
        on_new_file: Callable[[], None],
        *,
        max_file_bytes: int = MAX_FILE_BYTES,
    ) -> None:
        self._path = path
        self._folder = is_folder(path)
        self._context = context
        self._on_new_file = on_new_file
        self._max_file_bytes = max_file_bytes
        self._lock = threading.RLock()
        self._file: _Written | None = None
        self._writer: MCAPWriter | None = None
        self._hour = ""
        self.paths: list[Path] = []
        self._open()

    @property
    def recording(self) -> bool:
        return self._writer is not None

    def describe(self) -> str:
        """Where the recording goes, for a person: the file written now and, for a folder, when
        the next one starts."""
        line = f"recording to {self.paths[-1]}"
        if self._folder:
            size = f"{self._max_file_bytes / (1 << 30):g} GiB"
            line += f" (a new file in {self._path} each hour and past {size})"
        return line

    def _open(self) -> None:
        now = datetime.now(timezone.utc)
        path = self._path if not self._folder else self._new_name(now)
        self._file = _Written(path)
        # Without seeking, a chunk is written whole once it is complete; with it, a chunk's
        # length is written as a placeholder first and patched at its end, so a killed process
        # would leave a chunk no reader can step over.
        options = MCAPWriteOptions(
            compression=MCAPCompression.Zstd,
            chunk_size=CHUNK_BYTES,
            compression_threads=0,
            disable_seeking=True,
        )
        try:  # check_record_path (and _new_name) made sure no file of the name exists
            self._writer = foxglove.open_mcap(
                path, allow_overwrite=True, context=self._context, writer_options=options
            )
        except RuntimeError as exc:  # the SDK's word for a file it cannot create
            raise InputError(f"--record {path}: cannot create ({exc})") from None
        self._hour = now.strftime("%Y%m%d%H")
        self.paths.append(path)
        log.info("recording to %s", path)
        self._on_new_file()

    def _new_name(self, now: datetime) -> Path:
        stem = now.strftime("%Y%m%dT%H%M%SZ")
        path, n = self._path / f"{stem}.mcap", 1
        while path.exists():
            n += 1
            path = self._path / f"{stem}-{n}.mcap"
        return path

    def check(self) -> None:
        """End the recording if a write failed (it shows at a flush)."""
        file = self._file
        if file is not None and file.error is not None:
            self.close()  # says so, once

    def flush(self) -> None:
        """Finish the current chunk and hand it to the operating system; then start the next
        file of a folder when the hour changed or the file is full."""
        with self._lock:
            if self._writer is None or self._file is None:
                return
            try:
                self._writer.flush()
            except RuntimeError as exc:  # the SDK's word for a failed write
                _note(self._file, exc)
            self.check()
            file = self._file
            if file is None or not self._folder:
                return
            hour = time.strftime("%Y%m%d%H", time.gmtime())
            if file.written >= self._max_file_bytes or hour != self._hour:
                self.close()
                self._open()

    def close(self) -> None:
        """Write the index and close the file; safe to call twice."""
        with self._lock:
            writer, file = self._writer, self._file
            self._writer = self._file = None
            if writer is None or file is None:
                return
            try:
                writer.close()
            except RuntimeError as exc:
                _note(file, exc)
            if file.error is not None:
                _warn(file.path, file.error)


def _note(file: _Written | None, exc: RuntimeError) -> None:
    """Keep the SDK's failure when the file saw none of its own."""
    if file is not None and file.error is None:
        file.error = OSError(str(exc))


def _warn(path: Path, error: OSError) -> None:
    log.warning(
        "recording stopped: cannot write %s (%s); the cell goes on, the audit file is its record",
        path,
        error.strerror or error,
    )
