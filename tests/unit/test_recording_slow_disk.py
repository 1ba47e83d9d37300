"""A recording never holds the cycle: when its disk stalls, the cell's calls to the recording
return at once; once ``WORK_QUEUE`` messages wait, the ones after them are dropped, with one
warning (record/publisher.py, docs/recording.md "Files").

The disk that stalls: the recording's real MCAP files (``recorder.McapFiles``, the Foxglove SDK
writing a real file) whose chunk flush waits until the test lets the disk go on, so the writer
thread stands still in the middle of a write, as behind a slow disk."""

from __future__ import annotations

import logging
import threading
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader

from handeye_pick.config.hand_eye import calibration_from_config
from handeye_pick.config.load import load_config
from handeye_pick.geometry import ur_pose_list
from handeye_pick.record import publisher
from handeye_pick.record.recorder import McapFiles
from tests.integration.test_pick_cli import write_config

CALLS = publisher.WORK_QUEUE + 5000  # the cell's samples while the disk stands still
HELD_S = 60.0  # far longer than the calls take: a cycle that waits for the disk never ends


class _StalledDisk(McapFiles):
    """The recording's files, whose every chunk flush waits until ``going`` is set."""

    going = threading.Event()
    stalled = threading.Event()  # a flush is waiting

    def flush(self) -> None:
        self.stalled.set()
        self.going.wait()
        super().flush()


def test_a_stalled_disk_drops_messages_past_the_queue_with_one_warning_and_holds_no_call(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    monkeypatch.setattr(publisher, "McapFiles", _StalledDisk)
    _StalledDisk.going.clear()
    _StalledDisk.stalled.clear()
    config = load_config(write_config(tmp_path, "127.0.0.2"))
    record = tmp_path / "slow.mcap"
    recording = publisher.Publisher(config, calibration_from_config(config), record=record)
    pose = ur_pose_list(np.eye(4))

    def cycle() -> None:
        recording.on_audit('{"event": "plan"}')  # its chunk's flush is where the disk stalls
        for i in range(CALLS):  # a moving arm: every sample a new pose, 20 ms apart
            recording.on_sample([0.001 * i, *pose[1:]], 0.02 * i)

    with caplog.at_level(logging.WARNING):
        cell = threading.Thread(target=cycle)
        cell.start()
        cell.join(HELD_S)
        held = cell.is_alive()
        assert _StalledDisk.stalled.is_set()  # the writer did stand still
        _StalledDisk.going.set()  # the disk goes on (and a held cycle can end)
        cell.join()
        recording.close()
    assert not held, "the cell's calls waited for the stalled disk"
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert warnings == [f"recording: {publisher.WORK_QUEUE} messages wait: later ones are dropped"]
    with record.open("rb") as file:
        topics = [channel.topic for _, channel, _ in make_reader(file).iter_messages()]
    assert topics.count("/cell/audit") == 1
    # What waited was written once the disk went on; what came past the queue was not.
    assert 0 < topics.count("/tf") <= publisher.WORK_QUEUE + 10 < CALLS
