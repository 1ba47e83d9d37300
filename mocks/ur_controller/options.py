"""ControllerOptions: what a simulated controller is started with, in one frozen value, and its
command-line spelling both ways.

`python -m mocks.ur_controller` parses its command line into ControllerOptions (add_arguments,
from_args); SimulatedController turns its keyword arguments into ControllerOptions and hands
them to its child process as that same command line (to_argv). The checks that need a profile
or the kinematics (a model the profile has, a reachable start pose, ...) are the Controller's,
so a bad option is refused where it always was: by Controller, which for SimulatedController
runs in the child, at start().
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from mocks.ur_controller.kinematics import ALL_MODELS
from mocks.ur_controller.profiles import DEFAULT_PROFILE, PROFILES

EXIT_CANNOT_LISTEN = 3  # command-line exit status: a port is taken or the address is not local

@dataclass(frozen=True)
class ControllerOptions:
    """A simulated controller's options; README.md ("Use") describes each. Poses are UR vectors
    [x, y, z, rx, ry, rz] (m, rad), joints in rad."""

    host: str = "127.0.0.1"  # a loopback address unless allow_non_loopback
    model: str | None = None  # None: the profile's default arm
    initial_q: Sequence[float] | None = None
    initial_flange_pose: Sequence[float] | None = None  # or initial_q, not both
    tcp_offset: Sequence[float] = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)  # T_flange_tcp
    speed_factor: float = 1.0  # motions run this many times faster than real time
    instant: bool = False  # motions end within two cycles; the speed factor then plays no part
    record_path: str | Path | None = None  # command record, appended as JSON lines
    inject: Sequence[str] = ()  # FAULT@WHEN specs (faults.py)
    remote_control: bool = True  # False: start in local control
    allow_non_loopback: bool = False
    profile: str = DEFAULT_PROFILE  # a name in profiles.PROFILES
    tracking: bool = False  # actual joints lag the target and carry measurement noise
    seed: int = 0  # the noise seed, with tracking
    motion_record_path: str | Path | None = None  # motion record, appended as JSON lines
    part_width_mm: float | None = None  # a part this wide waits at the gripper
    feedback_input: Sequence[int] | None = None  # (output bit, input bit), each 0..17
    program_start_s: float = 0.0  # a program from the script port runs this long after it came
    program_start_cost: bool = False  # ... or after the profile's start cost for its length
    trace_tcp: bool = False  # each motion record entry lists the TCP pose and joints of every cycle


_DEFAULTS = ControllerOptions()


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The controller's options on a command line, with ControllerOptions' defaults."""
    parser.add_argument("--host", default=_DEFAULTS.host, help="loopback address to serve on")
    parser.add_argument("--profile", default=_DEFAULTS.profile, choices=sorted(PROFILES),
                        help="controller generation (default %(default)s)")
    parser.add_argument("--model", choices=sorted(ALL_MODELS),
                        help="arm (default: ur5e, or ur5 with --profile cb3)")
    start = parser.add_mutually_exclusive_group()
    start.add_argument("--initial-q", nargs=6, type=float, metavar="Q", help="joints (rad)")
    start.add_argument("--initial-flange-pose", nargs=6, type=float, metavar="V",
                       help="flange pose in base, UR vector (m, rad)")
    parser.add_argument("--tcp-offset", nargs=6, type=float, metavar="V",
                        default=list(_DEFAULTS.tcp_offset),
                        help="active TCP offset T_flange_tcp (m, rad)")
    speed = parser.add_mutually_exclusive_group()
    speed.add_argument("--speed-factor", type=float, default=_DEFAULTS.speed_factor,
                       help="run motions this many times faster than real time")
    speed.add_argument("--instant", action="store_true", help="motions end within two cycles")
    parser.add_argument("--tracking", action="store_true",
                        help="actual joints lag the target by 3 cycles and carry measurement "
                             "noise (default: actual == target exactly)")
    parser.add_argument("--seed", type=int, default=_DEFAULTS.seed,
                        help="noise seed for --tracking")
    parser.add_argument("--record", metavar="FILE", help="append commands as JSON lines")
    parser.add_argument("--record-motions", metavar="FILE",
                        help="append each motion's start, end and time moving as JSON lines")
    parser.add_argument("--inject", action="append", default=[], metavar="FAULT@WHEN",
                        help="fault, e.g. protective-stop@move:2:0.5 (repeatable)")
    parser.add_argument("--part-width-mm", type=float, metavar="W",
                        help="a part W mm wide waits at the gripper (default: none)")
    parser.add_argument("--feedback-input", nargs=2, type=int, metavar=("DO", "DI"),
                        help="digital input bit DI reads true while output bit DO is on and "
                             "the part is present (bits of actual_digital_*_bits, 0-17)")
    parser.add_argument("--program-start-s", type=float, default=_DEFAULTS.program_start_s,
                        metavar="S", help="a program received on the script port starts S "
                                          "seconds of controller time later (default 0)")
    parser.add_argument("--program-start-cost", action="store_true",
                        help="a program received on the script port starts after the profile's "
                             "start cost for its length (cb3 2 ms a line, e-Series 1 ms a line, "
                             "at the speed factor); default: at once")
    parser.add_argument("--trace-tcp", action="store_true",
                        help="the motion record lists the target TCP pose of every cycle each "
                             "motion moved (tcp_trace) and its joints (q_trace)")
    parser.add_argument("--no-remote-control", action="store_true",
                        help="start in local control (dashboard says remote control is off)")
    parser.add_argument("--allow-non-loopback", action="store_true",
                        help="allow a host address that is not loopback")


