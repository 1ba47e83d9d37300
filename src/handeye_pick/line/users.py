"""The OPC UA server's users (``run --opcua-users FILE``): names and scrypt-hashed passwords.

One user a line, ``NAME:scrypt:N:r:p:SALT_HEX:HASH_HEX``; blank lines and lines starting with
``#`` are skipped. Passwords are never stored: only scrypt (``hashlib.scrypt``, a memory-hard
key derivation) of the password with a random 16-byte salt. A line is added with::

    python -m handeye_pick.line.users FILE NAME      # asks for the password twice

A user whose password matches may call the server's methods; anonymous clients only read.
"""

from __future__ import annotations

import getpass
import hashlib
import hmac
import os
import sys
from dataclasses import dataclass
from pathlib import Path

from handeye_pick.errors import InputError

SCRYPT_N, SCRYPT_R, SCRYPT_P = 2**14, 8, 1  # about 16 MB and 30-60 ms a check
# scrypt needs 128 * r * N bytes: a users line asking for more is refused when the file is
# read, so that a sign-in never fails on OpenSSL's memory cap (MAX_SCRYPT_BYTES, with room).
MAX_USER_SCRYPT_BYTES = 128 * 1024 * 1024
MAX_SCRYPT_BYTES = 2 * MAX_USER_SCRYPT_BYTES
HASH_BYTES = 32
MAX_FILE_BYTES = 1_000_000
MIN_PASSWORD_CHARS = 8


@dataclass(frozen=True)
class User:
    """One user: a name and the scrypt parameters, salt and hash of its password."""

    name: str
    n: int
    r: int
    p: int
    salt: bytes
    digest: bytes

    def accepts(self, password: str) -> bool:
        """Whether ``password`` is this user's (compared in constant time)."""
        given = hashlib.scrypt(
            password.encode("utf-8"), salt=self.salt, n=self.n, r=self.r, p=self.p,
            dklen=len(self.digest), maxmem=MAX_SCRYPT_BYTES,
        )
        return hmac.compare_digest(given, self.digest)


def hashed_line(name: str, password: str) -> str:
    """The users-file line for ``name`` with ``password`` hashed under a fresh salt."""
    if not name or ":" in name or name.strip() != name:
        raise InputError(f"user name {name!r}: expected a non-empty name without ':' or spaces")
    if len(password) < MIN_PASSWORD_CHARS:
        raise InputError(f"password of {name}: at least {MIN_PASSWORD_CHARS} characters")
    salt = os.urandom(16)
    digest = hashlib.scrypt(
        password.encode("utf-8"), salt=salt, n=SCRYPT_N, r=SCRYPT_R, p=SCRYPT_P, dklen=HASH_BYTES
    )
    return f"{name}:scrypt:{SCRYPT_N}:{SCRYPT_R}:{SCRYPT_P}:{salt.hex()}:{digest.hex()}"


def read_users(path: Path) -> dict[str, User]:
    """Every user of the file at ``path``; InputError (one line, exit 2) naming the line."""
    try:
        with path.open("rb") as file:
            data = file.read(MAX_FILE_BYTES + 1)
    except OSError as exc:
        raise InputError(f"--opcua-users {path}: cannot read ({exc.strerror or exc})") from None
    if len(data) > MAX_FILE_BYTES:
        raise InputError(f"--opcua-users {path}: longer than {MAX_FILE_BYTES} bytes")
    users: dict[str, User] = {}
    for number, line in enumerate(data.decode("utf-8", errors="replace").splitlines(), 1):
        if not line.strip() or line.startswith("#"):
            continue
        user = _user(line.strip())
        if user is None:
            raise InputError(
                f"--opcua-users {path} line {number}: expected NAME:scrypt:N:r:p:SALT:HASH "
                "(write it with python -m handeye_pick.line.users FILE NAME)"
            )
        users[user.name] = user
    if not users:
        raise InputError(f"--opcua-users {path}: no users in the file")
    return users


def _user(line: str) -> User | None:
    parts = line.split(":")
    if len(parts) != 7 or parts[1] != "scrypt" or not parts[0]:
        return None
    try:
        n, r, p = int(parts[2]), int(parts[3]), int(parts[4])
        salt, digest = bytes.fromhex(parts[5]), bytes.fromhex(parts[6])
    except ValueError:
        return None
    if not (2 <= n <= 2**20 and 1 <= r <= 32 and 1 <= p <= 16 and salt and len(digest) >= 16):
        return None
    if 128 * r * n > MAX_USER_SCRYPT_BYTES:
        return None
    return User(parts[0], n, r, p, salt, digest)


def main(argv: list[str]) -> int:
    """``python -m handeye_pick.line.users FILE NAME``: append NAME with a typed password."""
    if len(argv) != 2:
        print("usage: python -m handeye_pick.line.users FILE NAME", file=sys.stderr)
        return 2
    path, name = Path(argv[0]), argv[1]
    password = getpass.getpass(f"password for {name}: ")
    if getpass.getpass("again: ") != password:
        print("the passwords differ; nothing written", file=sys.stderr)
        return 2
    try:
        line = hashed_line(name, password)
    except InputError as exc:
        print(exc, file=sys.stderr)
        return 2
    fd = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o600)
    with os.fdopen(fd, "a", encoding="utf-8") as file:
        file.write(line + "\n")
    print(f"{name} added to {path}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
