"""The OPC UA server's users file (``handeye_pick.line.users``): what it accepts, what it
refuses and says, and the command that appends a user."""

from __future__ import annotations

import hashlib
import stat
from pathlib import Path

import pytest

from handeye_pick.errors import InputError
from handeye_pick.line import users
from handeye_pick.line.users import (
    MAX_FILE_BYTES,
    SCRYPT_N,
    SCRYPT_P,
    SCRYPT_R,
    User,
    hashed_line,
    read_users,
)

PASSWORD = "correct horse"


def _file(tmp_path: Path, *lines: str) -> Path:
    path = tmp_path / "users"
    path.write_text("".join(line + "\n" for line in lines))
    return path


def test_a_hashed_line_holds_scrypt_parameters_a_fresh_salt_and_no_password() -> None:
    line = hashed_line("alice", PASSWORD)
    name, kind, n, r, p, salt, digest = line.split(":")
    assert (name, kind, int(n), int(r), int(p)) == ("alice", "scrypt", SCRYPT_N, SCRYPT_R, SCRYPT_P)
    assert (len(bytes.fromhex(salt)), len(bytes.fromhex(digest))) == (16, 32)
    assert PASSWORD not in line
    assert hashed_line("alice", PASSWORD).split(":")[5] != salt  # a new salt each time


def test_only_the_right_password_is_accepted(tmp_path: Path) -> None:
    read = read_users(_file(tmp_path, hashed_line("alice", PASSWORD), hashed_line("bob", "x" * 8)))
    assert sorted(read) == ["alice", "bob"]
    alice = read["alice"]
    assert isinstance(alice, User)
    assert (alice.name, alice.n, alice.r, alice.p) == ("alice", SCRYPT_N, SCRYPT_R, SCRYPT_P)
    assert alice.accepts(PASSWORD)
    assert not alice.accepts(PASSWORD + " ")
    assert not alice.accepts("x" * 8)
    assert read["bob"].accepts("x" * 8)


@pytest.mark.parametrize(
    ("name", "password", "message"),
    [
        ("", PASSWORD, "user name '': expected a non-empty name without ':' or spaces"),
        ("a:b", PASSWORD, "user name 'a:b': expected a non-empty name without ':' or spaces"),
        (" al", PASSWORD, "user name ' al': expected a non-empty name without ':' or spaces"),
        ("al ", PASSWORD, "user name 'al ': expected a non-empty name without ':' or spaces"),
        ("alice", "1234567", "password of alice: at least 8 characters"),
    ],
)
def test_a_bad_name_or_short_password_is_refused(name: str, password: str, message: str) -> None:
    with pytest.raises(InputError) as info:
        hashed_line(name, password)
    assert str(info.value) == message


def test_comments_and_blank_lines_are_skipped(tmp_path: Path) -> None:
    path = _file(tmp_path, "# the line's operators", "", "   ", hashed_line("alice", PASSWORD))
    assert list(read_users(path)) == ["alice"]


def _broken(line: str) -> list[str]:
    """Ways to spoil a good users line, each to be refused."""
    name, kind, n, r, p, salt, digest = line.split(":")
    return [
        f"{name}:{kind}:{n}:{r}:{p}:{salt}",  # six fields
        f"{line}:extra",  # eight
        f"{name}:sha256:{n}:{r}:{p}:{salt}:{digest}",  # not scrypt
        f":{kind}:{n}:{r}:{p}:{salt}:{digest}",  # no name
        f"{name}:{kind}:x:{r}:{p}:{salt}:{digest}",  # not a number
        f"{name}:{kind}:{n}:{r}:{p}:zz:{digest}",  # not hex
        f"{name}:{kind}:1:{r}:{p}:{salt}:{digest}",  # n below 2
        f"{name}:{kind}:{2**20 + 1}:{r}:{p}:{salt}:{digest}",  # n above 2^20
        f"{name}:{kind}:{n}:0:{p}:{salt}:{digest}",  # r below 1
        f"{name}:{kind}:{n}:33:{p}:{salt}:{digest}",  # r above 32
        f"{name}:{kind}:{n}:{r}:0:{salt}:{digest}",  # p below 1
        f"{name}:{kind}:{n}:{r}:17:{salt}:{digest}",  # p above 16
        f"{name}:{kind}:{n}:{r}:{p}::{digest}",  # no salt
        f"{name}:{kind}:{n}:{r}:{p}:{salt}:{digest[:30]}",  # a 15-byte hash
        f"{name}:{kind}:{2**18}:8:{p}:{salt}:{digest}",  # 256 MiB of scrypt
    ]


