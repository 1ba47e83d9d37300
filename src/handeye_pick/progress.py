"""What a person sees while a command runs: progress lines on stderr, and the logging setup.

Progress lines are for the operator (``connecting``, ``approach 40%``, ``approach done in
0.84 s``); ``--quiet`` and ``--json`` silence them. Standard ``logging`` carries the details:
warnings go to stderr unless quiet, everything down to DEBUG goes to ``--log-file``. The audit
file, not the log, is the record of picks.
"""

from __future__ import annotations

import argparse
import logging
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import TextIO

from handeye_pick.errors import InputError
from handeye_pick.robot.port import ProgressCallback

log = logging.getLogger(__name__)

PERCENT_EVERY_S = 0.25
"""Shortest time between two percentage lines of one step: a slow move shows every tenth,
a fast one only a few."""


class Progress:
    """Writes progress lines to ``stream``; ``stream=None`` is silent (quiet or --json)."""

    def __init__(self, stream: TextIO | None) -> None:
        self._stream = stream

    @classmethod
    def quiet(cls) -> Progress:
        return cls(None)

    def say(self, text: str) -> None:
        """One line for the operator (also logged at INFO)."""
        log.info("%s", text)
        if self._stream is not None:
            print(text, file=self._stream, flush=True)

    @contextmanager
    def step(self, name: str) -> Iterator[ProgressCallback]:
        """Announce a step, time it, and yield a callback that reports its fraction done.

        The callback prints ``name 40%`` on a new tenth, at most every ``PERCENT_EVERY_S``; the
        end prints ``name done in X.XX s`` or, when the block raises, ``name failed after X.XX s``.
        """
        self.say(name)
        start = time.monotonic()
        shown = {"tenths": 0, "at": start}

        def report(fraction: float) -> None:
            tenths = int(min(max(fraction, 0.0), 1.0) * 10)
            now = time.monotonic()
            if shown["tenths"] < tenths < 10 and now - shown["at"] >= PERCENT_EVERY_S:
                shown["tenths"], shown["at"] = tenths, now
                self.say(f"{name} {tenths * 10}%")

        try:
            yield report
        except BaseException:
            self.say(f"{name} failed after {time.monotonic() - start:.2f} s")
            raise
        self.say(f"{name} done in {time.monotonic() - start:.2f} s")


def add_output_args(parser: argparse.ArgumentParser, *, with_defaults: bool = True) -> None:
    """``--quiet`` and ``--log-file FILE``. Added once with defaults to the top-level parser and
    again ``with_defaults=False`` to each command, so they work before or after the command
    name (a sub-parser default would otherwise overwrite a value given before it)."""
    default_quiet: object = False if with_defaults else argparse.SUPPRESS
    default_log: object = None if with_defaults else argparse.SUPPRESS
    parser.add_argument(
        "--quiet",
        action="store_true",
        default=default_quiet,
        help="no progress lines or warnings on stderr (errors are still printed)",
    )
    parser.add_argument(
        "--log-file",
        type=Path,
        default=default_log,
        metavar="FILE",
        help="append a debug log (every step, every controller call) to FILE",
    )


def configure_logging(log_file: Path | None, *, quiet: bool) -> None:
    """Warnings to stderr unless ``quiet``; everything to ``log_file`` (appended) when given."""
    root = logging.getLogger("handeye_pick")
    root.setLevel(logging.DEBUG)
    root.propagate = False
    for handler in list(root.handlers):
        root.removeHandler(handler)
        handler.close()
    if not quiet:
        console = logging.StreamHandler(sys.stderr)
        console.setLevel(logging.WARNING)
        console.setFormatter(logging.Formatter("%(levelname)s: %(message)s"))
        root.addHandler(console)
    if log_file is not None:
        try:
            file_handler = logging.FileHandler(log_file, encoding="utf-8")
        except OSError as exc:
            raise InputError(f"--log-file: cannot open {log_file} for appending: {exc}") from None
        file_handler.setLevel(logging.DEBUG)
        file_handler.setFormatter(
            logging.Formatter("%(asctime)s %(levelname)s %(name)s: %(message)s")
        )
        root.addHandler(file_handler)
    if not root.handlers:
        root.addHandler(logging.NullHandler())
