"""The line's OPC UA server (``run --opcua [HOST:]PORT``), on a thread and event loop of its own.

asyncua is imported here only, and this module only when ``--opcua`` is given, so every other
command starts without it. The server never touches the robot: it reads the line state
(``line.state.Line``) every ``PUBLISH_S`` into its variables and turns method calls into line
commands, run on a worker thread so a slow one (a resume waits for the cell) never blocks
other clients. It is bounded (``MAX_SESSIONS``, ``MAX_SUBSCRIPTIONS``, ``MAX_QUEUE``,
``MAX_PENDING_MESSAGES``, ``MIN_PUBLISHING_MS``); whatever ends it (a defect, a client that
breaks it) ends only the server, with one warning line, never the cell.

asyncua ships no companion nodesets (no DI, no Machinery in its package), so the machine's
nodes are built here after OPC 40001-1: ``Machines/<cell>`` with ``Identification``,
``MachineryBuildingBlocks/MachineryItemState`` and ``.../MachineryOperationMode`` (each a
``CurrentState`` text and a ``StateNumber``), plus the line's own ``Line`` object with the
counters, the last error and the methods. The node tree: docs/line.md.

Security: without users (loopback only) every client may read and call. With users
(``--opcua-users``; a remote address requires them) the only endpoint is Basic256Sha256
SignAndEncrypt with a self-signed certificate kept next to the users file, user names are
checked against their scrypt hashes, and anonymous clients may read but never call.
"""

from __future__ import annotations

import asyncio
import contextlib
import contextvars
import logging
import os
import socket
import threading
from collections.abc import Awaitable, Callable
from pathlib import Path
from typing import Any

from asyncua import ua
from asyncua.common.node import Node
from asyncua.crypto import cert_gen
from asyncua.crypto.permission_rules import USER_TYPES, SimpleRoleRuleset, UserRole
from asyncua.crypto.permission_rules import User as UaUser
from asyncua.server.server import Server
from asyncua.server.user_managers import UserManager
from asyncua.ua.object_ids import ObjectIds
from asyncua.ua.status_codes import StatusCodes
from cryptography.x509.oid import ExtendedKeyUsageOID

from handeye_pick.errors import InputError
from handeye_pick.line.counters import OUTCOMES
from handeye_pick.line.state import CommandResult, Line
from handeye_pick.line.users import User

log = logging.getLogger(__name__)

NAMESPACE = "urn:handeye-pick:line"
PUBLISH_S = 0.25
"""How often the variables are brought up to date from the line state."""
MAX_SESSIONS = 8
MAX_SUBSCRIPTIONS = 32
MAX_QUEUE = 100
MAX_PENDING_MESSAGES = 50
MIN_PUBLISHING_MS = 250.0
"""The fastest publishing interval a subscription gets (a faster one is revised to this): the
values change at most every ``PUBLISH_S``, and a client asking for 10 ms would only make the
server wake 100 times a second for nothing."""
START_TIMEOUT_S = 30.0
_CALLER: contextvars.ContextVar[str] = contextvars.ContextVar("caller", default="anonymous")


def _node_id(number: int) -> ua.NodeId:
    """A namespace-0 node id of the standard (``ObjectIds``)."""
    return ua.NodeId(ua.Int32(number))


_CALL = _node_id(ObjectIds.CallRequest_Encoding_DefaultBinary)
_WRITE = _node_id(ObjectIds.WriteRequest_Encoding_DefaultBinary)
_READ_TYPES = frozenset(_node_id(t) for t in USER_TYPES) - {_CALL, _WRITE}


class _Users(UserManager):
    """Anonymous: a reader. A known name with its password: a user. Anything else: refused."""

    def __init__(self, users: dict[str, User]) -> None:
        self._users = users

    def get_user(self, iserver: Any, username: str | None = None, password: str | None = None,
                 certificate: Any = None) -> UaUser | None:
        if username is None:
            return UaUser(role=UserRole.Anonymous)
        user = self._users.get(username)
        if user is None or password is None or not user.accepts(password):
            log.warning("OPC UA: refused user %r (unknown name or wrong password)", username)
            return None
        return UaUser(role=UserRole.User, name=username)


