"""RTDE protocol version 2 server (port 30004): framing, recipes, input claims, streaming.

Wire format (UR's RTDE guide; docs/ur-rtde.md, "RTDE wire format"): every package is `uint16 size`
(big-endian, header included) + `uint8 type` + payload. Setup requests (V, v, O, I, S, P) get
exactly one reply each, at once; text messages (M) from a client are logged, never answered.
After S a sender thread streams the output recipe at the requested frequency, at most the
control loop's: like a real controller's, each data package leaves right after the control cycle
that produced it, one package for every cycle due, none skipped. Field names and types are the
profile's (fields.py); any other name is answered NOT_FOUND.
"""

from __future__ import annotations

import logging
import socket
import struct
import threading
from collections import deque
from collections.abc import Mapping, Sequence
from typing import Protocol

from mocks.ur_controller.net import Listener, recv_exactly
from mocks.ur_controller.profiles import DEFAULT_PROFILE, PROFILES, Profile

log = logging.getLogger("mocks.ur_controller")

RTDE_PORT = 30004
PROTOCOL_VERSION = 2  # the only RTDE protocol version served; any other request is refused
RECENT_CYCLES = 500  # published cycles kept for late senders (1 s at 500 Hz, 4 s at 125 Hz)
STREAM_FALLBACK_S = 0.1
"""A sender that sees no control cycle this long after one was due sends the latest outputs
anyway: a starved control loop slows the stream but never pauses it towards ur_rtde's 2.5 s."""

_FORMATS = {
    "BOOL": "?",
    "UINT8": "B",
    "INT32": "i",
    "UINT32": "I",
    "UINT64": "Q",
    "DOUBLE": "d",
    "VECTOR3D": "3d",
    "VECTOR6D": "6d",
    "VECTOR6INT32": "6i",
    "VECTOR6UINT32": "6I",
}
_VECTOR_SIZES = {"VECTOR3D": 3, "VECTOR6D": 6, "VECTOR6INT32": 6, "VECTOR6UINT32": 6}


def package(kind: bytes, payload: bytes) -> bytes:
    """One RTDE package: size (header included), type byte, payload."""
    return struct.pack(">HB", len(payload) + 3, kind[0]) + payload


def recipe_struct(types: Sequence[str]) -> struct.Struct:
    """Struct for a data package body: recipe id byte, then each field big-endian."""
    return struct.Struct(">B" + "".join(_FORMATS[t] for t in types))


def flatten(values: Sequence[object]) -> list[object]:
    """Vectors become their elements, scalars stay: the argument list for a recipe struct."""
    flat: list[object] = []
    for value in values:
        if isinstance(value, (tuple, list)):
            flat.extend(value)
        else:
            flat.append(value)
    return flat


class RtdeBackend(Protocol):
    """What the RTDE server needs from the controller."""

    def latest_outputs(self) -> Mapping[str, object]:
        """Every output variable's value as of the last control cycle."""

    def write_inputs(self, values: Mapping[str, object]) -> None:
        """Input fields written by one client data package, applied together."""

    def take_refused_start(self) -> bool:
        """True once if the next start request must be refused (fault refuse-start)."""

    def stream_stalled(self) -> bool:
        """True while the data stream must pause (fault stall:SECONDS)."""


class _Recipe:
    def __init__(self, names: list[str], types: list[str]):
        self.names = names
        self.types = types
        self.struct = recipe_struct(types)


class _Connection:
    """One client on 30004: its recipes, input claims and (after S) its sender thread."""

    def __init__(self, sock: socket.socket, frequency_hz: float):
        self.sock = sock
        self.send_lock = threading.Lock()  # replies and data packages never interleave
        self.inputs: dict[int, _Recipe] = {}
        self.output: _Recipe | None = None
        self.frequency_hz = frequency_hz
        self.streaming = threading.Event()
        self.closed = threading.Event()
        self.sender: threading.Thread | None = None

    def send(self, data: bytes) -> None:
        with self.send_lock:
            self.sock.sendall(data)


