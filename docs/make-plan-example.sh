#!/bin/sh
# Redraws docs/plan-example.png, the picture of `handeye-pick plan --plot` in docs/commands.md.
# Offline: the flange pose is given on the command line, so no robot or simulator is needed.
# Run from anywhere with the project's environment active (or HANDEYE_PICK=.venv/bin/handeye-pick).
set -eu
cd "$(dirname "$0")/.."
"${HANDEYE_PICK:-handeye-pick}" plan \
    --config docs/plan-example.yaml \
    --cloud examples/table_box_camera_mm.npy --pixel 13 8 \
    --robot-pose-ur 0.35 -0.25 0.45 3.1416 0 0 \
    --plot docs/plan-example.png