class _Rules(SimpleRoleRuleset):
    """Readers read, browse and subscribe; only users call. Notes who asks, for the audit:
    the check runs in the task that then serves the request."""

    def __init__(self, users_required: bool) -> None:
        super().__init__()  # type: ignore[no-untyped-call]  # asyncua's own is untyped
        self._users_required = users_required

    def check_validity(self, user: Any, action_type: Any, body: Any) -> bool:
        name = getattr(user, "name", None)
        role = getattr(user, "role", UserRole.Anonymous)
        _CALLER.set(f"OPC UA user {name}" if name else "OPC UA anonymous client")
        if action_type == _WRITE:
            return False  # every variable is the cell's: read-only
        if action_type == _CALL:
            return role in (UserRole.User, UserRole.Admin) or not self._users_required
        return action_type in _READ_TYPES or role in (UserRole.User, UserRole.Admin)


class LineServer:
    """The OPC UA server of ``line`` on ``host:port``; ``users`` None: open (loopback only).

    ``identity``: product, version, robot host and model, cell config (Identification)."""

    def __init__(self, line: Line, host: str, port: int, users: dict[str, User] | None,
                 cert_dir: Path | None, identity: dict[str, str]) -> None:
        self.line = line
        self.host, self.port = host, port
        self.users = users
        self.cert_dir = cert_dir
        self.identity = identity
        self.bound_port: int | None = None
        self._ready = threading.Event()
        self._failure: str | None = None
        self._loop: asyncio.AbstractEventLoop | None = None
        self._stop: asyncio.Event | None = None
        self._thread = threading.Thread(target=self._run, name="opcua", daemon=True)

    @property
    def url(self) -> str:
        host = f"[{self.host}]" if ":" in self.host else self.host
        return f"opc.tcp://{host}:{self.bound_port}"

    def start(self) -> LineServer:
        """Start and wait until it listens; InputError (exit 2) when it cannot. asyncua's own
        log is kept to errors: a client refused at a bound would otherwise write a line each
        time it tries."""
        logging.getLogger("asyncua").setLevel(logging.ERROR)
        self._thread.start()
        if not self._ready.wait(START_TIMEOUT_S):
            raise InputError(f"run --opcua: the server did not start within {START_TIMEOUT_S} s")
        if self._failure is not None:
            raise InputError(f"run --opcua {self.host}:{self.port}: {self._failure}")
        return self

    def close(self) -> None:
        loop, stop = self._loop, self._stop
        if loop is not None and stop is not None and not loop.is_closed():
            with contextlib.suppress(RuntimeError):  # the loop ended already
                loop.call_soon_threadsafe(stop.set)
        self._thread.join(timeout=5.0)

    def _run(self) -> None:
        try:
            asyncio.run(self._serve())
        except Exception as exc:  # whatever ends the server ends only the server
            if not self._ready.is_set():
                self._failure = _one_line(exc)
                self._ready.set()
            else:
                log.warning("OPC UA server stopped (%s); the cell goes on without it",
                            _one_line(exc))

    async def _serve(self) -> None:
        self._loop, self._stop = asyncio.get_running_loop(), asyncio.Event()
        server = await self._server()
        nodes = await _Nodes.build(server, self)
        async with server:
            self.bound_port = server.bserver.port if server.bserver is not None else self.port
            self._ready.set()
            while not self._stop.is_set():
                await nodes.publish(self.line)
                with contextlib.suppress(asyncio.TimeoutError):
                    await asyncio.wait_for(self._stop.wait(), PUBLISH_S)

    async def _server(self) -> Server:
        server = Server(user_manager=_Users(self.users) if self.users is not None else None)
        await server.init()
        iserver = server.iserver
        iserver.max_connections = MAX_SESSIONS
        iserver.max_subscriptions = MAX_SUBSCRIPTIONS
        iserver.max_monitored_item_queue_size = MAX_QUEUE
        iserver.max_pending_messages_per_connection = MAX_PENDING_MESSAGES
        iserver.max_unacked_messages_per_subscription = MAX_QUEUE
        _slow_publishing(iserver.subscription_service)
        host = f"[{self.host}]" if ":" in self.host else self.host
        server.set_endpoint(f"opc.tcp://{host}:{self.port}/")
        server.set_server_name(f"handeye-pick {self.identity.get('cell', '')}".strip())
        await server.set_application_uri(NAMESPACE)
        rules = _Rules(users_required=self.users is not None)
        if self.users is None:
            server.set_security_policy([ua.SecurityPolicyType.NoSecurity], rules)
            server.set_identity_tokens([ua.AnonymousIdentityToken])
        else:
            await self._certificate(server)
            server.set_security_policy(
                [ua.SecurityPolicyType.Basic256Sha256_SignAndEncrypt], rules
            )
            server.set_identity_tokens([ua.AnonymousIdentityToken, ua.UserNameIdentityToken])
        return server

    async def _certificate(self, server: Server) -> None:
        """A self-signed certificate kept in ``cert_dir`` (made once, key readable by the
        owner only), so clients can trust it once."""
        folder = self.cert_dir if self.cert_dir is not None else Path.cwd()
        key, cert = folder / "opcua-server-key.pem", folder / "opcua-server-cert.der"
        await cert_gen.setup_self_signed_certificate(
            key, cert, NAMESPACE, socket.gethostname(),
            [ExtendedKeyUsageOID.SERVER_AUTH, ExtendedKeyUsageOID.CLIENT_AUTH],
            {"commonName": "handeye-pick line"},
        )
        os.chmod(key, 0o600)
        await server.load_certificate(str(cert))
        await server.load_private_key(str(key))


