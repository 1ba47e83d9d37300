"""The documentation's links, and the code's references into it, stay true.

- Every relative Markdown link in README.md and the pages of docs/ leads to a file inside the
  repository, and a ``#fragment`` to a heading of that file (GitHub's heading anchors).
- Every mention of a page of docs/ in the comments and docstrings under src/, mocks/ and tests/
  names a page that exists; a heading quoted right after it (the page, a comma, the heading in
  double quotes, possibly wrapped onto the next line behind a comment marker) is a heading of
  that page.
- Nothing under src/, mocks/, tests/ or docs/, nor the README, points at reference material
  that is not in the repository.

Each check is a function that returns its problems; the tests below run it on the repository
and on small made-up files, so that each is seen to fail where it should.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PAGES = (ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")))
CODE_FOLDERS = ("src", "mocks", "tests")
# Written in pieces so that this file does not hold what it looks for.
OUTSIDE = ("shared" + "/reference", "ur_rtde_" + "protocol.md", "field" + " note")

_FENCE = re.compile(r"^ {0,3}(```|~~~)")
_HEADING = re.compile(r"^ {0,3}(#{1,6})[ \t]+(.+?)[ \t]*#*[ \t]*$")
_INLINE_CODE = re.compile(r"(`+)(.+?)\1")
_LINK = re.compile(r"!?\[(?:[^\[\]]|\[[^\]]*\])*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
_REFERENCE_DEFINITION = re.compile(r"^ {0,3}\[[^\]]+\]:\s*<?(\S+?)>?(?:\s|$)")
_SCHEME = re.compile(r"^[a-zA-Z][a-zA-Z0-9+.-]*:")
_DOCS_PAGE = re.compile(r"docs/([A-Za-z0-9_.-]+?\.md)\b")
# After a page: a comma, then the quoted heading; either may follow a line break and the
# indentation and comment marker that continue a comment.
_WRAP = r"(?:[ \t]*\n[ \t]*(?:#[ \t]*)?)"
_QUOTED_HEADING = re.compile(r",(?:[ \t]*|" + _WRAP + r')"')
_MAX_HEADING_CHARS = 200


def _outside_fences(text: str) -> Iterator[tuple[int, str]]:
    """(line number, line) of every line outside fenced code blocks."""
    fence: str | None = None
    for number, line in enumerate(text.splitlines(), start=1):
        match = _FENCE.match(line)
        if match:
            if fence is None:
                fence = match.group(1)
            elif match.group(1) == fence:
                fence = None
            continue
        if fence is None:
            yield number, line


def _plain(markdown: str) -> str:
    """A heading's text as GitHub renders it: links as their text, no emphasis or code marks."""
    text = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", markdown)
    return text.replace("`", "").replace("*", "")


def headings(text: str) -> list[str]:
    """The ATX headings of a Markdown text, as written (without the leading #s)."""
    found = []
    for _, line in _outside_fences(text):
        match = _HEADING.match(line)
        if match:
            found.append(match.group(2))
    return found


def slug(heading: str) -> str:
    """GitHub's anchor for a heading: lower case, punctuation dropped, spaces to hyphens."""
    text = _plain(heading).strip().lower()
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def anchors(text: str) -> set[str]:
    """Every heading anchor of a page; a repeated heading gets -1, -2, ... as on GitHub."""
    seen: dict[str, int] = {}
    result = set()
    for heading in headings(text):
        base = slug(heading)
        count = seen.get(base, 0)
        seen[base] = count + 1
        result.add(base if count == 0 else f"{base}-{count}")
    return result


def links(text: str) -> list[tuple[int, str]]:
    """(line number, target) of every Markdown link and image outside code."""
    found = []
    for number, line in _outside_fences(text):
        line = _INLINE_CODE.sub("", line)
        found += [(number, match.group(1)) for match in _LINK.finditer(line)]
        definition = _REFERENCE_DEFINITION.match(line)
        if definition:
            found.append((number, definition.group(1)))
    return found


