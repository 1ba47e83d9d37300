"""Zivid's matrix YAML (``__version__`` serializer 1 / data 1, ``FloatMatrix: Data: 4x4``).

Zivid writes poses this way (``RobotTransform.yaml``, hand-eye results, a calibration board's
pose), translation in millimetres. Written here with every float's full ``repr`` so a reader gets
the exact matrix back, and atomically (a temporary file renamed into place), so a program
waiting for the file never reads half of it.
"""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

import numpy as np
import yaml

from mocks.camera.frames import Matrix


def write_zivid_matrix(path: str | Path, T: Matrix) -> None:
    """Write a 4x4 (translation in mm, as Zivid's files hold it) to ``path``."""
    arr = np.asarray(T, dtype=np.float64)
    if arr.shape != (4, 4) or not np.all(np.isfinite(arr)):
        raise ValueError(f"write_zivid_matrix: need a finite 4x4, got {arr.tolist()}")
    rows = ",\n".join("    [" + ", ".join(repr(float(v)) for v in row) + "]" for row in arr)
    text = ("__version__:\n  serializer: 1\n  data: 1\nFloatMatrix:\n"
            f"  Data: [\n{rows}]\n")
    target = Path(path)
    handle, temporary = tempfile.mkstemp(dir=target.parent, prefix=f".{target.name}.")
    try:
        with os.fdopen(handle, "w") as out:
            out.write(text)
        os.replace(temporary, target)
    except BaseException:
        Path(temporary).unlink(missing_ok=True)
        raise


def read_zivid_matrix(path: str | Path) -> Matrix:
    """The 4x4 in a Zivid matrix file, as written (translation in the file's unit, mm)."""
    doc = yaml.safe_load(Path(path).read_text())
    try:
        data = doc["FloatMatrix"]["Data"]
    except (TypeError, KeyError) as exc:
        raise ValueError(f"{path}: not a Zivid matrix file (no FloatMatrix: Data)") from exc
    arr = np.asarray(data, dtype=np.float64)
    if arr.shape != (4, 4) or not np.all(np.isfinite(arr)):
        raise ValueError(f"{path}: FloatMatrix.Data must be a finite 4x4")
    return arr
