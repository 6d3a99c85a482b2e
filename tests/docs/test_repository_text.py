"""No development log in the product: the repository's text (code, comments, presets, docs,
tests) says what a thing does and why, never at which development step it changed. History
belongs to ``CHANGELOG.md`` and ``docs/decisions/``."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

#: "stop" or "issue" (or their plurals) and a number: a development step or a tracker number;
#: or "seed" and three digits, the project's old names of the papers (a paper is named by its
#: subject; "seed" means a random seed).
HISTORY = re.compile(r"\b(stop|issue)s? [0-9]+|seed[0-9]{3}", re.I)

#: Where history is the subject (results/ holds recorded runs under the names they ran with).
HISTORY_PLACES = ("CHANGELOG.md", "docs/decisions/", "results/")

#: Pending: files other work edits at the same time; they are cleaned when that work is merged,
#: then removed from this list (the test then covers them).
PENDING: set[str] = set()
PENDING_FOLDERS: tuple[str, ...] = ()


def tracked_text_files() -> list[str]:
    """The repository's tracked files, as ``git ls-files`` lists them."""
    try:
        out = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True,
                             check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("not a git checkout")
    return [f for f in out.splitlines() if f]


def _checked(path: str) -> bool:
    return not (path.startswith(HISTORY_PLACES) or path in PENDING
                or path.startswith(PENDING_FOLDERS))


def history_mentions(text: str) -> list[str]:
    """The phrases of ``text`` that speak of a development step or a tracker number."""
    return [m.group(0) for m in HISTORY.finditer(text)]


def test_no_development_history_in_the_product():
    found = []
    n = 0
    for path in tracked_text_files():
        if not _checked(path):
            continue
        try:
            text = (ROOT / path).read_text(encoding="utf-8")
        except (UnicodeDecodeError, FileNotFoundError, IsADirectoryError):
            continue  # a binary file, or one deleted in the working tree
        n += 1
        for lineno, line in enumerate(text.splitlines(), 1):
            if HISTORY.search(line):
                found.append(f"{path}:{lineno}: {line.strip()[:100]}")
    assert n > 200  # the whole repository was read, not an empty list
    assert not found, "development history outside CHANGELOG.md and docs/decisions/:\n" + \
        "\n".join(found)


def test_the_pattern_and_the_exclusions():
    # the phrases are built here so that this file does not hold them
    phrases = [" ".join(p) for p in (("Stop", "24"), ("issue", "16"), ("issues", "3"),
                                     ("stops", "2"))]
    assert history_mentions("before {}, see {}; {} and {}".format(*phrases)) == phrases
    assert history_mentions("the {} benchmark".format("seed" + "003")) == ["seed" + "003"]
    assert not history_mentions("stops at frame 10; nonstop 3; tissue 4; a stop-24 name")
    assert not history_mentions("--seed 3; seeds 0-4; seed 1000")
    assert not _checked("CHANGELOG.md") and not _checked("docs/decisions/index.md")
    assert _checked("toolkit/pftrack/render/report.py")
    assert _checked("README.md") and _checked("plugins/pftrack_network/linkers.py")
    for path in PENDING:  # every pending file exists: a renamed one must leave the list
        assert (ROOT / path).is_file(), path
