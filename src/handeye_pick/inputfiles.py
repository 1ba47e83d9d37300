"""The small text files a user hands in (cell config, detection, hand-eye and pose files), read
with bounds so a hostile or broken file ends in one line naming it, never in a traceback, a
memory blow-up or a long stall.

Bounds (each far above any real file of these kinds, which are a few kB with under 200 values):

- ``MAX_INPUT_BYTES``: a larger file is refused from its size, before it is read or parsed.
- ``MAX_YAML_VALUES``: values in a YAML document, counting every alias as a full copy of what it
  names; stops "billion laughs" files (a few lines of aliases that expand to 10^9 values).
  Composing stops as soon as the count is passed, so a file under the size bound of 1 MB still
  takes about a second at worst (PyYAML checks every character of the text first).
- ``MAX_YAML_DEPTH``: nesting of lists and mappings (the deepest real file nests 4 levels).
- ``MAX_INTEGER_CHARS``: digits of one integer (YAML or JSON).

YAML is read with PyYAML's safe constructors only (``!!python/...`` tags are refused) and a key
given twice in one mapping is refused instead of silently keeping the last one.
"""

from __future__ import annotations

import json
import os
from pathlib import Path

import yaml

from handeye_pick.errors import InputError

MAX_INPUT_BYTES = 1_000_000
MAX_YAML_VALUES = 10_000
MAX_YAML_DEPTH = 20
MAX_INTEGER_CHARS = 40  # a longer integer overflows float and, past 4300 digits, int() itself


def read_input_bytes(path: Path, what: str, error: type[InputError]) -> bytes:
    """The bytes of ``path`` (a ``what``, e.g. "transform file"), refused when larger than
    ``MAX_INPUT_BYTES``; raises ``error`` with one line naming the file."""
    try:
        with Path(path).open("rb") as file:
            too_big = os.fstat(file.fileno()).st_size > MAX_INPUT_BYTES
            # Read one byte more than allowed: a pipe or a device reports no size.
            data = b"" if too_big else file.read(MAX_INPUT_BYTES + 1)
    except OSError as exc:
        raise error(f"cannot read {what} {path}: {exc.strerror or exc}") from None
    if too_big or len(data) > MAX_INPUT_BYTES:
        raise error(
            f"{what} {path} is larger than {MAX_INPUT_BYTES // 1000} kB, far beyond any real "
            "one: refusing to read it (wrong file?)"
        )
    return data


class BoundedLoader(yaml.SafeLoader):
    """PyYAML's safe loader with duplicate keys refused and values and nesting bounded."""

    def __init__(self, stream: str) -> None:
        super().__init__(stream)
        self._values = 0
        self._depth = 0

    def compose_node(self, parent: yaml.Node | None, index: int) -> yaml.Node | None:
        mark = self.peek_event().start_mark  # type: ignore[no-untyped-call]  # untyped in stubs
        self._values += 1
        if self._values > MAX_YAML_VALUES:
            raise yaml.composer.ComposerError(
                None, None, f"more than {MAX_YAML_VALUES} values", mark
            )
        self._depth += 1
        try:
            if self._depth > MAX_YAML_DEPTH:
                raise yaml.composer.ComposerError(
                    None, None, f"nested deeper than {MAX_YAML_DEPTH} levels", mark
                )
            return super().compose_node(parent, index)
        finally:
            self._depth -= 1

    def construct_document(self, node: yaml.Node) -> object:
        # Aliases share one node, so the count while composing saw each once; what the readers
        # walk (and an error message would print) is the expansion.
        problem = _expansion_problem(node, MAX_YAML_VALUES)
        if problem is not None:
            raise yaml.composer.ComposerError(None, None, problem, node.start_mark)
        return super().construct_document(node)


def _construct_unique_mapping(
    loader: yaml.SafeLoader, node: yaml.MappingNode
) -> dict[object, object]:
    seen: set[object] = set()
    for key_node, _ in node.value:
        if key_node.tag == "tag:yaml.org,2002:merge":
            continue  # "<<: *anchor" merges; keys written next to it override on purpose
        key = loader.construct_object(key_node)
        if key in seen:
            raise yaml.constructor.ConstructorError(
                None, None, f"key {key!r} appears twice", key_node.start_mark
            )
        seen.add(key)
    return loader.construct_mapping(node)


BoundedLoader.add_constructor(
    yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_unique_mapping
)


def _construct_bounded_int(loader: yaml.SafeLoader, node: yaml.ScalarNode) -> int:
    if len(node.value) > MAX_INTEGER_CHARS:
        raise yaml.constructor.ConstructorError(
            None, None, f"an integer of {len(node.value)} characters", node.start_mark
        )
    value: int = loader.construct_yaml_int(node)
    return value


BoundedLoader.add_constructor("tag:yaml.org,2002:int", _construct_bounded_int)


def _children(node: yaml.Node) -> list[yaml.Node]:
    if isinstance(node, yaml.SequenceNode):
        return list(node.value)
    if isinstance(node, yaml.MappingNode):
        return [child for pair in node.value for child in pair]
    return []


def _expansion_problem(root: yaml.Node, limit: int) -> str | None:
    """Why ``root`` with every alias copied out is too big (more than ``limit`` values, or
    endless), or None.

    Iterative, each shared node sized once: linear in the composed nodes, whatever the aliases.
    """
    sizes: dict[int, int] = {}
    open_nodes: set[int] = set()  # on the path from the root: meeting one again is a cycle
    stack: list[tuple[yaml.Node, bool]] = [(root, False)]
    while stack:
        node, children_sized = stack.pop()
        key = id(node)
        if children_sized:
            open_nodes.discard(key)
            sizes[key] = 1 + sum(sizes[id(child)] for child in _children(node))
            if sizes[key] > limit:
                return f"more than {limit} values once its aliases (*name) are expanded"
        elif key not in sizes:
            if key in open_nodes:
                return "an alias (*name) inside the value it names"
            open_nodes.add(key)
            stack.append((node, True))
            stack.extend((child, False) for child in _children(node))
    return None


def yaml_problem(exc: yaml.YAMLError) -> str:
    """One line: what the parser objected to and where (line and column, from 1)."""
    if isinstance(exc, yaml.MarkedYAMLError):
        mark = exc.problem_mark or exc.context_mark
        problem = " ".join(str(exc.problem or exc.context or "invalid YAML").split())
        if mark is not None:
            return f"{problem} at line {mark.line + 1}, column {mark.column + 1}"
        return problem
    return " ".join(str(exc).split())


def load_json(text: str) -> object:
    """Parse JSON; every problem (syntax, nesting too deep, a huge integer) is a ``ValueError``
    whose message is one line with the line and column where they are known."""
    try:
        return json.loads(text, parse_int=_bounded_json_int)
    except json.JSONDecodeError as exc:
        raise ValueError(f"{exc.msg} at line {exc.lineno}, column {exc.colno}") from None
    except RecursionError:  # json's decoder recurses into nested lists
        raise ValueError("nested too deeply") from None


def _bounded_json_int(text: str) -> int:
    if len(text) > MAX_INTEGER_CHARS:
        raise ValueError(f"an integer of {len(text)} characters")
    return int(text)


def shown(value: object) -> str:
    """``value`` for a one-line message: its repr, cut to 80 characters."""
    text = repr(value)
    return text if len(text) <= 80 else text[:77] + "..."
