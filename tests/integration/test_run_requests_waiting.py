"""The ``run`` request loop's line of waiting requests (cli/run.py, docs/requests.md), against
the simulated controller through the real ur_rtde: ``status`` is answered at once while
requests wait, even when none runs yet; and at most ``MAX_WAITING`` wait behind the running
request: each one past that is answered at once with a bad-request reply and never runs.

The first test drives the loop in-process (its reading side first, then its running side), the
only way to hold the moment between two queued requests when none has started; the second runs
``handeye-pick run`` as a client sees it."""

from __future__ import annotations

import io
import json
from pathlib import Path
from typing import Any

from handeye_pick.cell.session import Cell
from handeye_pick.cli.run import MAX_WAITING, _Loop
from handeye_pick.runner import Runner
from tests.integration.test_pick_cli import TCP_OFFSET, motion_commands
from tests.integration.test_run_loop import SimFactory, loop, loop_config
from tests.integration.test_run_while_moving import lines_until_reply, next_event


def _line(request: dict[str, Any]) -> bytes:
    return json.dumps(request).encode() + b"\n"


def _replies(out: io.StringIO) -> list[dict[str, Any]]:
    return [json.loads(line) for line in out.getvalue().splitlines()]


def test_status_is_answered_at_once_between_two_queued_requests_before_either_runs(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    """Two moves queued with a ``status`` between them, none started: the status is answered
    by the reading side at once (``busy``, no request running), before either move runs; the
    moves then run in order."""
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    out = io.StringIO()
    with Cell(loop_config(tmp_path, ctl.host)) as cell:
        requests = _Loop(Runner(cell), out)
        requests.read(
            iter(
                [
                    _line({"id": "m1", "op": "move", "pose": "home"}),
                    _line({"id": "s", "op": "status"}),
                    _line({"id": "m2", "op": "move", "pose": "aside"}),
                ]
            )
        )
        assert _replies(out) == [
            {
                "id": "s",
                "ok": True,
                "status": "busy",
                "request": None,
                "halted": False,
                "halted_reason": None,
            }
        ]
        assert motion_commands(ctl) == []  # answered before any request ran
        requests.run()  # the running side: the two moves, in order
    replies = _replies(out)
    assert [(r["id"], r["status"]) for r in replies] == [
        ("s", "busy"),
        ("m1", "moved"),
        ("m2", "moved"),
    ]


def test_requests_past_the_bound_are_refused_at_once_and_the_waiting_ones_run(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    """While a move runs, a client sends ``MAX_WAITING`` + 2 more: the two past the bound are
    each answered with a bad-request reply before the running move ends, and never run; the
    ``MAX_WAITING`` that wait run in order after it."""
    ctl = sim_controller(tcp_offset=TCP_OFFSET)  # real-time motion: the move takes a while
    with loop(loop_config(tmp_path, ctl.host)) as run:
        assert run.ask({"id": "h", "op": "move", "pose": "home"})["ok"]
        commands_before = len(motion_commands(ctl))
        run.send(json.dumps({"id": "a", "op": "move", "pose": "aside", "events": True}))
        next_event(run, "step")  # the move to aside is under way
        sent = [f"w{i}" for i in range(MAX_WAITING + 2)]
        for request_id in sent:
            run.send(json.dumps({"id": request_id, "op": "move", "pose": "home"}))
        running, before = lines_until_reply(run, "a")
        assert running["status"] == "moved", running
        refused = [line for line in before if "ok" in line]
        assert [r["id"] for r in refused] == sent[MAX_WAITING:]
        for reply in refused:
            assert (reply["ok"], reply["status"]) == (False, "bad-request"), reply
            assert reply["error"] == (
                f"{MAX_WAITING} requests are waiting already: this one was not queued, not run"
            )
        for request_id in sent[:MAX_WAITING]:
            reply, between = lines_until_reply(run, request_id)
            assert (reply["ok"], reply["status"]) == (True, "moved"), reply
            assert not [line for line in between if "ok" in line]
        assert run.ask({"id": "q", "op": "quit"})["status"] == "bye"
        assert run.close() == 0
    # The move to aside, then one move home per waiting request: none for the refused two.
    assert len(motion_commands(ctl)) == commands_before + 1 + MAX_WAITING
