"""Audit log: strict JSON lines, appended, fsynced before append returns, never silently lost."""

from __future__ import annotations

import json
import os
from datetime import datetime, timedelta, timezone
from pathlib import Path

import numpy as np
import pytest

from handeye_pick.audit import AuditError, AuditLog
from handeye_pick.calibration import HandEyeMode
from handeye_pick.robot.port import SafetyMode
from handeye_pick.safety import CheckResult


def _reject_constant(name: str) -> object:
    raise ValueError(f"not strict JSON: {name}")


def _lines(path: Path) -> list[dict[str, object]]:
    text = path.read_text(encoding="utf-8")
    assert text.endswith("\n")
    return [json.loads(line, parse_constant=_reject_constant) for line in text.splitlines()]


def test_records_are_appended_one_json_object_per_line(tmp_path: Path) -> None:
    path = tmp_path / "picks.jsonl"
    path.write_text('{"earlier": "run"}\n')
    log = AuditLog(path)
    log.append({"event": "plan", "n": 1})
    log.append({"event": "outcome", "n": 2})
    earlier, plan, outcome = _lines(path)
    assert earlier == {"earlier": "run"}
    assert plan["event"] == "plan"
    assert outcome["event"] == "outcome"
    assert plan["pick_id"] == outcome["pick_id"] == log.pick_id


def test_timestamp_is_iso_utc_and_now(tmp_path: Path) -> None:
    before = datetime.now(timezone.utc)
    AuditLog(tmp_path / "a.jsonl").append({"event": "plan"})
    (record,) = _lines(tmp_path / "a.jsonl")
    stamp = datetime.fromisoformat(str(record["timestamp"]))
    assert stamp.utcoffset() == timedelta(0)
    assert before <= stamp <= datetime.now(timezone.utc)


def test_pick_ids_differ_between_logs_unless_given(tmp_path: Path) -> None:
    assert AuditLog(tmp_path / "a.jsonl").pick_id != AuditLog(tmp_path / "a.jsonl").pick_id
    log = AuditLog(tmp_path / "a.jsonl", pick_id="touch-7")
    log.append({"event": "plan"})
    assert _lines(tmp_path / "a.jsonl")[0]["pick_id"] == "touch-7"


def test_numpy_paths_enums_dataclasses_and_non_finite_become_strict_json(tmp_path: Path) -> None:
    path = tmp_path / "a.jsonl"
    AuditLog(path).append(
        {
            "T": np.eye(4),
            "pose": np.array([0.1, 0.2, 0.3, 0.0, 3.14, 0.0], dtype=np.float32),
            "count": np.int64(3),
            "error_mm": np.float64(0.25),
            "file": Path("/cal/hand_eye.yaml"),
            "mode": HandEyeMode.EYE_IN_HAND,
            "safety_mode": SafetyMode.PROTECTIVE_STOP,
            "check": CheckResult("tilt", "grasp", False, "61 deg"),
            "missing": [float("nan"), float("inf"), -float("inf")],
            "nested": {"pair": (1, 2), 3: None},
        }
    )
    (record,) = _lines(path)
    assert record["T"] == np.eye(4).tolist()
    assert record["pose"] == pytest.approx([0.1, 0.2, 0.3, 0.0, 3.14, 0.0], abs=1e-6)
    assert record["count"] == 3
    assert record["error_mm"] == 0.25
    assert record["file"] == "/cal/hand_eye.yaml"
    assert record["mode"] == "eye-in-hand"
    assert record["safety_mode"] == 3
    assert record["check"] == {
        "name": "tilt",
        "target": "grasp",
        "passed": False,
        "detail": "61 deg",
    }
    assert record["missing"] == ["nan", "inf", "-inf"]
    assert record["nested"] == {"pair": [1, 2], "3": None}


def test_record_is_fsynced_before_append_returns(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = tmp_path / "a.jsonl"
    synced: list[int] = []
    real_fsync = os.fsync

    def fsync(fd: int) -> None:
        # The line must already be flushed out of Python's buffer when fsync is asked for it.
        synced.append(os.fstat(fd).st_size)
        real_fsync(fd)

    monkeypatch.setattr(os, "fsync", fsync)
    log = AuditLog(path)
    log.append({"event": "plan"})
    first = path.stat().st_size
    log.append({"event": "outcome"})
    # File content at the first fsync, the new file's directory, then the second line.
    assert synced[0] == first
    assert synced[-1] == path.stat().st_size > first
    assert len(synced) == 3


@pytest.mark.parametrize("where", ["missing-folder/a.jsonl", "a-folder"])
def test_unwritable_file_raises_audit_error(tmp_path: Path, where: str) -> None:
    (tmp_path / "a-folder").mkdir()
    with pytest.raises(AuditError, match=r"cannot append to .*refusing to go on"):
        AuditLog(tmp_path / where).append({"event": "plan"})


def test_unserialisable_value_raises_and_writes_nothing(tmp_path: Path) -> None:
    path = tmp_path / "a.jsonl"
    with pytest.raises(AuditError, match=r"record\.outcome\.error of type object"):
        AuditLog(path).append({"outcome": {"error": object()}})
    assert not path.exists()


@pytest.mark.parametrize("key", ["timestamp", "pick_id"])
def test_reserved_keys_are_refused(tmp_path: Path, key: str) -> None:
    with pytest.raises(AuditError, match="set by the audit log itself"):
        AuditLog(tmp_path / "a.jsonl").append({key: "x"})
