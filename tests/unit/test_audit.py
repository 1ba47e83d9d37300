"""Audit log: strict JSON lines, appended, fsynced before append returns, never silently lost."""

from __future__ import annotations

import fcntl
import json
import os
from datetime import datetime, timedelta, timezone
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from handeye_pick.audit import (
    AuditError,
    AuditLog,
    TornLine,
    check_appendable,
    open_audit,
    read_audit,
)
from handeye_pick.hand_eye.files import HandEyeMode
from handeye_pick.robot.port import SafetyMode
from handeye_pick.safety import CheckResult


def _reject_constant(name: str) -> object:
    raise ValueError(f"not strict JSON: {name}")


def _lines(path: Path) -> list[dict[str, object]]:
    text = path.read_text(encoding="utf-8")
    assert text.endswith("\n")
    return [json.loads(line, parse_constant=_reject_constant) for line in text.splitlines()]


def test_records_are_appended_one_json_object_per_line(tmp_path: Path) -> None:
    path = tmp_path / "free-picks.jsonl"
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
    AuditLog(tmp_path / "free-a.jsonl").append({"event": "plan"})
    (record,) = _lines(tmp_path / "free-a.jsonl")
    stamp = datetime.fromisoformat(str(record["timestamp"]))
    assert stamp.utcoffset() == timedelta(0)
    assert before <= stamp <= datetime.now(timezone.utc)


def test_pick_ids_differ_between_logs_unless_given(tmp_path: Path) -> None:
    assert (
        AuditLog(tmp_path / "free-a.jsonl").pick_id != AuditLog(tmp_path / "free-a.jsonl").pick_id
    )
    log = AuditLog(tmp_path / "free-a.jsonl", pick_id="touch-7")
    log.append({"event": "plan"})
    assert _lines(tmp_path / "free-a.jsonl")[0]["pick_id"] == "touch-7"


def test_numpy_paths_enums_dataclasses_and_non_finite_become_strict_json(tmp_path: Path) -> None:
    path = tmp_path / "free-a.jsonl"
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
    path = tmp_path / "free-a.jsonl"
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
    path = tmp_path / "free-a.jsonl"
    with pytest.raises(AuditError, match=r"record\.outcome\.error of type object"):
        AuditLog(path).append({"outcome": {"error": object()}})
    assert not path.exists()


@pytest.mark.parametrize("key", ["timestamp", "pick_id"])
def test_reserved_keys_are_refused(tmp_path: Path, key: str) -> None:
    with pytest.raises(AuditError, match="set by the audit log itself"):
        AuditLog(tmp_path / "free-a.jsonl").append({key: "x"})


# --- before anything connects: can the file be appended to? --------------------------------------


@pytest.mark.parametrize(
    ("where", "message"),
    [
        ("a-folder", r"a-folder is a folder, not a file: name a file in it \(audit\.file\)"),
        ("missing-folder/a.jsonl", r"cannot append to .*\(No such file or directory\)"),
        ("a-file/a.jsonl", r"cannot append to .*\(Not a directory\)"),
    ],
)
def test_check_appendable_refuses_in_one_line(tmp_path: Path, where: str, message: str) -> None:
    (tmp_path / "a-folder").mkdir()
    (tmp_path / "a-file").write_text("")
    with pytest.raises(AuditError, match=message) as info:
        check_appendable(tmp_path / where)
    assert "\n" not in str(info.value)
    assert "refusing to start without a record" in str(info.value)


