"""Every audit record the suite writes, checked against docs/audit.schema.json."""

from __future__ import annotations

import json
from functools import cache
from pathlib import Path
from typing import Any

from jsonschema import Draft202012Validator

SCHEMA = Path(__file__).resolve().parents[1] / "docs" / "audit.schema.json"


@cache
def validator() -> Draft202012Validator:
    schema = json.loads(SCHEMA.read_text())
    Draft202012Validator.check_schema(schema)
    return Draft202012Validator(schema)


def record_problems(record: dict[str, Any]) -> list[str]:
    """What is wrong with one record (empty when it is valid)."""
    return [error.message for error in validator().iter_errors(record)]


def invalid_records(folder: Path) -> list[str]:
    """One line per invalid record written by handeye-pick (it carries ``schema``) in any
    ``*.jsonl`` file under ``folder``. Left out as not the package's: records a test wrote by
    hand (no ``schema``), torn lines, and files named ``free-*.jsonl``, where the audit log's
    own tests append records of any shape on purpose."""
    found: list[str] = []
    for path in sorted(folder.rglob("*.jsonl")):
        if not path.is_file() or path.name.startswith("free-"):
            continue
        for number, line in enumerate(path.read_bytes().splitlines(), 1):
            try:
                record = json.loads(line)
            except ValueError:
                continue
            if not isinstance(record, dict) or "schema" not in record:
                continue
            for problem in record_problems(record):
                found.append(f"{path}:{number}: {problem[:300]}")
    return found
