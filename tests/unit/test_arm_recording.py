"""The recording's ``/cell/plan`` shows the arm (record/channels.py): the link solids at the
start and at the end of every move of the plan, at the joints the scene check follows, as
foxglove cylinders (and a capsule's two end spheres)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from foxglove.messages import SceneUpdate
from mcap.records import Schema
from mcap_protobuf.decoder import DecoderFactory

from handeye_pick.arm.kinematics import link_poses, tcp_poses
from handeye_pick.config.load import load_config
from handeye_pick.record.channels import arm_entities, plan_update
from handeye_pick.steps import Move, Step

ROOT = Path(__file__).resolve().parents[2]
Q_CAPTURE = np.array([0.0, -1.63039, 1.338517, -1.278923, -1.570796, 0.0])  # config/bin.yaml


def _decoded(update: SceneUpdate) -> Any:
    """The update as a viewer reads it: its protobuf bytes decoded with its own schema."""
    schema = SceneUpdate.get_schema()
    decode = DecoderFactory().decoder_for(
        "protobuf", Schema(id=1, name=schema.name, encoding=schema.encoding, data=schema.data)
    )
    assert decode is not None
    return decode(bytes(update.encode()))


def test_the_plan_carries_the_arm_at_each_stop() -> None:
    config = load_config(ROOT / "config" / "bin.yaml")
    model = config.robot.model
    assert model is not None
    T_start = tcp_poses(model, Q_CAPTURE, config.robot.T_flange_tcp)[0]
    lowered = T_start.copy()
    lowered[2, 3] -= 0.1
    steps: list[Step] = [Move("approach", lowered), Move("grasp", lowered, slow=True)]
    arm = arm_entities(config, steps, T_start, tuple(Q_CAPTURE), 0)
    entities = _decoded(plan_update(steps, T_start, 0, arm)).entities[-3:]
    assert [e.id for e in entities] == ["arm at start", "arm at approach", "arm at grasp"]
    for entity in entities:
        assert len(entity.cylinders) == len(model.links)
        assert len(entity.spheres) == 2 * sum(link.kind == "capsule" for link in model.links)
    start = link_poses(model, Q_CAPTURE)[0]
    for cylinder, T in zip(entities[0].cylinders, start, strict=True):
        p = cylinder.pose.position
        np.testing.assert_allclose([p.x, p.y, p.z], T[:3, 3], atol=1e-9)
    wrist = [link.name for link in model.links].index("wrist 3")
    at = [e.cylinders[wrist].pose.position.z for e in entities]
    assert abs(at[1] - at[0] + 0.1) < 1e-6  # the last wrist went down with the TCP