def test_check_appendable_refuses_a_disk_that_cannot_sync(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    def fsync(fd: int) -> None:
        raise OSError(5, "Input/output error")

    monkeypatch.setattr(os, "fsync", fsync)
    with pytest.raises(AuditError, match=r"cannot append to .*\(Input/output error\)"):
        check_appendable(tmp_path / "free-a.jsonl")


def test_check_appendable_leaves_an_existing_file_as_it_was(tmp_path: Path) -> None:
    path = tmp_path / "free-a.jsonl"
    check_appendable(path)
    assert path.read_bytes() == b""
    path.write_bytes(b'{"a": 1}\n{"b": ')
    check_appendable(path)
    assert path.read_bytes() == b'{"a": 1}\n{"b": '


# --- torn lines: a write cut short by a power cut ------------------------------------------------


def test_append_after_a_torn_line_starts_a_fresh_line(tmp_path: Path) -> None:
    path = tmp_path / "free-a.jsonl"
    AuditLog(path, pick_id="one").append({"event": "plan"})
    complete = path.read_bytes()
    path.write_bytes(complete + b'{"timestamp": "2024-01-01T00:00:00+00:00", "pick_id": "tw')
    AuditLog(path, pick_id="three").append({"event": "plan"})
    first, torn, third = read_audit(path)
    assert isinstance(first, dict)
    assert first["pick_id"] == "one"
    assert torn == TornLine(
        len(complete), '{"timestamp": "2024-01-01T00:00:00+00:00", "pick_id": "tw'
    )
    assert isinstance(third, dict)
    assert third["pick_id"] == "three"


def test_zero_filled_tail_is_a_torn_line(tmp_path: Path) -> None:
    # ext4 may leave the file longer but zero-filled after a power cut.
    path = tmp_path / "free-a.jsonl"
    path.write_bytes(b'{"a": 1}\n' + b"\0" * 300)
    AuditLog(path).append({"event": "plan"})
    first, torn, plan = read_audit(path)
    assert first == {"a": 1}
    assert isinstance(torn, TornLine)
    assert torn.offset == 9
    assert torn.text.startswith("\0\0\0")
    assert len(torn.text) == 80
    assert isinstance(plan, dict)
    assert plan["event"] == "plan"


def test_a_complete_last_record_without_its_newline_is_a_record(tmp_path: Path) -> None:
    path = tmp_path / "free-a.jsonl"
    path.write_bytes(b'{"a": 1}\n{"b": 2}')
    AuditLog(path).append({"event": "plan"})
    assert [entry for entry in read_audit(path) if isinstance(entry, TornLine)] == []
    assert [list(e)[-1] for e in read_audit(path) if isinstance(e, dict)] == ["a", "b", "event"]


@given(
    events=st.lists(st.sampled_from(["plan", "outcome"]), min_size=1, max_size=6),
    cut_fraction=st.floats(0.0, 1.0),
)
@settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
def test_a_power_cut_anywhere_loses_no_complete_record(
    tmp_path_factory: pytest.TempPathFactory, events: list[str], cut_fraction: float
) -> None:
    path = tmp_path_factory.mktemp("cut") / "free-a.jsonl"
    log = AuditLog(path)
    for n, event in enumerate(events):
        log.append({"event": event, "n": n})
    data = path.read_bytes()
    cut = int(len(data) * cut_fraction)
    path.write_bytes(data[:cut])  # the power cut: everything after byte ``cut`` is lost
    survivors = data[:cut].count(b"\n")  # records whose line (and newline) reached the disk
    log.append({"event": "after", "n": -1})
    entries = list(read_audit(path))
    records = [entry for entry in entries if isinstance(entry, dict)]
    torn = [entry for entry in entries if isinstance(entry, TornLine)]
    ended_cleanly = cut == 0 or data[cut - 1 : cut] == b"\n"
    whole_record_without_newline = not ended_cleanly and data[cut : cut + 1] == b"\n"
    assert [r["n"] for r in records] == [
        *range(survivors + whole_record_without_newline),
        -1,
    ]
    assert len(torn) == (0 if ended_cleanly or whole_record_without_newline else 1)


# --- open_audit: the one entry point --------------------------------------------------------------


def _write_lines(path: Path, *records: dict[str, object]) -> None:
    path.write_text("".join(json.dumps(record) + "\n" for record in records))


PLAN_A = {"timestamp": "t1", "pick_id": "a", "event": "plan", "dry_run": False, "host": "h"}
OUTCOME_A = {"timestamp": "t2", "pick_id": "a", "event": "outcome", "status": "done"}
PLAN_B = {
    "timestamp": "2024-05-01T10:00:00+00:00",
    "pick_id": "b",
    "event": "plan",
    "dry_run": False,
    "host": "10.0.0.5",
    "config": "/cell/cell.yaml",
}


def test_open_audit_closes_a_plan_left_without_an_outcome(tmp_path: Path) -> None:
    path = tmp_path / "free-a.jsonl"
    _write_lines(path, PLAN_A, OUTCOME_A, PLAN_B)
    with open_audit(path)[0] as audit:
        pass
    audit, warnings = open_audit(path)  # the next start finds nothing left
    audit.close()
    assert warnings == []
    *_, abandoned = _lines(path)
    assert abandoned["pick_id"] == "b"
    assert abandoned["event"] == "outcome"
    assert abandoned["status"] == "abandoned"
    assert abandoned["plan_timestamp"] == "2024-05-01T10:00:00+00:00"
    assert abandoned["dry_run"] is False


def test_the_abandon_warning_says_what_was_abandoned(tmp_path: Path) -> None:
    path = tmp_path / "free-a.jsonl"
    _write_lines(path, PLAN_A, OUTCOME_A, {**PLAN_B, "dry_run": True})
    audit, (warning,) = open_audit(path)
    audit.close()
    assert warning == (
        f"audit {path}: dry run b planned at 2024-05-01T10:00:00+00:00 on 10.0.0.5 (config "
        "/cell/cell.yaml) has no outcome: its process ended without one (killed, crashed or a "
        "power cut); recorded as abandoned. Check where the robot is before moving it"
    )


def test_open_audit_reports_a_torn_plan_and_closes_the_one_before(tmp_path: Path) -> None:
    path = tmp_path / "free-a.jsonl"
    _write_lines(path, PLAN_A, OUTCOME_A, PLAN_B)
    size = path.stat().st_size
    with path.open("ab") as file:
        file.write(b'{"timestamp": "t9", "pick_id": "c", "event": "pl')
    audit, warnings = open_audit(path)
    audit.close()
    assert len(warnings) == 2
    assert warnings[0].startswith(f"audit {path}: an incomplete line at byte {size} (a write cut")
    assert "b planned at" in warnings[1]
    entries = list(read_audit(path))
    assert isinstance(entries[3], TornLine)
    assert entries[4]["status"] == "abandoned"  # type: ignore[index]


def test_a_live_process_keeps_its_plan(tmp_path: Path) -> None:
    path = tmp_path / "free-a.jsonl"
    _write_lines(path, PLAN_A, OUTCOME_A, PLAN_B)
    other = os.open(path, os.O_RDONLY)  # another process's open_audit holds a shared lock
    try:
        fcntl.flock(other, fcntl.LOCK_SH)
        audit, (warning,) = open_audit(path)
        audit.close()
    finally:
        os.close(other)
    assert "another process is using this file" in warning
    assert [r["pick_id"] for r in _lines(path)] == ["a", "a", "b"]


def test_a_session_holds_the_file_until_closed_and_each_cycle_has_its_pick_id(
    tmp_path: Path,
) -> None:
    path = tmp_path / "free-a.jsonl"
    first, warnings = open_audit(path)
    assert warnings == []
    first.append({"event": "plan"})
    second = first.next_pick()
    assert (second.path, second.pick_id != first.pick_id) == (path, True)
    second.append({"event": "outcome"})  # the first pick is left open: the session is live
    meanwhile, (warning,) = open_audit(path)
    meanwhile.close()
    assert "another process is using this file" in warning
    second.close()  # the session ends: its lock goes for every cycle's log
    after, (warning,) = open_audit(path)
    after.close()
    assert f"pick {first.pick_id} planned at" in warning


def test_the_scan_reads_back_only_to_the_last_finished_plan(tmp_path: Path) -> None:
    path = tmp_path / "free-a.jsonl"
    old_unfinished = {**PLAN_B, "pick_id": "old"}
    records = [old_unfinished] + [
        {"pick_id": f"p{n}", "event": event, "n": n}
        for n in range(50_000)
        for event in ("plan", "outcome")
    ]
    path.write_text("garbage from before\n" + "".join(json.dumps(r) + "\n" for r in records))
    _write_lines_append(path, PLAN_B)
    audit, (warning,) = open_audit(path)
    audit.close()
    # Closed: the plan after the last finished one. Not reached: the old plan and the garbage.
    assert "b planned at" in warning
    with path.open("rb") as file:
        file.seek(-400, os.SEEK_END)
        assert b'"status": "abandoned"' in file.read()


def _write_lines_append(path: Path, *records: dict[str, object]) -> None:
    with path.open("a") as file:
        file.write("".join(json.dumps(record) + "\n" for record in records))


def test_open_audit_refuses_an_unwritable_file_in_one_line(tmp_path: Path) -> None:
    with pytest.raises(AuditError, match="is a folder, not a file"):
        open_audit(tmp_path)
