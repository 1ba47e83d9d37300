"""`run` says where its audit records go, and `run --record` / `pick --record` which file they
record to (a folder's file is named by its start time, so only the command can say it), against
the simulated controller through the real ur_rtde client."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from mocks.ur_controller import SimulatedController
from tests.integration.test_pick_cli import DEMO, TCP_OFFSET, run_pick, write_config
from tests.integration.test_run_loop import loop, loop_config

SimFactory = Callable[..., SimulatedController]


def test_run_says_its_audit_file_and_the_file_a_record_folder_gets(
    sim_controller: SimFactory, tmp_path: Path
) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    folder = tmp_path / "recordings"
    folder.mkdir()
    with loop(loop_config(tmp_path, ctl.host), "--record", str(folder)) as run:
        assert run.close() == 0
        lines = run.stderr().splitlines()
    [written] = folder.glob("*.mcap")
    assert f"audit records go to {tmp_path / 'picks.jsonl'}" in lines
    assert (f"recording to {written} (a new file in {folder} each hour and past 1 GiB)"
            in lines)


def test_pick_says_the_file_it_records_to(sim_controller: SimFactory, tmp_path: Path) -> None:
    ctl = sim_controller(tcp_offset=TCP_OFFSET, instant=True)
    record = tmp_path / "pick.mcap"
    done = run_pick(write_config(tmp_path, ctl.host), "--detection",
                    str(DEMO / "detection.yaml"), "--dry-run", "--record", str(record))
    assert done.returncode == 0, done.stderr
    assert f"recording to {record}" in done.stderr.splitlines()
    assert record.is_file()
