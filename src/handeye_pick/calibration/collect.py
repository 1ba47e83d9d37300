"""Collecting a hand-eye dataset on a cell: move, latch the flange pose, capture, keep the pair.

For each pose of a pose list (``pose_list``), in order:

1. ``Cell.move_to``: readiness, pre-flight checks, plan and outcome in the audit file, moveL or
   moveJ, as for a pick. A pose the pre-flight refuses is skipped (nothing moved).
2. ``Cell.latch_flange_pose``: waits until the arm is steady and latches ``T_base_flange`` from
   a fresh RTDE sample (audited as a ``capture`` record), in both hand-eye modes.
3. The capture: the integrator's program (``CommandCapture``) or the operator (``EnterCapture``)
   writes ``T_cam_obj`` to a staging file in the dataset folder, ``pending_object_pose_N.yaml``
   (a name ``calibrate`` ignores).
4. Only when that file exists and reads as a plausible pose are the pair's files put in place:
   ``object_pose_N.yaml`` (the staging file, renamed), then ``robot_pose_N.yaml`` (Zivid's
   format). A failed capture skips the pose and leaves nothing of it; the next pose reuses N.

A robot fault, a cell that is not ready, Ctrl-C and SIGTERM end the run (the ``Cell`` and its
adapter stop the arm and audit the ending); the pairs already written stay.

Units: robot poses are metres inside; the files are written in the dataset's unit (mm, Zivid's,
unless declared), the same unit the capture program writes ``T_cam_obj`` in.
"""

from __future__ import annotations

import contextlib
import logging
import os
import shlex
import shutil
import signal
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from handeye_pick.calibration.dataset import (
    OBJECT_POSE_PREFIX,
    ROBOT_POSE_PREFIX,
    object_pose_path,
    read_dataset,
    robot_pose_path,
)
from handeye_pick.calibration.pose_list import PoseList
from handeye_pick.config.schema import CellConfig
from handeye_pick.errors import CalibrationError, InputError
from handeye_pick.geometry import LengthUnit, Transform
from handeye_pick.hand_eye.files import read_object_pose_file, write_zivid_transform
from handeye_pick.safety import PreflightRefusal, tcp_offset_difference

if TYPE_CHECKING:  # the cell's machinery is loaded by the command that runs, not for --help
    from handeye_pick.cell.session import Cell

log = logging.getLogger(__name__)

POSE_INDEX_ENV = "HANDEYE_POSE_INDEX"
OBJECT_POSE_FILE_ENV = "HANDEYE_OBJECT_POSE_FILE"
PENDING_PREFIX = "pending_"  # staging files: not a pose file name, so calibrate ignores them
UNITS_FLAG = "--units"


class CaptureFailed(Exception):
    """The capture of one pose gave no usable ``T_cam_obj``; the message says why."""


CaptureStep = Callable[[int, Path], None]
"""Takes the pair number N and the file to write ``T_cam_obj`` to; raises ``CaptureFailed``."""


@dataclass(frozen=True)
class SkippedPose:
    """A pose that gave no pair, and why."""

    pose: str  # "pose 3"
    reason: str


@dataclass
class Collection:
    """What a run has done so far; filled as it goes, so an interrupted run still tells."""

    dataset: Path
    pairs: list[int] = field(default_factory=list)  # pair numbers written, in order
    skipped: list[SkippedPose] = field(default_factory=list)


# --- before the first move ----------------------------------------------------------------------