def link_problems(page: Path, root: Path = ROOT) -> list[str]:
    """Relative links of ``page`` that lead nowhere: no such file, a file outside ``root``, or
    an anchor that is no heading of the Markdown file it names."""
    problems = []
    for number, target in links(page.read_text(encoding="utf-8")):
        if _SCHEME.match(target):
            continue  # not a relative link
        where = f"{page.relative_to(root)}:{number}: {target}"
        path_part, _, fragment = target.partition("#")
        path = (page.parent / path_part).resolve() if path_part else page.resolve()
        if not path.is_relative_to(root.resolve()):
            problems.append(f"{where}: leads outside the repository")
            continue
        if not path.exists():
            problems.append(f"{where}: no such file")
            continue
        if (
            fragment
            and path.suffix == ".md"
            and fragment not in anchors(path.read_text(encoding="utf-8"))
        ):
            problems.append(f"{where}: no heading with the anchor #{fragment} in {path.name}")
    return problems


def references(text: str) -> Iterator[tuple[int, str, str | None]]:
    """(line number, page, quoted heading or None) of every mention of a page of docs/.

    A heading broken over lines is joined with one space, the comment markers dropped. An
    opening quote without its closing one within a heading's length is yielded as the heading
    ``'"'`` (no page has that heading), so an unterminated reference is reported, not skipped.
    """
    for match in _DOCS_PAGE.finditer(text):
        number = text.count("\n", 0, match.start()) + 1
        quote = _QUOTED_HEADING.match(text, match.end())
        if quote is None:
            yield number, match.group(1), None
            continue
        end = text.find('"', quote.end(), quote.end() + _MAX_HEADING_CHARS)
        if end < 0:
            yield number, match.group(1), '"'
            continue
        heading = re.sub(_WRAP, " ", text[quote.end() : end])
        yield number, match.group(1), re.sub(r"[ \t]+", " ", heading).strip()


def reference_problems(source: Path, root: Path = ROOT) -> list[str]:
    """Mentions of docs/ pages in ``source`` whose page or heading does not exist."""
    problems = []
    text = source.read_text(encoding="utf-8")
    for number, page, heading in references(text):
        where = f"{source.relative_to(root)}:{number}: docs/{page}"
        path = root / "docs" / page
        if not path.is_file():
            problems.append(f"{where}: no such page")
        elif heading is not None and heading not in headings(path.read_text(encoding="utf-8")):
            problems.append(f'{where}: no heading "{heading}" in it')
    return problems


def outside_mentions(source: Path, root: Path = ROOT) -> list[str]:
    """Lines of ``source`` that mention reference material from outside the repository."""
    problems = []
    text = source.read_text(encoding="utf-8", errors="replace")
    for number, line in enumerate(text.splitlines(), start=1):
        lowered = line.lower()
        problems += [
            f"{source.relative_to(root)}:{number}: mentions {word!r}"
            for word in OUTSIDE
            if word in lowered
        ]
    return problems


def _text_files(*folders: str) -> list[Path]:
    files = []
    for folder in folders:
        for path in sorted((ROOT / folder).rglob("*")):
            if not path.is_file() or "__pycache__" in path.parts:
                continue
            if b"\0" in path.read_bytes()[:8192]:
                continue  # binary: a picture, a cloud
            files.append(path)
    return files


# --- the repository -----------------------------------------------------------------------------


@pytest.mark.parametrize("page", PAGES, ids=lambda page: page.name)
def test_every_relative_link_leads_to_a_file_and_heading(page: Path) -> None:
    assert link_problems(page) == []


def test_every_reference_from_the_code_names_a_page_and_heading_that_exist() -> None:
    sources = [path for path in _text_files(*CODE_FOLDERS) if path.suffix == ".py"]
    problems = [problem for source in sources for problem in reference_problems(source)]
    assert problems == []


