"""The documentation's own rules (docs/architecture.md, "Where a new thing goes"): each guide is short and all of
them together are read in an hour; no page written by hand carries a date, a commit hash or an issue number (the
measurement history is in git; the figures page, written by benchmarks/report.py, says when and where it was
measured); and the README's links lead to pages and headings that exist. The links inside docs/ are checked by the
strict site build (`mkdocs build --strict`), the examples by `python -m pytest README.md docs`."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from markdown.extensions.toc import slugify

ROOT = Path(__file__).resolve().parents[2]
DOCS = ROOT / "docs"
MEASURED = {"figures.md"}  # written by benchmarks/report.py, with its date and commit
DEVELOPERS = {"architecture.md"}  # the code's map, beside the design notes
GUIDE_MAX_LINES = 300
USER_FACING_MAX_LINES = 3000

USER_FACING = [ROOT / "README.md"] + sorted(
    page for page in DOCS.glob("*.md") if page.name not in MEASURED | DEVELOPERS
)
WRITTEN_BY_HAND = USER_FACING + [DOCS / name for name in sorted(DEVELOPERS)] + sorted((DOCS / "design").glob("*.md"))

MONTHS = "Jan|Feb|Mar|Apr|May|Jun|Jul|Aug|Sep|Oct|Nov|Dec"
DATE = re.compile(
    rf"\b(19|20)\d\d-[01]\d-[0-3]\d\b|\b\d{{1,2}} ({MONTHS})[a-z]* (19|20)\d\d\b|\b({MONTHS})[a-z]* (19|20)\d\d\b"
)
COMMIT_HASH = re.compile(r"(?<![\w./-])(?=[0-9a-f]*[a-f])(?=[0-9a-f]*\d)[0-9a-f]{7,40}(?!\w)")
ISSUE_NUMBER = re.compile(r"\b(issue|issues|PR|pull request)[ -]?#?\d+\b|(?<![\w&/])#\d+\b", re.IGNORECASE)
LINK = re.compile(r"\]\(([^)\s]+)\)")


def lines(page: Path) -> int:
    return len(page.read_text().splitlines())


@pytest.mark.parametrize("page", USER_FACING, ids=lambda page: page.name)
def test_a_guide_is_short(page):
    assert lines(page) <= GUIDE_MAX_LINES, f"{page.name}: {lines(page)} lines; a guide is under {GUIDE_MAX_LINES}"


def test_the_user_facing_docs_are_read_in_an_hour():
    total = sum(lines(page) for page in USER_FACING)
    assert total <= USER_FACING_MAX_LINES, f"{total} lines of user-facing docs, at most {USER_FACING_MAX_LINES}"


@pytest.mark.parametrize("page", WRITTEN_BY_HAND, ids=lambda page: str(page.relative_to(ROOT)))
def test_no_dates_commit_hashes_or_issue_numbers(page):
    found = [
        f"{page.relative_to(ROOT)}:{number}: {match.group(0)!r}"
        for number, line in enumerate(page.read_text().splitlines(), start=1)
        for pattern in (DATE, COMMIT_HASH, ISSUE_NUMBER)
        for match in pattern.finditer(line)
    ]
    assert not found, "history belongs in commit messages, not in the docs:\n" + "\n".join(found)


@pytest.mark.parametrize(
    ("line", "found"),
    [
        ("measured on 2026-11-24 on the machine", True),
        ("flown (24 Nov 2026) twice", True),
        ("the code of commit 75f638e", True),
        ("as issue 11 asks", True),
        ("see #123", True),
        ("PWM 1691, 0x1FFF, 1e-6, deadline, decade, [link](mpc.md#the-model-21-23)", False),
    ],
)
def test_the_history_patterns(line, found):
    assert any(pattern.search(line) for pattern in (DATE, COMMIT_HASH, ISSUE_NUMBER)) == found


def headings(page: Path) -> set[str]:
    text = re.sub(r"```.*?```", "", page.read_text(), flags=re.DOTALL)
    return {slugify(match.group(1).strip(), "-") for match in re.finditer(r"^#+ (.+)$", text, flags=re.MULTILINE)}


def test_the_readme_links_lead_to_pages_and_headings_that_exist():
    readme = ROOT / "README.md"
    broken = []
    for target in LINK.findall(readme.read_text()):
        if re.match(r"[a-z]+://", target):
            continue
        path, _, anchor = target.partition("#")
        page = (readme.parent / path).resolve()
        if not page.is_file():
            broken.append(f"{target}: no such file")
        elif anchor and page.suffix == ".md" and anchor not in headings(page):
            broken.append(f"{target}: no such heading")
    assert not broken, "README.md: " + "; ".join(broken)
