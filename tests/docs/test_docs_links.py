"""The user docs hold together: every relative link in README.md and docs/*.md names a file that exists (and,
where it names a heading of a Markdown page, a heading that page has), and README.md stays a short page for
users (the reference lives in docs/)."""

from __future__ import annotations

import re
from pathlib import Path
from urllib.parse import unquote

import pytest

from conftest import ROOT

PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
README_MAX_LINES = 300

LINK = re.compile(r"(?<!!)\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")  # [text](target "title")
FENCE = re.compile(r"^(```|~~~)")


def _prose(text: str) -> str:
    """The page without its fenced code blocks (a link-like text in a code sample is not a link)."""
    out, fenced = [], False
    for line in text.splitlines():
        if FENCE.match(line.lstrip()):
            fenced = not fenced
            continue
        if not fenced:
            out.append(re.sub(r"`[^`]*`", "", line))
    return "\n".join(out)


def _anchors(page: Path) -> set[str]:
    """The anchors GitHub gives a Markdown page's headings: lowercase, punctuation dropped, spaces as hyphens,
    a repeated heading suffixed -1, -2, ..."""
    seen: dict[str, int] = {}
    fenced = False
    for line in page.read_text(encoding="utf-8").splitlines():
        if FENCE.match(line.lstrip()):
            fenced = not fenced
        if fenced or not line.startswith("#"):
            continue
        slug = re.sub(r"[^\w\- ]", "", line.lstrip("#").strip().lower()).replace(" ", "-")
        n = seen.get(slug, 0)
        seen[slug] = n + 1
        seen.setdefault(slug if n == 0 else f"{slug}-{n}", 1)
    return set(seen)


def _links() -> list[tuple[str, str]]:
    found = []
    for page in PAGES:
        for target in LINK.findall(_prose(page.read_text(encoding="utf-8"))):
            if not re.match(r"^[a-z][a-z0-9+.-]*:", target):  # not http:, https:, mailto:
                found.append((str(page.relative_to(ROOT)), target))
    return found


@pytest.mark.parametrize("page, target", _links())
def test_every_relative_link_resolves(page: str, target: str) -> None:
    path, _, anchor = target.partition("#")
    file = (ROOT / page).parent / unquote(path) if path else ROOT / page
    assert file.exists(), f"{page}: the link {target} names {file.relative_to(ROOT)}, which does not exist"
    if anchor and file.suffix == ".md":
        assert anchor in _anchors(file), f"{page}: {file.name} has no heading whose anchor is #{anchor}"


def test_the_pages_have_links_to_check() -> None:
    assert {page for page, _ in _links()} >= {"README.md"}


def test_readme_is_a_short_page_for_users() -> None:
    lines = (ROOT / "README.md").read_text(encoding="utf-8").splitlines()
    assert len(lines) < README_MAX_LINES, f"README.md has {len(lines)} lines; move reference material to docs/"