class RtdeServer:
    """Serves RTDE on (host, 30004) for any number of clients."""

    def __init__(self, host: str, backend: RtdeBackend,
                 profile: Profile = PROFILES[DEFAULT_PROFILE]):
        self._backend = backend
        self._profile = profile
        self._claims: dict[str, _Connection] = {}
        self._claims_lock = threading.Lock()
        self._cycle = 0  # number (controller time / period) of the latest published cycle
        self._recent: deque[tuple[int, Mapping[str, object]]] = deque(maxlen=RECENT_CYCLES)
        self._cycle_done = threading.Condition()
        self.listener = Listener(host, RTDE_PORT, "rtde", self._serve)

    def _serve(self, sock: socket.socket) -> None:
        conn = _Connection(sock, self._profile.cycle_hz)
        try:
            while True:
                size, kind = struct.unpack(">HB", recv_exactly(sock, 3))
                if size < 3:
                    raise ConnectionError(f"RTDE package header says size {size}, minimum is 3")
                self._handle(conn, bytes([kind]), recv_exactly(sock, size - 3))
        except ConnectionError:
            pass  # client disconnected, or drop_clients() closed the socket
        finally:
            conn.closed.set()
            with self._cycle_done:
                self._cycle_done.notify_all()  # its sender returns now, not at the next cycle
            with self._claims_lock:
                for name in [n for n, owner in self._claims.items() if owner is conn]:
                    del self._claims[name]
            if conn.sender is not None:
                conn.sender.join(timeout=1.0)

    def _handle(self, conn: _Connection, kind: bytes, payload: bytes) -> None:
        if kind == b"V":
            (version,) = struct.unpack_from(">H", payload) if len(payload) >= 2 else (0,)
            accepted = version == PROTOCOL_VERSION
            if not accepted:
                log.warning("rtde: refusing protocol version %d (serving %d)", version,
                            PROTOCOL_VERSION)
            conn.send(package(b"V", bytes([accepted])))
        elif kind == b"v":
            conn.send(package(b"v", struct.pack(">IIII", *self._profile.version)))
        elif kind == b"M":
            log.info("rtde: text message from a client: %r", payload)
        elif kind == b"O":
            self._setup_outputs(conn, payload)
        elif kind == b"I":
            self._setup_inputs(conn, payload)
        elif kind == b"S":
            self._start(conn)
        elif kind == b"P":
            conn.streaming.clear()
            conn.send(package(b"P", b"\x01"))
        elif kind == b"U":
            self._receive_inputs(conn, payload)
        else:
            log.warning("rtde: ignoring package type %r (%d bytes)", kind, len(payload))

    def _setup_outputs(self, conn: _Connection, payload: bytes) -> None:
        (frequency_hz,) = struct.unpack_from(">d", payload)
        names = [n for n in payload[8:].decode("ascii").split(",") if n]
        types = [self._profile.output_types.get(name, "NOT_FOUND") for name in names]
        if "NOT_FOUND" not in types:
            conn.output = _Recipe(names, types)
            conn.frequency_hz = frequency_hz if frequency_hz > 0 else self._profile.cycle_hz
        else:
            missing = [n for n, t in zip(names, types, strict=True) if t == "NOT_FOUND"]
            log.warning("rtde: output names not found: %s", missing)
        conn.send(package(b"O", b"\x01" + ",".join(types).encode("ascii")))

    def _setup_inputs(self, conn: _Connection, payload: bytes) -> None:
        names = [n for n in payload.decode("ascii").split(",") if n]
        types = [self._profile.input_types.get(name, "NOT_FOUND") for name in names]
        with self._claims_lock:
            for i, name in enumerate(names):
                owner = self._claims.get(name)
                if owner is not None and owner is not conn:
                    types[i] = "IN_USE"
            usable = "IN_USE" not in types and "NOT_FOUND" not in types
            if usable:
                for name in names:
                    self._claims[name] = conn
        if usable:
            # ur_rtde hard-codes input recipe ids 1, 2, 3... in request order per connection.
            recipe_id = len(conn.inputs) + 1
            conn.inputs[recipe_id] = _Recipe(names, types)
        else:
            recipe_id = 0
            log.warning("rtde: input recipe refused: %s", dict(zip(names, types, strict=True)))
        conn.send(package(b"I", bytes([recipe_id]) + ",".join(types).encode("ascii")))

    def _start(self, conn: _Connection) -> None:
        if self._backend.take_refused_start() or conn.output is None:
            log.warning("rtde: refusing start request (fault or no output recipe)")
            conn.send(package(b"S", b"\x00"))
            return
        conn.send(package(b"S", b"\x01"))
        conn.streaming.set()
        if conn.sender is None:
            conn.sender = threading.Thread(
                target=self._stream, args=(conn,), name="rtde-sender", daemon=True
            )
            conn.sender.start()

    def _receive_inputs(self, conn: _Connection, payload: bytes) -> None:
        recipe = conn.inputs.get(payload[0]) if payload else None
        if recipe is None or len(payload) < recipe.struct.size:
            expected = "unknown recipe" if recipe is None else f"{recipe.struct.size} bytes"
            log.warning(
                "rtde: dropping malformed data package: recipe %s, %d bytes, expected %s",
                payload[0] if payload else None, len(payload), expected,
            )
            return
        if len(payload) > recipe.struct.size:
            # ur_rtde 1.6.5 sends getForwardKinematics(q, tcp) as recipe 6 with 12 doubles.
            # Dropping it would hang the client for 300 s; the recipe's own fields are applied.
            log.warning(
                "rtde: data package for recipe %d has %d bytes, recipe needs %d: extra bytes "
                "ignored", payload[0], len(payload), recipe.struct.size,
            )
        values = recipe.struct.unpack_from(payload)[1:]
        fields: dict[str, object] = {}
        index = 0
        for name, kind in zip(recipe.names, recipe.types, strict=True):
            count = _VECTOR_SIZES.get(kind, 1)
            fields[name] = values[index] if count == 1 else tuple(values[index : index + count])
            index += count
        self._backend.write_inputs(fields)

    def cycle_done(self, cycle: int | None = None) -> None:
        """Wake the senders: called by the control loop right after each cycle's publish, with
        the cycle's number in controller time (default: the previous number + 1).

        Keeps that cycle's outputs for the senders and only notifies; the senders send on their
        own threads, so a slow client socket never holds up the control loop.
        """
        with self._cycle_done:
            self._cycle = self._cycle + 1 if cycle is None else cycle
            self._recent.append((self._cycle, self._backend.latest_outputs()))
            self._cycle_done.notify_all()

    def _wait_for_cycle(self, conn: _Connection, after: int,
                        timeout_s: float) -> list[tuple[int, Mapping[str, object]]]:
        """Wait until a cycle later than ``after`` is published, the connection closes or
        ``timeout_s`` passes; returns the recent cycles later than ``after``, oldest first."""
        with self._cycle_done:
            self._cycle_done.wait_for(
                lambda: self._cycle > after or conn.closed.is_set(), timeout=timeout_s
            )
            newer: list[tuple[int, Mapping[str, object]]] = []
            for n, outputs in reversed(self._recent):  # newest first: stop at the first seen
                if n <= after:
                    break
                newer.append((n, outputs))
            newer.reverse()
            return newer

    def _stream(self, conn: _Connection) -> None:
        """Send the output recipe of every Nth control cycle until the connection closes.

        N = control loop frequency / requested frequency, rounded, at least 1: on e-Series a
        500 Hz client gets every cycle, a 125 Hz one the cycles whose number is a multiple of 4.
        A sender that fell behind (descheduled, or the loop ran cycles back to back to catch up)
        sends every due cycle it missed, oldest first, in one write: each package keeps its own
        timestamp and none is skipped while the sender is less than RECENT_CYCLES behind. With
        no cycle at all for a while it resends the latest outputs (see STREAM_FALLBACK_S).
        """
        cycle_hz = self._profile.cycle_hz
        every = max(1, round(cycle_hz / conn.frequency_hz))
        timeout_s = every / cycle_hz + STREAM_FALLBACK_S
        seen = self._cycle
        while not conn.closed.is_set():
            new = self._wait_for_cycle(conn, seen, timeout_s)
            if conn.closed.is_set():
                return
            if new:
                seen = new[-1][0]
                due = [outputs for n, outputs in new if n % every == 0]
            else:
                due = [self._backend.latest_outputs()]  # no cycle came: the loop is starved
            recipe = conn.output
            if (not due or recipe is None or not conn.streaming.is_set()
                    or self._backend.stream_stalled()):
                continue
            data = b"".join(
                package(b"U", recipe.struct.pack(1, *flatten([out[name] for name in recipe.names])))
                for out in due
            )
            try:
                conn.send(data)
            except OSError:
                return
