"""Mutation testing of the safety modules with mutmut (docs/mutation-testing.md).

    .venv/bin/pip install -e '.[test,mutation]'
    .venv/bin/python tools/mutation.py --module scene/collide.py --max-children 1
    .venv/bin/python tools/mutation.py                  # every module of [tool.mutmut] only_mutate
    .venv/bin/python tools/mutation.py --table          # only the table of the last runs

Python 3.11 or later (tomllib). Run from anywhere; it works in the repository root. It prepares
what mutmut 3.8.1 needs on this project (``mutants/src`` made before mutmut starts,
``PYTHONPATH`` pointing there so the CLI subprocesses the tests start import the mutated code),
runs ``mutmut run`` for one module (``--module``, a path under ``src/handeye_pick/``) or all of
them, and prints one row per module: mutants, killed, survived, timeout and the rest (no tests,
not checked, suspicious). Survivors: ``.venv/bin/mutmut results`` lists them,
``.venv/bin/mutmut show NAME`` shows one.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from collections import Counter
from pathlib import Path

import tomllib

ROOT = Path(__file__).resolve().parent.parent
PACKAGE = "src/handeye_pick/"
COLUMNS = ("killed", "survived", "timeout")


def safety_modules() -> list[str]:
    """The modules of ``[tool.mutmut] only_mutate``, as paths under src/handeye_pick/."""
    with (ROOT / "pyproject.toml").open("rb") as file:
        only_mutate: list[str] = tomllib.load(file)["tool"]["mutmut"]["only_mutate"]
    return [path.removeprefix(PACKAGE) for path in only_mutate]


def mutant_glob(module: str) -> str:
    """mutmut's name pattern for the mutants of ``module`` (``scene/collide.py``)."""
    return "handeye_pick." + module.removesuffix(".py").replace("/", ".") + ".*"


def run_mutmut(module: str | None, max_children: int) -> int:
    """``mutmut run`` in the repository root for ``module`` (None: all); its exit status."""
    mutated_src = ROOT / "mutants" / "src"
    # Before mutmut starts: a PYTHONPATH entry that does not exist yet is cached as empty,
    # and the tests would import the unmutated code.
    mutated_src.mkdir(parents=True, exist_ok=True)
    # A module added to only_mutate after mutants/ was made sits there as a plain copy, which
    # mutmut takes as unmodified and never mutates: remove it so that mutmut makes it again.
    for listed in safety_modules():
        copy = ROOT / "mutants" / PACKAGE / listed
        if copy.exists() and not copy.with_name(copy.name + ".meta").exists():
            copy.unlink()
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(
        p for p in (str(mutated_src), os.environ.get("PYTHONPATH", "")) if p
    )
    command = [str(Path(sys.executable).parent / "mutmut"), "run"]
    command += ["--max-children", str(max_children)]
    if module is not None:
        command.append(mutant_glob(module))
    return subprocess.run(command, cwd=ROOT, env=env, check=False).returncode


def counts(module: str) -> Counter[str]:
    """How many mutants of ``module`` ended how, from mutmut's record in ``mutants/``."""
    from mutmut.stats import status_by_exit_code

    meta = ROOT / "mutants" / f"{PACKAGE}{module}.meta"
    if not meta.exists():
        return Counter()
    exit_codes: dict[str, int | None] = json.loads(meta.read_text())["exit_code_by_key"]
    return Counter(status_by_exit_code[code] for code in exit_codes.values())


def table(modules: list[str]) -> str:
    """One row per module: mutants, killed, survived, timeout, other (none run: not yet run)."""
    rows = [
        "| module | mutants | killed | survived | timeout | other |",
        "|---|---|---|---|---|---|",
    ]
    for module in modules:
        found = counts(module)
        total = sum(found.values())
        if total == 0 or found["not checked"] == total:
            rows.append(f"| `{module}` | not yet run | | | | |")
            continue
        other = total - sum(found[c] for c in COLUMNS)
        cells = [str(total), *(str(found[c]) for c in COLUMNS), str(other)]
        rows.append(f"| `{module}` | " + " | ".join(cells) + " |")
    return "\n".join(rows)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--module", help="one module, e.g. scene/collide.py (default: all)")
    parser.add_argument("--max-children", type=int, default=1, help="mutmut workers (default 1)")
    parser.add_argument("--table", action="store_true", help="print the table only, run nothing")
    args = parser.parse_args(argv)
    modules = safety_modules()
    if args.module is not None and args.module not in modules:
        parser.error(f"--module {args.module}: not in [tool.mutmut] only_mutate: {modules}")
    status = 0
    if not args.table:
        start = time.monotonic()
        status = run_mutmut(args.module, args.max_children)
        print(f"mutmut run: exit {status} after {(time.monotonic() - start) / 60.0:.1f} min")
    print(table(modules if args.module is None else [args.module]))
    return status


if __name__ == "__main__":
    sys.exit(main())
