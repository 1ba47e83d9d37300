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

import io
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


class _File(io.RawIOBase):
    """The file the SDK writes to: counts the bytes and remembers the first write error."""

    def __init__(self, path: Path) -> None:
        super().__init__()
        self.path = path
        self._file = path.open("xb")
        self.written = 0
        self.error: OSError | None = None

    def writable(self) -> bool:
        return True

    def seekable(self) -> bool:
        return True

    def write(self, data: bytes | bytearray | memoryview) -> int:  # type: ignore[override]
        try:
            n = self._file.write(data)
        except OSError as exc:
            self.error = self.error or exc
            raise
        self.written += n
        return n

    def seek(self, offset: int, whence: int = io.SEEK_SET) -> int:
        return self._file.seek(offset, whence)

    def tell(self) -> int:
        return self._file.tell()

    def flush(self) -> None:
        try:
            self._file.flush()
        except OSError as exc:
            self.error = self.error or exc
            raise

    def close(self) -> None:
        if self.closed:
            return
        try:
            super().close()  # flushes first
            self._file.close()
        except OSError as exc:
            self.error = self.error or exc
            self._file.close()


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
        self._file: _File | None = None
        self._writer: MCAPWriter | None = None
        self._hour = ""
        self.paths: list[Path] = []
        self._open()

    @property
    def recording(self) -> bool:
        return self._writer is not None

    def _open(self) -> None:
        now = datetime.now(timezone.utc)
        path = self._path if not self._folder else self._new_name(now)
        try:
            self._file = _File(path)
        except OSError as exc:
            raise InputError(f"--record {path}: cannot create ({exc.strerror or exc})") from None
        # Without seeking, a chunk is written whole once it is complete; with it, a chunk's
        # length is written as a placeholder first and patched at its end, so a killed process
        # would leave a chunk no reader can step over.
        options = MCAPWriteOptions(
            compression=MCAPCompression.Zstd,
            chunk_size=CHUNK_BYTES,
            compression_threads=0,
            disable_seeking=True,
        )
        self._writer = foxglove.open_mcap(self._file, context=self._context, writer_options=options)
        self._hour = now.strftime("%Y%m%d%H")
        self.paths.append(path)
        self._on_new_file()

    def _new_name(self, now: datetime) -> Path:
        stem = now.strftime("%Y%m%dT%H%M%SZ")
        path, n = self._path / f"{stem}.mcap", 1
        while path.exists():
            n += 1
            path = self._path / f"{stem}-{n}.mcap"
        return path

    def check(self) -> None:
        """After a write: end the recording on a write error, start the next file of a folder
        when the hour changed or the file is full."""
        file = self._file
        if file is None:
            return
        if file.error is not None:
            self.close()  # says so, once
            return
        if not self._folder:
            return
        full = file.written >= self._max_file_bytes
        if full or time.strftime("%Y%m%d%H", time.gmtime()) != self._hour:
            with self._lock:
                if self._file is file:
                    self.close()
                    self._open()

    def flush(self) -> None:
        """Finish the current chunk and hand it to the operating system."""
        with self._lock:
            if self._writer is None:
                return
            try:
                self._writer.flush()
            except RuntimeError as exc:  # the SDK's word for a failed write
                _note(self._file, exc)
            self.check()

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
            file.close()
            if file.error is not None:
                _warn(file.path, file.error)


def _note(file: _File | None, exc: RuntimeError) -> None:
    """Keep the SDK's failure when the file saw none of its own."""
    if file is not None and file.error is None:
        file.error = OSError(str(exc))


def _warn(path: Path, error: OSError) -> None:
    log.warning(
        "recording stopped: cannot write %s (%s); the cell goes on, the audit file is its record",
        path,
        error.strerror or error,
    )
