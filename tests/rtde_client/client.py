"""A small RTDE client written from UR's RTDE guide alone, to test the simulated controller with a
client that is not ur_rtde and shares no code with the simulator.

Protocol version 2 as the guide describes it: every package is a header (uint16 size including
the header, uint8 type) and a payload, big-endian. Setup requests are answered once each; after
START the controller streams DATA_PACKAGEs of the output recipe, each led by its recipe id; input
DATA_PACKAGEs carry the input recipe id and the values in recipe order.
"""

from __future__ import annotations

import socket
import struct
from dataclasses import dataclass
from typing import Any

RTDE_PORT = 30004
REQUEST_PROTOCOL_VERSION = b"V"
GET_URCONTROL_VERSION = b"v"
TEXT_MESSAGE = b"M"
DATA_PACKAGE = b"U"
SETUP_OUTPUTS = b"O"
SETUP_INPUTS = b"I"
START = b"S"
PAUSE = b"P"

# The guide's data types and their sizes: BOOL and UINT8 1 byte, UINT32 and INT32 4, UINT64 and
# DOUBLE 8, the vectors that many of those.
FORMATS = {"BOOL": "?", "UINT8": "B", "UINT32": "I", "UINT64": "Q", "INT32": "i", "DOUBLE": "d",
           "VECTOR3D": "3d", "VECTOR6D": "6d", "VECTOR6INT32": "6i", "VECTOR6UINT32": "6I"}


@dataclass(frozen=True)
class Recipe:
    """A recipe as the controller answered its setup: id (0 when refused), names and types."""

    recipe_id: int
    names: tuple[str, ...]
    types: tuple[str, ...]

    @property
    def accepted(self) -> bool:
        return self.recipe_id != 0 and not {"NOT_FOUND", "IN_USE"} & set(self.types)

    def layout(self) -> struct.Struct:
        return struct.Struct(">B" + "".join(FORMATS[t] for t in self.types))


class RtdeClient:
    """One connection to a controller's RTDE interface; a context manager."""

    def __init__(self, host: str, timeout_s: float = 5.0):
        self.sock = socket.create_connection((host, RTDE_PORT), timeout=timeout_s)
        self.sock.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.output: Recipe | None = None

    def __enter__(self) -> RtdeClient:
        return self

    def __exit__(self, *exc_info: object) -> None:
        self.close()

    def close(self) -> None:
        self.sock.close()

    # --- framing ----------------------------------------------------------------------------

    def send(self, kind: bytes, payload: bytes = b"") -> None:
        self.sock.sendall(struct.pack(">HB", 3 + len(payload), kind[0]) + payload)

    def _read(self, size: int) -> bytes:
        data = b""
        while len(data) < size:
            chunk = self.sock.recv(size - len(data))
            if not chunk:
                raise ConnectionError("the controller closed the connection")
            data += chunk
        return data

    def read_package(self) -> tuple[bytes, bytes]:
        size, kind = struct.unpack(">HB", self._read(3))
        return bytes([kind]), self._read(size - 3)

    def _reply(self, kind: bytes) -> bytes:
        """The next package of type `kind` (data packages that arrive first are skipped)."""
        while True:
            got, payload = self.read_package()
            if got == kind:
                return payload
            if got != DATA_PACKAGE:
                raise AssertionError(f"expected a {kind!r} reply, got {got!r}")

    # --- requests ---------------------------------------------------------------------------

    def request_protocol_version(self, version: int) -> bool:
        self.send(REQUEST_PROTOCOL_VERSION, struct.pack(">H", version))
        return self._reply(REQUEST_PROTOCOL_VERSION) == b"\x01"

    def controller_version(self) -> tuple[int, int, int, int]:
        self.send(GET_URCONTROL_VERSION)
        major, minor, bugfix, build = struct.unpack(">IIII", self._reply(GET_URCONTROL_VERSION))
        return major, minor, bugfix, build

    def setup_outputs(self, names: list[str], frequency_hz: float) -> Recipe:
        self.send(SETUP_OUTPUTS, struct.pack(">d", frequency_hz) + ",".join(names).encode())
        recipe = _recipe(names, self._reply(SETUP_OUTPUTS))
        if recipe.accepted:
            self.output = recipe
        return recipe

    def setup_inputs(self, names: list[str]) -> Recipe:
        self.send(SETUP_INPUTS, ",".join(names).encode())
        return _recipe(names, self._reply(SETUP_INPUTS))

    def start(self) -> bool:
        self.send(START)
        return self._reply(START) == b"\x01"

    def pause(self) -> bool:
        self.send(PAUSE)
        return self._reply(PAUSE) == b"\x01"

    def text_message(self, message: str, source: str = "rtde_client test") -> None:
        """A message for the controller's log; the guide defines no reply."""
        text, origin = message.encode(), source.encode()
        self.send(TEXT_MESSAGE, bytes([len(text)]) + text + bytes([len(origin)]) + origin
                  + bytes([1]))  # level 1: info

    def receive(self) -> dict[str, Any]:
        """The next output data package, as name -> value (vectors as tuples)."""
        if self.output is None:
            raise AssertionError("no output recipe set up")
        layout = self.output.layout()
        while True:
            kind, payload = self.read_package()
            if kind == DATA_PACKAGE:
                break
        values = layout.unpack(payload)
        assert values[0] == self.output.recipe_id
        result: dict[str, Any] = {}
        index = 1
        for name, type_ in zip(self.output.names, self.output.types, strict=True):
            count = int(FORMATS[type_][0]) if FORMATS[type_][0].isdigit() else 1
            result[name] = values[index] if count == 1 else tuple(values[index:index + count])
            index += count
        return result

    def write_inputs(self, recipe: Recipe, values: list[Any]) -> None:
        """One input data package: `values` in recipe order (vectors as sequences)."""
        flat: list[Any] = []
        for value in values:
            flat.extend(value if isinstance(value, (list, tuple)) else [value])
        self.send(DATA_PACKAGE, recipe.layout().pack(recipe.recipe_id, *flat))


def _recipe(names: list[str], reply: bytes) -> Recipe:
    types = tuple(reply[1:].decode().split(","))
    return Recipe(reply[0], tuple(names), types)