def first_pair_number(dataset: Path, append: bool, units: LengthUnit) -> int:
    """The number of the run's first pair; creates ``dataset`` when it does not exist.

    A folder that already holds pose files is refused unless ``append``: then its pairs are
    read and checked first (a half pair or a misnamed file is an error before anything moves)
    and numbering continues after the highest N.
    """
    if dataset.exists() and not dataset.is_dir():
        raise InputError(f"dataset {dataset} is a file, not a folder")
    try:
        dataset.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(f"cannot create the dataset folder {dataset}: {exc.strerror}") from None
    if not any(
        p.name.startswith((ROBOT_POSE_PREFIX, OBJECT_POSE_PREFIX)) for p in dataset.iterdir()
    ):
        return 0
    if not append:
        raise InputError(
            f"dataset {dataset} already holds pose files: give --append to add pairs after "
            "them, or choose a new folder"
        )
    numbers = [pair.number for pair in read_dataset(dataset, units, UNITS_FLAG)]
    return max(numbers) + 1


def check_pose_list_tcp(pose_list: PoseList, config: CellConfig) -> None:
    """Refuse a pose list made for another TCP than the config's ``robot.tcp_offset``."""
    if pose_list.T_flange_tcp is None:
        return
    robot = config.robot
    offset_mm, offset_deg = tcp_offset_difference(pose_list.T_flange_tcp, robot.T_flange_tcp)
    if offset_mm > robot.tcp_offset_tolerance_mm or offset_deg > robot.tcp_offset_tolerance_deg:
        raise InputError(
            f"{pose_list.path}: tcp_offset differs from robot.tcp_offset of {config.path} by "
            f"{offset_mm:.1f} mm and {offset_deg:.2f} deg: its tcp_pose entries are for another "
            "TCP; propose the poses again for this cell"
        )


# --- capturing ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class CommandCapture:
    """Run the integrator's capture program once per pose, without a shell.

    The program gets ``HANDEYE_POSE_INDEX`` (the pair number N) and ``HANDEYE_OBJECT_POSE_FILE``
    (where to write ``T_cam_obj``) in its environment, no standard input, and ``timeout_s`` to
    finish; then it is killed with every process it started (its own process group), as it is
    when the run is interrupted. Exit status 0 means success; its output goes to the debug log.
    """

    argv: tuple[str, ...]
    timeout_s: float

    @classmethod
    def parse(cls, command: str, timeout_s: float) -> CommandCapture:
        """Split ``command`` like a POSIX shell would (quotes, no expansion) and check that its
        program exists, so a typo is found before the arm moves."""
        try:
            argv = tuple(shlex.split(command))
        except ValueError as exc:
            raise InputError(f"--capture-command {command!r}: {exc}") from None
        if not argv:
            raise InputError("--capture-command is empty")
        if shutil.which(argv[0]) is None:
            raise InputError(f"--capture-command: {argv[0]!r} is not an executable program")
        if not timeout_s > 0:
            raise InputError(f"--capture-timeout-s must be > 0 s, got {timeout_s:g}")
        return cls(argv, timeout_s)

    def __call__(self, number: int, object_pose_file: Path) -> None:
        env = {
            **os.environ,
            POSE_INDEX_ENV: str(number),
            OBJECT_POSE_FILE_ENV: str(object_pose_file.absolute()),  # the program may chdir
        }
        name = Path(self.argv[0]).name
        with subprocess.Popen(
            self.argv,
            env=env,
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            start_new_session=True,
        ) as process:
            try:
                out, err = process.communicate(timeout=self.timeout_s)
            except subprocess.TimeoutExpired:
                _kill_group(process)
                raise CaptureFailed(
                    f"{name} did not finish within {self.timeout_s:g} s (killed; "
                    "--capture-timeout-s sets the limit)"
                ) from None
            except BaseException:  # Ctrl-C, SIGTERM: no capture program outlives the run
                _kill_group(process)
                raise
        log.debug("capture command %s (pair %d) stdout: %s stderr: %s", name, number, out, err)
        if process.returncode != 0:
            last = next((line for line in reversed(err.splitlines()) if line.strip()), "")
            said = f": {last.strip()[:200]}" if last else ""
            raise CaptureFailed(f"{name} exited with status {process.returncode}{said}")


def _kill_group(process: subprocess.Popen[str]) -> None:
    with contextlib.suppress(ProcessLookupError):
        os.killpg(process.pid, signal.SIGKILL)
    process.wait()


