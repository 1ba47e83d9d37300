"""Commands that transform points, clouds and poses without a robot (filled in by issue 2)."""

from __future__ import annotations

import argparse


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the transform commands to the top-level parser."""