def from_args(args: argparse.Namespace) -> ControllerOptions:
    """The options parsed by a parser that add_arguments set up (vectors as argparse's lists)."""
    return ControllerOptions(
        host=args.host, model=args.model, initial_q=args.initial_q,
        initial_flange_pose=args.initial_flange_pose, tcp_offset=args.tcp_offset,
        speed_factor=args.speed_factor, instant=args.instant, record_path=args.record,
        inject=args.inject, remote_control=not args.no_remote_control,
        allow_non_loopback=args.allow_non_loopback, profile=args.profile,
        tracking=args.tracking, seed=args.seed, motion_record_path=args.record_motions,
        part_width_mm=args.part_width_mm, feedback_input=args.feedback_input,
        program_start_s=args.program_start_s, program_start_cost=args.program_start_cost,
        trace_tcp=args.trace_tcp,
    )


def to_argv(options: ControllerOptions) -> list[str]:
    """The command line whose from_args gives these options back.

    The command line takes --speed-factor or --instant, so with `instant` the speed factor is
    left out (it plays no part then), and --seed goes only with --tracking (its only user).
    """
    o = options
    argv = ["--host", o.host, "--profile", o.profile, "--tcp-offset", *_numbers(o.tcp_offset)]
    if o.model is not None:
        argv += ["--model", o.model]
    if o.initial_q is not None:
        argv += ["--initial-q", *_numbers(o.initial_q)]
    if o.initial_flange_pose is not None:
        argv += ["--initial-flange-pose", *_numbers(o.initial_flange_pose)]
    argv += ["--instant"] if o.instant else ["--speed-factor", repr(float(o.speed_factor))]
    if o.record_path is not None:
        argv += ["--record", str(o.record_path)]
    for spec in o.inject:
        argv += ["--inject", spec]
    if not o.remote_control:
        argv.append("--no-remote-control")
    if o.allow_non_loopback:
        argv.append("--allow-non-loopback")
    if o.tracking:
        argv += ["--tracking", "--seed", str(o.seed)]
    if o.motion_record_path is not None:
        argv += ["--record-motions", str(o.motion_record_path)]
    if o.part_width_mm is not None:
        argv += ["--part-width-mm", repr(float(o.part_width_mm))]
    if o.feedback_input is not None:
        argv += ["--feedback-input", *(str(int(b)) for b in o.feedback_input)]
    if o.program_start_s:
        argv += ["--program-start-s", repr(float(o.program_start_s))]
    if o.program_start_cost:
        argv.append("--program-start-cost")
    if o.trace_tcp:
        argv.append("--trace-tcp")
    return argv


def _numbers(values: Sequence[float]) -> list[str]:
    """Command-line spelling of floats that round-trips exactly."""
    return [repr(float(v)) for v in values]

