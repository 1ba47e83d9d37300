"""Ctrl-C must not split a message to the ur_rtde process: it is held, then delivered."""

from __future__ import annotations

import os
import signal

import pytest

from handeye_pick.robot.ur.child import _ctrl_c_held


def _message_with_ctrl_c(steps: list[str]) -> None:
    with _ctrl_c_held():
        os.kill(os.getpid(), signal.SIGINT)
        steps.append("rest of the message written")


def test_ctrl_c_inside_is_delivered_after_the_message_not_during_it() -> None:
    steps: list[str] = []
    with pytest.raises(KeyboardInterrupt):
        _message_with_ctrl_c(steps)
    assert steps == ["rest of the message written"]
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler


def test_no_ctrl_c_means_no_interrupt_and_the_handler_is_restored() -> None:
    with _ctrl_c_held():
        pass
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
