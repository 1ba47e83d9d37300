"""The CLI entry point: every ending has a defined exit status and a one-line message."""

from __future__ import annotations

import argparse

import pytest

from handeye_pick import cli
from handeye_pick.errors import CalibrationError, RobotFault, SafetyRefusal


def _parser_running(failure: BaseException) -> argparse.ArgumentParser:
    """A top-level parser whose one command, ``point`` (without ``--json``), raises
    ``failure``."""

    def run(_args: argparse.Namespace) -> int:
        raise failure

    parser = argparse.ArgumentParser()
    parser.set_defaults(run=run, log_file=None, quiet=True)
    parser.commands = {"point": parser}  # type: ignore[attr-defined]
    return parser


@pytest.mark.parametrize(
    ("failure", "status", "first_words"),
    [
        (CalibrationError("hand_eye.yaml: bad"), 2, "error: hand_eye.yaml: bad"),
        (SafetyRefusal("grasp outside the box"), 3, "error: grasp outside the box"),
        (RobotFault("protective stop"), 4, "error: protective stop"),
        (KeyboardInterrupt(), 130, "interrupted"),
        (ZeroDivisionError("division by zero"), 1, "internal error: ZeroDivisionError"),
    ],
)
def test_each_failure_kind_has_its_status_and_one_line(
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    failure: BaseException,
    status: int,
    first_words: str,
) -> None:
    monkeypatch.setattr(cli, "build_parser", lambda argv: ("point", _parser_running(failure)))
    assert cli.main([]) == status
    err = capsys.readouterr().err
    assert err.startswith(first_words)
    assert len(err.strip().splitlines()) == 1
    assert "Traceback" not in err
