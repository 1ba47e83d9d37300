"""ControllerOptions and its command-line spelling: what SimulatedController passes its child
process is read back as the same options, and the command line's defaults are the options'."""

from __future__ import annotations

import argparse
import dataclasses
from typing import Any

import pytest

from mocks.ur_controller.options import ControllerOptions, add_arguments, from_args, to_argv

# Between them every field differs from its default (the command line takes initial_q or
# initial_flange_pose, and --speed-factor or --instant).
CASES = [
    ControllerOptions(
        host="127.0.0.9", model="ur10", initial_q=(0.1, -1.2, 1.3, -1.4, -1.5, 0.6),
        tcp_offset=(0.0, 0.0, 0.1, 0.0, 0.0, 0.5), speed_factor=2.5, record_path="c.jsonl",
        inject=("refuse-move", "stall:1.5@move:2:0.5"), remote_control=False,
        allow_non_loopback=True, profile="cb3", tracking=True, seed=7,
        motion_record_path="m.jsonl", part_width_mm=40.5, feedback_input=(16, 3),
        program_start_s=0.25, trace_tcp=True,
    ),
    ControllerOptions(initial_flange_pose=(-0.4, -0.1, 0.4, 3.1, 0.0, 0.0), instant=True,
                      profile="polyscope-x", program_start_cost=True),
]


def _parse(argv: list[str]) -> ControllerOptions:
    parser = argparse.ArgumentParser()
    add_arguments(parser)
    return from_args(parser.parse_args(argv))


def _plain(options: ControllerOptions) -> dict[str, Any]:
    """The fields, argparse's lists as tuples."""
    return {name: tuple(value) if isinstance(value, list) else value
            for name, value in dataclasses.asdict(options).items()}


@pytest.mark.parametrize("options", [ControllerOptions(), *CASES])
def test_the_command_line_reads_back_the_options_it_was_given(
    options: ControllerOptions,
) -> None:
    assert _plain(_parse(to_argv(options))) == _plain(options)


def test_the_cases_set_every_field() -> None:
    default = dataclasses.asdict(ControllerOptions())
    unset = [name for name in default
             if all(dataclasses.asdict(case)[name] == default[name] for case in CASES)]
    assert unset == []


def test_the_command_line_defaults_are_the_options_defaults() -> None:
    assert _plain(_parse([])) == _plain(ControllerOptions())