@dataclass(frozen=True)
class EnterCapture:
    """The operator captures by hand: a prompt on stderr, then Enter on the terminal.

    The operator writes ``T_cam_obj`` (Zivid YAML, in ``units``) to the file named in the
    prompt and presses Enter; Enter without a file skips the pose. Closed input ends the run.
    """

    units: LengthUnit

    def __call__(self, number: int, object_pose_file: Path) -> None:
        print(
            f"pair {number}: the arm is steady. Capture, write T_cam_obj ({self.units}, Zivid "
            f"YAML) to {object_pose_file.absolute()}, then press Enter (Enter alone skips the "
            "pose, Ctrl-C ends the collection) ",
            end="",
            file=sys.stderr,
            flush=True,
        )
        if not sys.stdin.readline():
            raise KeyboardInterrupt  # input closed: nobody is there to capture


# --- the run ------------------------------------------------------------------------------------


def collect_pairs(
    cell: Cell,
    pose_list: PoseList,
    capture: CaptureStep,
    first_number: int,
    units: LengthUnit,
    collection: Collection,
) -> None:
    """Visit every pose of ``pose_list`` on the connected ``cell`` and fill ``collection``.

    Pairs are numbered from ``first_number``; a skipped pose does not use up its number.
    Raises what ends the run (``SafetyRefusal`` when the cell is not ready, ``RobotError``,
    ``KeyboardInterrupt``); every pair written before stays.
    """
    dataset = collection.dataset
    number = first_number
    total = len(pose_list.poses)
    for index, pose in enumerate(pose_list.poses):
        cell.progress.say(f"{pose.name} ({index + 1} of {total}): pair {number}")
        request_id = f"collect {pose.name}"
        staged_object = dataset / f"{PENDING_PREFIX}{OBJECT_POSE_PREFIX}{number}.yaml"
        staged_robot = dataset / f"{PENDING_PREFIX}{ROBOT_POSE_PREFIX}{number}.yaml"
        try:
            _remove(staged_object, staged_robot)  # left by an earlier run that was killed
            try:
                cell.move_to(pose, request_id=request_id)
            except PreflightRefusal as refusal:
                _skip(collection, pose.name, str(refusal))
                continue
            T_base_flange = cell.latch_flange_pose(request_id=request_id)
            try:
                capture(number, staged_object)
                if not staged_object.is_file():
                    raise CaptureFailed(f"no file was written to {staged_object}")
                read_object_pose_file(staged_object, units, UNITS_FLAG)
            except (CaptureFailed, CalibrationError) as exc:
                _skip(collection, pose.name, str(exc))
                continue
            _store_pair(dataset, number, T_base_flange, staged_object, staged_robot, units)
        finally:
            _remove(staged_object, staged_robot)
        collection.pairs.append(number)
        cell.progress.say(
            f"pair {number}: {robot_pose_path(dataset, number).name} and "
            f"{object_pose_path(dataset, number).name} written"
        )
        number += 1


def _store_pair(
    dataset: Path,
    number: int,
    T_base_flange: Transform,
    staged_object: Path,
    staged_robot: Path,
    units: LengthUnit,
) -> None:
    """Put both files of pair ``number`` in place, the object pose first; never half a pair."""
    write_zivid_transform(staged_robot, T_base_flange, units)
    object_path = object_pose_path(dataset, number)
    try:
        os.replace(staged_object, object_path)
        os.replace(staged_robot, robot_pose_path(dataset, number))
    except BaseException:  # an interrupt between the two renames: take the first one back
        object_path.unlink(missing_ok=True)
        raise


def _skip(collection: Collection, pose: str, reason: str) -> None:
    collection.skipped.append(SkippedPose(pose, reason))
    log.warning("%s skipped: %s", pose, reason)


def _remove(*paths: Path) -> None:
    for path in paths:
        path.unlink(missing_ok=True)
