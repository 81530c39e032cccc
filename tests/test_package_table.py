"""The package table of docs/architecture.md names every public module and subpackage of armlab, and nothing that is
not there."""

from __future__ import annotations

import pkgutil
import re
from pathlib import Path

import armlab

ROOT = Path(__file__).resolve().parents[1]


def _table_modules() -> set[str]:
    text = (ROOT / "docs" / "architecture.md").read_text()
    section = text[text.index("## The package"):]
    section = section[:section.index("\n\n", section.index("| module |"))]
    return set(re.findall(r"`(armlab\.[a-z_]+)`", "\n".join(line.split("|")[1] for line in section.splitlines()
                                                            if line.startswith("| `"))))


def test_the_package_table_matches_the_layout():
    modules = {f"armlab.{m.name}" for m in pkgutil.iter_modules(armlab.__path__) if not m.name.startswith("_")}
    listed = _table_modules()
    assert not modules - listed, f"docs/architecture.md's package table misses {sorted(modules - listed)}"
    assert not listed - modules, f"docs/architecture.md's table names missing modules {sorted(listed - modules)}"
