"""Every file path the documentation cites exists in the repository (as a
repository path: ``bench/harness/run.py``, not the installed
``structbench/harness/run.py``)."""
from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PATH = re.compile(r"(?<![\w./-])((?:\.\./)?[A-Za-z_][\w.-]*/[\w./-]*\.(?:py|md|toml))\b")
PLACEHOLDERS = ("out/", "DIR/", "PATH/", "OUT/", "my", "your")  # example outputs and user files


def documents() -> list[Path]:
    return [ROOT / "README.md", ROOT / "fmus" / "README.md", *sorted((ROOT / "docs").rglob("*.md")),
            *sorted((ROOT / "campaigns").glob("*.toml"))]


def cited(path: Path) -> set[str]:
    return {m for m in PATH.findall(path.read_text()) if not m.startswith(PLACEHOLDERS)}


def exists(reference: str, document: Path) -> bool:
    if reference.startswith("shared/"):  # the project's shared folder beside the repository
        reference = "../" + reference
    return any((base / reference).exists() for base in (ROOT, document.parent))


def test_cited_paths_exist():
    missing = {str(d.relative_to(ROOT)): sorted(r for r in cited(d) if not exists(r, d)) for d in documents()}
    assert not {d: r for d, r in missing.items() if r}
