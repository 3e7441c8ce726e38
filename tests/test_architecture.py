"""The data flows one way: models -> FMU -> bench -> traces -> identifier -> scoring."""
import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def imported_packages(package: str) -> dict[str, set[str]]:
    """Top-level packages imported by each module of ``package``."""
    out = {}
    for path in (ROOT / package).rglob("*.py"):
        found = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                found |= {a.name.split(".")[0] for a in node.names}
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                found.add(node.module.split(".")[0])
        out[str(path.relative_to(ROOT))] = found
    return out


@pytest.mark.parametrize("package, forbidden", [("identifier", {"bench"}), ("models", {"bench", "identifier"})])
def test_no_import_against_the_data_flow(package, forbidden):
    bad = {module: sorted(found & forbidden) for module, found in imported_packages(package).items()
           if found & forbidden}
    assert not bad


def test_identifiers_never_name_the_truth_file():
    """No string in identifier/ code (docstrings aside) names truth.json."""
    for path in (ROOT / "identifier").rglob("*.py"):
        tree = ast.parse(path.read_text())
        docstrings = {id(node.value) for node in ast.walk(tree) if isinstance(node, ast.Expr)}
        strings = [node.value for node in ast.walk(tree) if isinstance(node, ast.Constant)
                   and isinstance(node.value, str) and id(node) not in docstrings]
        assert not [s for s in strings if "truth" in s], path