class _Nodes:
    """The address space of the cell and the values last written to it."""

    def __init__(self, idx: int) -> None:
        self.idx = idx
        self.variables: dict[str, Node] = {}
        self.written: dict[str, object] = {}

    @classmethod
    async def build(cls, server: Server, owner: LineServer) -> _Nodes:
        idx = await server.register_namespace(NAMESPACE)
        nodes = cls(idx)
        objects = server.nodes.objects
        machines = await objects.add_folder(idx, "Machines")
        machine = await machines.add_object(idx, owner.identity.get("cell", "cell"))
        ident = await machine.add_object(idx, "Identification")
        for name, value in owner.identity.items():
            await ident.add_variable(idx, _camel(name), value, ua.VariantType.String)
        blocks = await machine.add_object(idx, "MachineryBuildingBlocks")
        for block in ("MachineryItemState", "MachineryOperationMode"):
            state = await blocks.add_object(idx, block)
            await nodes._variable(state, f"{block}.CurrentState", "CurrentState",
                                  ua.LocalizedText(""), ua.VariantType.LocalizedText)
            await nodes._variable(state, f"{block}.StateNumber", "StateNumber", 0,
                                  ua.VariantType.UInt32)
        line = await machine.add_object(idx, "Line")
        for name, initial, kind in _LINE_VARIABLES:
            await nodes._variable(line, name, name, initial, kind)
        counters = await line.add_object(idx, "Counters")
        for name, initial, kind in _COUNTER_VARIABLES:
            await nodes._variable(counters, name, name, initial, kind)
        outputs = [ua.Argument(Name="Status", DataType=_node_id(ObjectIds.StatusCode),
                               ValueRank=-1),
                   ua.Argument(Name="Text", DataType=_node_id(ObjectIds.String),
                               ValueRank=-1)]
        for method, command in _methods(owner.line).items():
            await line.add_method(idx, method, _callback(command), [], outputs)
        return nodes

    async def _variable(self, parent: Node, key: str, name: str, initial: object,
                        kind: ua.VariantType) -> None:
        self.variables[key] = await parent.add_variable(self.idx, name, initial, kind)

    async def publish(self, line: Line) -> None:
        """Write every value that changed since the last look."""
        values = await asyncio.to_thread(_values, line)
        for key, (value, kind) in values.items():
            if self.written.get(key) != value:
                await self.variables[key].write_value(ua.Variant(value, kind))
                self.written[key] = value


_U32, _DBL, _STR, _BOOL = (ua.VariantType.UInt32, ua.VariantType.Double, ua.VariantType.String,
                           ua.VariantType.Boolean)
