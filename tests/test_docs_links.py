"""The docs a reader wants: every relative link of the repository's Markdown files resolves (to a
file, and its anchor to a heading of the page), the README fits a screen (at most 200 lines) with
its headline figures taken from docs/results.md, no date appears outside CHANGELOG.md, and the
package's layout is written in one place (docs/architecture.md)."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
README = REPO / "README.md"
DOCS = REPO / "docs"
MARKDOWN = sorted(
    [
        README,
        REPO / "CONTRIBUTING.md",
        REPO / "CHANGELOG.md",
        *DOCS.glob("*.md"),
        *REPO.glob("benchmarks/*.md"),
    ]
)
"""Every Markdown file of the repository a reader opens."""

README_MAX_LINES = 200
DATE = re.compile(r"\b(?:19|20)\d\d-[01]\d-[0-3]\d\b")
LINK = re.compile(r"!?\[(?:[^\[\]]|\[[^\]]*\])*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")
"""An inline link or image, ``[text](target)`` or ``![alt](target "title")``: the target."""


def without_fences(text: str) -> str:
    """``text`` without its fenced code blocks."""
    return re.sub(r"^(```|~~~).*?^\1[^\n]*$", "", text, flags=re.S | re.M)


def prose(text: str) -> str:
    """``text`` without its fenced code blocks and code spans (links there are not links)."""
    return re.sub(r"(`+)(?:(?!\1).)+?\1", "", without_fences(text), flags=re.S)


def links(text: str) -> list[str]:
    """The targets of the inline links and images of a Markdown text."""
    return LINK.findall(prose(text))


def slug(heading: str) -> str:
    """A heading's anchor as GitHub makes it: formatting dropped, lower case, punctuation other than
    ``-`` and ``_`` removed, spaces as ``-``."""
    text = re.sub(r"!?\[([^\]]*)\]\([^)]*\)", r"\1", heading)  # a link's text
    text = re.sub(r"[`*]", "", text).strip().lower()
    return re.sub(r"[^\w\- ]", "", text).replace(" ", "-")


def anchors(path: Path) -> set[str]:
    """The anchors of a Markdown file's headings (a repeated one gets ``-1``, ``-2``, ... as on
    GitHub)."""
    seen: dict[str, int] = {}
    out = set()
    for line in without_fences(path.read_text(encoding="utf-8")).splitlines():
        match = re.match(r"#{1,6}\s+(.*?)\s*#*\s*$", line)
        if not match:
            continue
        base = slug(match.group(1))
        count = seen.get(base, 0)
        seen[base] = count + 1
        out.add(base if count == 0 else f"{base}-{count}")
    return out


def broken_links(path: Path) -> list[str]:
    """The relative links of ``path`` that name no file, or a heading its page does not have."""
    broken = []
    for target in links(path.read_text(encoding="utf-8")):
        if re.match(r"[a-z][a-z0-9+.-]*:", target, flags=re.I):  # http:, https:, mailto:
            continue
        file_part, _, anchor = target.partition("#")
        resolved = (path.parent / file_part).resolve() if file_part else path
        if not resolved.exists():
            broken.append(f"{target}: no such file")
        elif anchor and resolved.suffix == ".md" and anchor not in anchors(resolved):
            broken.append(f"{target}: {resolved.name} has no heading #{anchor}")
    return broken


@pytest.mark.parametrize("path", MARKDOWN, ids=[str(p.relative_to(REPO)) for p in MARKDOWN])
def test_every_relative_link_resolves(path: Path) -> None:
    assert not broken_links(path), f"{path.relative_to(REPO)}: {broken_links(path)}"


def test_the_link_check_finds_what_is_broken(tmp_path: Path) -> None:
    """The checker itself: a missing file, a missing heading and a link in code that is no link."""
    (tmp_path / "other.md").write_text("# Other page\n\n## The study's system: `identify`\n")
    page = tmp_path / "page.md"
    page.write_text(
        "# Page\n\n[ok](other.md#the-studys-system-identify) [self](#page) [web](https://drake.mit.edu)\n"
        "[gone](missing.md) [no heading](other.md#nowhere) ![image](missing.png)\n"
        "`[in code](missing_too.md)`\n\n```\n[in a block](missing_three.md)\n```\n"
    )
    assert broken_links(page) == [
        "missing.md: no such file",
        "other.md#nowhere: other.md has no heading #nowhere",
        "missing.png: no such file",
    ]


def test_the_readme_fits_a_screen() -> None:
    lines = README.read_text(encoding="utf-8").splitlines()
    assert len(lines) <= README_MAX_LINES, f"README.md has {len(lines)} lines (at most {README_MAX_LINES})"


@pytest.mark.parametrize("path", [README, *sorted(DOCS.glob("*.md"))], ids=lambda p: p.name)
def test_no_dates_outside_the_changelog(path: Path) -> None:
    """Dated notes are history: CHANGELOG.md keeps them."""
    dated = [line for line in path.read_text(encoding="utf-8").splitlines() if DATE.search(line)]
    assert not dated, f"{path.relative_to(REPO)}: dated lines (history goes to CHANGELOG.md): {dated}"


def _readme_results() -> list[list[str]]:
    """The cells of the rows of the README's results table."""
    text = README.read_text(encoding="utf-8")
    section = text[text.index("\n## Results\n") :]
    section = section[: section.index("\n## ", 1)]
    rows = [line for line in section.splitlines() if line.startswith("|")][2:]  # header, rule
    return [[c.strip() for c in row.strip("|").split("|")] for row in rows]


def test_the_readme_headline_figures_are_the_results_pages() -> None:
    """Each figure of the README's results table (its "ours" column) is on docs/results.md, which
    says which command measured it."""
    results = (DOCS / "results.md").read_text(encoding="utf-8")
    rows = _readme_results()
    assert len(rows) >= 4
    for cells in rows:
        figures = re.findall(r"[-+]?\d+(?:\.\d+)?", cells[1])
        assert figures, f"the README's results row {cells[0]!r} has no figure"
        for figure in figures:
            assert re.search(rf"(?<![\d.]){re.escape(figure)}(?![\d])", results), (
                f"README's {cells[0]!r}: {figure} is not on docs/results.md"
            )


def test_the_layout_is_written_in_one_place() -> None:
    """Only docs/architecture.md writes out the package's tree; no package docstring lists its
    modules (they point to that page)."""
    for path in MARKDOWN:
        if path == DOCS / "architecture.md":
            continue
        for block in re.findall(
            r"^```[^\n]*\n(.*?)^```", path.read_text(encoding="utf-8"), flags=re.S | re.M
        ):
            assert not re.search(r"^\s*src/drake_disamb/\s*$", block, flags=re.M), (
                f"{path.relative_to(REPO)} writes the package's tree: docs/architecture.md does"
            )
    for init in sorted((REPO / "src" / "drake_disamb").rglob("__init__.py")):
        doc = ast.get_docstring(ast.parse(init.read_text(encoding="utf-8"))) or ""
        listed = re.findall(r"^\s*- :mod:`", doc, flags=re.M)
        assert len(listed) < 2, f"{init.relative_to(REPO)} lists its modules: docs/architecture.md does"
