"""A recording whose disk is full: one warning, the recording ends, the caller goes on.

The write failure is real: the recording is written to /dev/full, which answers every write
with ENOSPC, by the Foxglove SDK's own MCAP writer."""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import pytest

from handeye_pick.config.hand_eye import calibration_from_config
from handeye_pick.config.load import load_config
from handeye_pick.geometry import ur_pose_list
from handeye_pick.record.publisher import Publisher
from tests.integration.test_pick_cli import write_config


def test_a_full_disk_ends_the_recording_with_one_warning(
    tmp_path: Path, caplog: pytest.LogCaptureFixture
) -> None:
    config = load_config(write_config(tmp_path, "127.0.0.2"))
    full = Path("/dev/full")  # every write to it fails with ENOSPC
    publisher = Publisher(config, calibration_from_config(config), record=full)
    files = publisher.files
    assert files is not None
    pose = ur_pose_list(np.eye(4))
    with caplog.at_level(logging.WARNING):
        for i in range(3000):  # far more than one chunk: the writer must write
            publisher.on_sample([0.001 * i, *pose[1:]], 0.01 * i)
            if i % 500 == 0:
                publisher.on_audit('{"event": "plan"}')
        publisher.close()
    warnings = [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING]
    assert len(warnings) == 1, warnings
    assert "recording stopped" in warnings[0]
    assert not files.recording
