"""The recording's pose conversion against the project's own quaternion maths (property): the
message is encoded by the Foxglove SDK and decoded from its own protobuf schema."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from foxglove.messages import Pose
from hypothesis import given
from hypothesis import strategies as st
from mcap.records import Schema
from mcap_protobuf.decoder import DecoderFactory

from handeye_pick.config.load import load_config
from handeye_pick.geometry import rotation_from_quaternion, ur_pose_to_matrix
from handeye_pick.record.channels import pose_of, scene_update

finite = st.floats(-3.0, 3.0, allow_nan=False)
_schema = Pose.get_schema()
_decode: Any = DecoderFactory().decoder_for(
    "protobuf", Schema(id=1, name=_schema.name, encoding=_schema.encoding, data=_schema.data)
)


@given(st.lists(finite, min_size=6, max_size=6))
def test_a_pose_goes_out_as_the_same_rotation_and_translation(pose: list[float]) -> None:
    T = ur_pose_to_matrix(pose)
    out = _decode(pose_of(T).encode())
    q = [out.orientation.x, out.orientation.y, out.orientation.z, out.orientation.w]
    np.testing.assert_allclose(rotation_from_quaternion(q, "xyzw"), T[:3, :3], atol=1e-9)
    p = out.position
    np.testing.assert_allclose([p.x, p.y, p.z], T[:3, 3], atol=0)


def test_the_scene_channel_draws_every_bin_wall_and_box_of_the_config() -> None:
    config = load_config(Path(__file__).resolve().parents[2] / "config" / "bin.yaml")
    assert config.scene is not None
    update = scene_update(config, 0)
    schema = update.get_schema()
    decode: Any = DecoderFactory().decoder_for(
        "protobuf", Schema(id=2, name=schema.name, encoding=schema.encoding, data=schema.data)
    )
    ids = [entity.id for entity in decode(update.encode()).entities]
    assert ids[0] == "workspace"
    walls = {
        f"bin '{b.name}' wall '{w}'"
        for b in config.scene.bins
        for w in ("east", "west", "north", "south")
    }
    assert walls <= set(ids)
    assert {f"box '{b.name}'" for b in config.scene.boxes} <= set(ids)
