"""docs/scripts.md names every script in scripts/ and no script that is gone, so scripts/ stays the tools a
developer runs again, each with its purpose and where its figures are."""

from __future__ import annotations

import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def test_every_script_has_its_line_in_docs_scripts_md():
    table = (REPO / "docs" / "scripts.md").read_text().split("Experiments of closed issues")[0]
    named = set(re.findall(r"^\| `([^`]+)`(?:, `([^`]+)`)?", table, flags=re.MULTILINE))
    listed = {name for pair in named for name in pair if name}
    present = {p.name for p in (REPO / "scripts").iterdir() if p.is_file()}
    assert present - listed == set(), f"scripts without a line in docs/scripts.md: {sorted(present - listed)}"
    assert listed - present == set(), f"docs/scripts.md names scripts that are gone: {sorted(listed - present)}"
