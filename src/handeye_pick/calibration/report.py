"""What ``calibrate`` tells: the record (JSON and ``hand_eye_residuals.yaml``) and the table.

Both carry the same facts: the transform and its name, the OpenCV start, the stated noise, the
residual of every pair by its file number N (mm, deg), mean and max, the suspects and what
excluding them would give, the warnings, and Zivid's published bands to judge the residuals by.
"""

from __future__ import annotations

import math
from dataclasses import asdict
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from handeye_pick.calibration.solver import HandEyeFit, HandEyeResult
from handeye_pick.errors import CalibrationError
from handeye_pick.geometry import rotation_angle_between
from handeye_pick.hand_eye.files import HandEyeMode

ZIVID_BANDS = (
    "Zivid's bands: residuals in the sub-millimetre range for a smaller robot and in the "
    "millimetre range for a larger one; rotation residuals in the sub-degree range"
)
TRANSFORM_NAMES = {HandEyeMode.EYE_IN_HAND: "T_flange_cam", HandEyeMode.EYE_TO_HAND: "T_base_cam"}


def result_record(result: HandEyeResult) -> dict[str, Any]:
    """Everything about ``result`` as plain data (metres for the transform, mm and deg else)."""
    suspects = set(result.suspects)
    record: dict[str, Any] = {
        "mode": result.mode.value,
        "transform_name": TRANSFORM_NAMES[result.mode],
        "transform_m": result.fit.T_cal.tolist(),
        "start_method": result.start_method,
        "pairs_used": [r.number for r in result.fit.residuals],
        "excluded": list(result.excluded),
        "noise": asdict(result.noise),
        **_fit_summary(result.fit),
        "residuals": [
            {
                "pair": r.number,
                "translation_mm": r.translation_mm,
                "rotation_deg": r.rotation_deg,
                "suspect": r.number in suspects,
            }
            for r in result.fit.residuals
        ],
        "suspects": list(result.suspects),
        "without_suspects": _without_suspects(result),
        "warnings": list(result.warnings),
        "bands": ZIVID_BANDS,
    }
    return record


def write_residuals(path: Path, result: HandEyeResult) -> None:
    """Write ``result_record`` as YAML to ``path``."""
    header = "# handeye-pick calibrate: residual per pair N (mm, deg), suspects, noise model\n"
    text = header + yaml.safe_dump(
        result_record(result), sort_keys=False, width=100, default_flow_style=None
    )
    try:
        Path(path).write_text(text, encoding="utf-8")
    except OSError as exc:
        raise CalibrationError(f"cannot write {path}: {exc.strerror}") from None


def result_table(result: HandEyeResult) -> str:
    """The residual table and what to make of it, for a person."""
    fit = result.fit
    suspects = set(result.suspects)
    excluded = f", pairs {_numbers(result.excluded)} excluded" if result.excluded else ""
    lines = [
        f"{result.mode.value}: {TRANSFORM_NAMES[result.mode]} from {len(fit.residuals)} pairs"
        f"{excluded} (start {result.start_method}, refined by weighted least squares)",
        f"  {'pair':>6}  {'translation mm':>14}  {'rotation deg':>12}",
    ]
    for r in fit.residuals:
        mark = "  suspect" if r.number in suspects else ""
        lines.append(f"  {r.number:>6}  {r.translation_mm:14.3f}  {r.rotation_deg:12.3f}{mark}")
    lines.append(f"  {'mean':>6}  {fit.translation_mean_mm:14.3f}  {fit.rotation_mean_deg:12.3f}")
    lines.append(f"  {'max':>6}  {fit.translation_max_mm:14.3f}  {fit.rotation_max_deg:12.3f}")
    lines.append(ZIVID_BANDS)
    if result.suspects:
        lines.append(_suspect_line(result))
    return "\n".join(lines)


def _fit_summary(fit: HandEyeFit) -> dict[str, float]:
    return {
        "translation_mean_mm": fit.translation_mean_mm,
        "translation_max_mm": fit.translation_max_mm,
        "rotation_mean_deg": fit.rotation_mean_deg,
        "rotation_max_deg": fit.rotation_max_deg,
    }


def _without_suspects(result: HandEyeResult) -> dict[str, Any] | None:
    if not result.suspects:
        return None
    other = result.without_suspects
    if other is None:
        return {"refused": result.without_suspects_refusal}
    moved_mm, moved_deg = _change(result.fit, other)
    return {
        "transform_m": other.T_cal.tolist(),
        "moves_translation_mm": moved_mm,
        "moves_rotation_deg": moved_deg,
        **_fit_summary(other),
    }


def _suspect_line(result: HandEyeResult) -> str:
    numbers = _numbers(result.suspects)
    which = f"pairs {numbers} stand" if len(result.suspects) > 1 else f"pair {numbers} stands"
    head = f"suspects: {which} out (wrongly paired, or the arm or the object moved?)"
    other = result.without_suspects
    if other is None:
        return f"{head}; excluding them is not possible: {result.without_suspects_refusal}"
    moved_mm, moved_deg = _change(result.fit, other)
    return (
        f"{head}; excluding them (--exclude {numbers.replace(' ', '')}) would move the result by "
        f"{moved_mm:.3f} mm and {moved_deg:.3f} deg, to residuals of mean "
        f"{other.translation_mean_mm:.3f} / max {other.translation_max_mm:.3f} mm and mean "
        f"{other.rotation_mean_deg:.3f} / max {other.rotation_max_deg:.3f} deg"
    )


def _change(fit: HandEyeFit, other: HandEyeFit) -> tuple[float, float]:
    """How far ``other``'s transform is from ``fit``'s: origin distance (mm), angle (deg)."""
    moved_mm = float(np.linalg.norm(other.T_cal[:3, 3] - fit.T_cal[:3, 3])) * 1e3
    moved_deg = math.degrees(rotation_angle_between(fit.T_cal[:3, :3], other.T_cal[:3, :3]))
    return moved_mm, moved_deg


def _numbers(numbers: tuple[int, ...]) -> str:
    return ", ".join(str(n) for n in numbers)