_LINE_VARIABLES: tuple[tuple[str, object, ua.VariantType], ...] = (
    ("Held", False, _BOOL), ("HeldBy", "", _STR), ("HaltedReason", "", _STR),
    ("RequestId", "", _STR), ("RequestStep", "", _STR), ("Heartbeat", 0, _U32),
    ("LastErrorCode", 0, _U32), ("LastErrorText", "", _STR),
)
_COUNTER_VARIABLES: tuple[tuple[str, object, ua.VariantType], ...] = (
    *((_camel_status, 0, _U32) for _camel_status in
      ("".join(w.capitalize() for w in o.split("-")) for o in OUTCOMES)),
    ("Cycles", 0, _U32), ("CycleTimeLast", 0.0, _DBL), ("CycleTimeMedian", 0.0, _DBL),
    ("PicksPerHour", 0.0, _DBL), ("HaltedSeconds", 0.0, _DBL), ("HeldSeconds", 0.0, _DBL),
)


def _slow_publishing(service: Any) -> None:
    """Revise every new subscription's publishing interval up to ``MIN_PUBLISHING_MS`` (asyncua
    takes the client's as asked)."""
    create = service.create_subscription

    async def bounded(params: Any, *args: Any, **kwargs: Any) -> Any:
        interval = params.RequestedPublishingInterval
        params.RequestedPublishingInterval = max(float(interval or 0.0), MIN_PUBLISHING_MS)
        return await create(params, *args, **kwargs)

    service.create_subscription = bounded


def _values(line: Line) -> dict[str, tuple[object, ua.VariantType]]:
    """Every variable's value now (on a worker thread: reading the audit file may take a
    moment)."""
    view, counts = line.view(), line.counts()
    request = view.request or {}
    values: dict[str, tuple[object, ua.VariantType]] = {
        "MachineryItemState.CurrentState": (ua.LocalizedText(view.state.title),
                                            ua.VariantType.LocalizedText),
        "MachineryItemState.StateNumber": (int(view.state), _U32),
        "MachineryOperationMode.CurrentState": (ua.LocalizedText(view.mode.title),
                                                ua.VariantType.LocalizedText),
        "MachineryOperationMode.StateNumber": (int(view.mode), _U32),
        "Held": (view.held, _BOOL),
        "HeldBy": (view.held_by or "", _STR),
        "HaltedReason": (view.halted_reason or "", _STR),
        "RequestId": (str(request.get("id", "") or ""), _STR),
        "RequestStep": (str(request.get("step", "") or ""), _STR),
        "Heartbeat": (view.heartbeat_s, _U32),
        "LastErrorCode": (counts.last_error.code, _U32),
        "LastErrorText": (counts.last_error.text, _STR),
        "Cycles": (counts.cycles, _U32),
        "CycleTimeLast": (counts.cycle_last_s or 0.0, _DBL),
        "CycleTimeMedian": (counts.cycle_median_s or 0.0, _DBL),
        "PicksPerHour": (round(counts.picks_per_hour, 3), _DBL),
        "HaltedSeconds": (round(counts.halted_s, 3), _DBL),
        "HeldSeconds": (round(line.held_s(), 3), _DBL),
    }
    for outcome, count in counts.outcomes.items():
        values["".join(w.capitalize() for w in outcome.split("-"))] = (count, _U32)
    return values


def _methods(line: Line) -> dict[str, Callable[[str], CommandResult]]:
    return {"CycleStop": line.cycle_stop, "Release": line.release, "Stop": line.stop,
            "Resume": line.resume}


def _callback(command: Callable[[str], CommandResult]) -> Callable[..., Awaitable[list[Any]]]:
    async def call(parent: Any, *args: Any) -> list[Any]:
        result = await asyncio.to_thread(command, _CALLER.get())
        number = StatusCodes.Good if result.ok else StatusCodes.BadInvalidState
        code = ua.StatusCode(ua.UInt32(number))
        return [ua.Variant(code, ua.VariantType.StatusCode),
                ua.Variant(result.text, ua.VariantType.String)]

    return call


def _camel(name: str) -> str:
    return "".join(word.capitalize() for word in name.replace("-", "_").split("_"))


def _one_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {text[0]}" if text else type(exc).__name__