def test_every_malformed_line_is_refused_naming_its_number(tmp_path: Path) -> None:
    good = hashed_line("alice", PASSWORD)
    for broken in _broken(good):
        path = _file(tmp_path, "# users", good, broken)
        with pytest.raises(InputError) as info:
            read_users(path)
        assert str(info.value) == (
            f"--opcua-users {path} line 3: expected NAME:scrypt:N:r:p:SALT:HASH "
            "(write it with python -m handeye_pick.line.users FILE NAME)"
        ), broken


def test_the_bounds_themselves_are_accepted(tmp_path: Path) -> None:
    _, kind, _, _, _, salt, digest = hashed_line("alice", PASSWORD).split(":")
    lines = [
        f"a:{kind}:2:1:1:{salt}:{digest[:32]}",
        f"b:{kind}:{2**20}:1:16:{salt}:{digest}",  # scrypt's memory at its bound, 128 MiB
        f"c:{kind}:{2**15}:32:1:{salt}:{digest}",
    ]
    read = read_users(_file(tmp_path, *lines))
    assert [(u.n, u.r, u.p, len(u.digest)) for u in read.values()] == [
        (2, 1, 1, 16), (2**20, 1, 16, 32), (2**15, 32, 1, 32),
    ]  # fmt: skip


def test_a_user_at_the_memory_bound_signs_in() -> None:
    """128 MiB of scrypt (N 2^17, r 8): above OpenSSL's default cap of 32 MiB, so the sign-in
    must give scrypt its own cap."""
    salt = b"0123456789abcdef"
    digest = hashlib.scrypt(PASSWORD.encode(), salt=salt, n=2**17, r=8, p=1, dklen=32,
                            maxmem=2**30)  # fmt: skip
    user = User("alice", 2**17, 8, 1, salt, digest)
    assert user.accepts(PASSWORD)
    assert not user.accepts("wrong password")


def test_a_file_with_bytes_that_are_not_utf8_is_still_read(tmp_path: Path) -> None:
    path = tmp_path / "users"
    path.write_bytes(b"# op\xe9rateurs \xff\n" + hashed_line("alice", PASSWORD).encode() + b"\n")
    assert list(read_users(path)) == ["alice"]


def test_an_empty_missing_or_huge_file_is_refused_in_one_line(tmp_path: Path) -> None:
    empty = _file(tmp_path, "# nobody yet")
    with pytest.raises(InputError, match=f"^--opcua-users {empty}: no users in the file$"):
        read_users(empty)
    missing = tmp_path / "nowhere"
    with pytest.raises(InputError, match=f"^--opcua-users {missing}: cannot read \\(No such"):
        read_users(missing)
    huge = tmp_path / "huge"
    huge.write_bytes(b"#" * (MAX_FILE_BYTES + 1))
    with pytest.raises(InputError, match=f"^--opcua-users {huge}: longer than 1000000 bytes$"):
        read_users(huge)
    at_limit = tmp_path / "at_limit"
    line = hashed_line("alice", PASSWORD) + "\n"
    at_limit.write_text("#" * (MAX_FILE_BYTES - len(line) - 1) + "\n" + line)
    assert list(read_users(at_limit)) == ["alice"]


def test_the_command_appends_a_user_readable_only_by_its_owner(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    answers = iter([PASSWORD, PASSWORD, "hunter22", "hunter22"])
    prompts: list[str] = []

    def typed(prompt: str) -> str:
        prompts.append(prompt)
        return next(answers)

    monkeypatch.setattr(users.getpass, "getpass", typed)
    path = tmp_path / "users"
    assert users.main([str(path), "alice"]) == 0
    assert users.main([str(path), "bob"]) == 0
    assert capsys.readouterr().err == f"alice added to {path}\nbob added to {path}\n"
    assert prompts == ["password for alice: ", "again: ", "password for bob: ", "again: "]
    assert stat.S_IMODE(path.stat().st_mode) == 0o600
    read = read_users(path)
    assert read["alice"].accepts(PASSWORD)
    assert read["bob"].accepts("hunter22")


@pytest.mark.parametrize(
    ("argv", "answers", "message"),
    [
        (["users"], [], "usage: python -m handeye_pick.line.users FILE NAME\n"),
        (["users", "alice", "x"], [], "usage: python -m handeye_pick.line.users FILE NAME\n"),
        (["users", "alice"], [PASSWORD, "other one"], "the passwords differ; nothing written\n"),
        (["users", "alice"], ["short", "short"], "password of alice: at least 8 characters\n"),
    ],
)
def test_the_command_writes_nothing_it_refuses(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    argv: list[str],
    answers: list[str],
    message: str,
) -> None:
    given = iter(answers)
    monkeypatch.setattr(users.getpass, "getpass", lambda prompt: next(given))
    monkeypatch.chdir(tmp_path)
    assert users.main(argv) == 2
    assert capsys.readouterr().err == message
    assert not (tmp_path / "users").exists()