def test_the_code_cites_the_pages_it_relies_on() -> None:
    # Guards the reference pattern itself: if it stopped matching, the test above would pass on
    # nothing.
    cited = {
        (page, heading)
        for source in _text_files(*CODE_FOLDERS)
        if source.suffix == ".py"
        for _, page, heading in references(source.read_text(encoding="utf-8"))
    }
    assert ("ur-rtde.md", "What makes the client throw or hang") in cited
    assert ("field-experience.md", "A supervisor's SIGTERM, a crash, a power cut") in cited


def test_nothing_points_at_reference_material_outside_the_repository() -> None:
    sources = [*_text_files(*CODE_FOLDERS, "docs"), ROOT / "README.md"]
    problems = [problem for source in sources for problem in outside_mentions(source)]
    assert problems == []


# --- each check fails where it should -----------------------------------------------------------


def test_slugs_follow_github() -> None:
    assert slug("What makes the client throw or hang") == "what-makes-the-client-throw-or-hang"
    assert slug("A supervisor's SIGTERM, a crash, a power cut") == (
        "a-supervisors-sigterm-a-crash-a-power-cut"
    )
    assert slug("plan --plot: see every frame") == "plan---plot-see-every-frame"
    assert slug("Whole clouds in memory: `transform_points`") == (
        "whole-clouds-in-memory-transform_points"
    )
    assert anchors("# Tests\n## Tests\n```\n# not a heading\n```\n") == {"tests", "tests-1"}


def test_a_link_to_a_missing_file_heading_or_place_outside_is_found(tmp_path: Path) -> None:
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "other.md").write_text("# Other page\n## A heading\n")
    page = tmp_path / "docs" / "page.md"
    page.write_text(
        "# Page\n"
        "[fine](other.md#a-heading) [fine too](#page) ![picture](other.md) [web](https://x.org)\n"
        "`[in code](missing.md)`\n"
        "```\n[in a block](missing.md)\n```\n"
        "[gone](missing.md) [no heading](other.md#nowhere) [up](../../elsewhere.md)\n"
        "[self](#not-here)\n"
        "[defined]: also-missing.md\n"
    )
    problems = link_problems(page, root=tmp_path)
    assert len(problems) == 5, problems
    assert f"{Path('docs', 'page.md')}:7: missing.md: no such file" in problems
    assert any("#nowhere" in problem for problem in problems)
    assert any("outside the repository" in problem for problem in problems)
    assert any("#not-here" in problem for problem in problems)
    assert any("also-missing.md" in problem for problem in problems)


def test_a_reference_to_a_missing_page_or_heading_is_found(tmp_path: Path) -> None:
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "guide.md").write_text("# Guide\n## A long heading, wrapped\n")
    source = tmp_path / "code.py"
    text = (  # DOCS/ stands for the folder, so that this file holds no reference of its own
        '"""See DOCS/guide.md, "Guide" and DOCS/guide.md alone."""\n'
        '# DOCS/guide.md, "A long\n#     heading, wrapped"\n'
        '    # DOCS/guide.md,\n    # "A long heading, wrapped": the page and heading wrap\n'
        '"""DOCS/guide.md, "A long\n    heading, wrapped")."""\n'
        '# DOCS/guide.md, "No such heading"\n'
        '# DOCS/gone.md, "Guide"\n'
        '# DOCS/guide.md, "never closed\n' + "#\n" * 200
    )
    source.write_text(text.replace("DOCS/", "docs/"))
    problems = reference_problems(source, root=tmp_path)
    assert [problem.replace("docs/", "DOCS/") for problem in problems] == [
        'code.py:8: DOCS/guide.md: no heading "No such heading" in it',
        "code.py:9: DOCS/gone.md: no such page",
        'code.py:10: DOCS/guide.md: no heading """ in it',
    ]


def test_a_mention_of_material_outside_the_repository_is_found(tmp_path: Path) -> None:
    source = tmp_path / "notes.md"
    lines = ["fine", f"see ../{OUTSIDE[0]}/x", OUTSIDE[1].upper(), f"{OUTSIDE[2].title()} 4"]
    source.write_text("\n".join(lines) + "\n")
    assert [problem.split(":")[1] for problem in outside_mentions(source, root=tmp_path)] == [
        "2",
        "3",
        "4",
    ]
