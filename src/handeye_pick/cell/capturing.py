"""Taking a capture: the flange pose ``T_base_flange`` (m) an image was taken at, latched from
a fresh RTDE sample with the arm at rest, or given from outside; each starts a cycle. Eye-to-hand
latches no pose (the camera is fixed); its capture pose takes the arm out of the camera's view.
"""

from __future__ import annotations

from handeye_pick.cell.captures import Capture
from handeye_pick.cell.moves import move_to_capture
from handeye_pick.cell.state import CellState
from handeye_pick.errors import ConfigError, InputError
from handeye_pick.geometry import Transform, ur_pose_list
from handeye_pick.hand_eye.files import HandEyeMode

LIVE = "live"
"""The source of a flange pose read at pick time because none was given (audit records:
``flange_pose_source``)."""


def capture(state: CellState, pose: str | None, request_id: str | None) -> Capture:
    """Move to the named ``pose`` (default ``capture.pose``) if any, then latch the flange pose
    at rest (eye-in-hand); audited as a ``capture``."""
    state.ensure_not_halted()
    name = pose if pose is not None else state.config.capture.pose
    eye_in_hand = state.calibration.mode is HandEyeMode.EYE_IN_HAND
    if name is None and not eye_in_hand:
        raise ConfigError(
            f"{state.config.path}: an eye-to-hand capture moves the arm out of the camera's "
            "view first: set capture.pose to a named pose, or give one"
        )
    state.cycle += 1
    if name is not None:
        move_to_capture(state, name, request_id)
    T_base_flange = _steady_flange_pose(state) if eye_in_hand else None
    taken = _register(state, T_base_flange, "latched")
    state.link.next_audit().append(taken.record(request_id))
    return taken


def latch_flange_pose(state: CellState, request_id: str | None) -> Transform:
    """``T_base_flange`` (m) where the arm stands, in either mode, moving nothing; audited as a
    ``capture``."""
    state.ensure_not_halted()
    state.cycle += 1
    T_base_flange = _steady_flange_pose(state)
    taken = _register(state, T_base_flange, "latched")
    state.link.next_audit().append(taken.record(request_id))
    return T_base_flange


def given_capture(state: CellState, T_base_flange: Transform, source: str) -> Capture:
    """A capture pose measured elsewhere: ``T_base_flange`` (m) at acquisition."""
    if state.calibration.mode is HandEyeMode.EYE_TO_HAND:
        raise InputError(
            f"{source}: an eye-to-hand cell uses no flange pose at capture (the camera is "
            "fixed): drop it, or check hand_eye.mode"
        )
    state.cycle += 1
    return _register(state, T_base_flange, source)


def request_capture(state: CellState, capture_id: str | None) -> Capture | None:
    """The capture a pick request of a running session names; None eye-to-hand without one.
    Eye-in-hand must name one (InputError): in a session the arm moves between image and pick,
    so the flange read at pick time would not be the flange of the image."""
    if capture_id is not None:
        return state.captures.find(capture_id)
    if state.calibration.mode is HandEyeMode.EYE_IN_HAND:
        raise InputError(
            "pick: an eye-in-hand pick needs the capture_id of the capture its image "
            "was taken at (send a capture request first)"
        )
    return None


def live_capture(state: CellState) -> Capture:
    """A pick's capture taken now (no capture given): the flange at rest eye-in-hand
    (``flange_pose_source: live``), none eye-to-hand."""
    if state.calibration.mode is HandEyeMode.EYE_TO_HAND:
        return _register(state, None, "none (eye-to-hand)")
    T_base_flange = state.link.arm.steady_flange_pose(state.config.capture.steady_timeout_s)
    return _register(state, T_base_flange, LIVE)


def live_pose_note(capture: Capture) -> str:
    """What a refusal of a pick's targets adds when they were chained from the flange pose read
    live at pick time (``live_capture``; empty otherwise): that pose is where the arm stands
    now, not where the image was taken, and how to give the pose the image was taken at."""
    if capture.source != LIVE or capture.T_base_flange is None:
        return ""
    pose = ", ".join(f"{v:.4f}" for v in ur_pose_list(capture.T_base_flange))
    return (
        f"the targets were chained from the live flange pose [{pose}] (m, rad), where the arm "
        "stands now, not where the image was taken if the arm has moved since: give the flange "
        "pose at image acquisition as the detection file's capture.flange_pose_ur (m, rad) or "
        "with --capture-pose-ur X Y Z RX RY RZ"
    )


def _register(state: CellState, T_base_flange: Transform | None, source: str) -> Capture:
    """A new capture of this cycle (the observer hears of it)."""
    taken = state.captures.register(T_base_flange, source, state.cycle)
    if state.observer is not None:
        state.observer.on_capture(taken)
    return taken


def _steady_flange_pose(state: CellState) -> Transform:
    """Check the TCP offset against the config, then latch the flange pose at rest."""
    state.ready_tcp_offset()
    with state.halt_on_fault():
        return state.link.arm.steady_flange_pose(state.config.capture.steady_timeout_s)
