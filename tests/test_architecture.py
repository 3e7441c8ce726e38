"""The package's shape: one namespace, the import rules between its parts,
small modules. The data flows one way: models -> fmus -> harness -> traces ->
identifier -> evaluation; the CLI sits on the API alone."""
import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
# folder -> its name inside the structbench namespace (pyproject's package-dir)
PACKAGES = {"models": "structbench.models", "fmus": "structbench.fmus", "identifier": "structbench.identifier",
            "bench": "structbench"}


def module_name(path: Path) -> str:
    folder, *rest = path.relative_to(ROOT).with_suffix("").parts
    parts = [PACKAGES.get(folder, folder), *rest]
    return ".".join(p for p in parts if p != "__init__")


def imports(path: Path) -> set[str]:
    """Absolute names of the structbench modules imported by one file
    (relative imports resolved; ``from X import y`` gives ``X.y``)."""
    package = module_name(path) if path.name == "__init__.py" else module_name(path).rpartition(".")[0]
    found = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.split(".")[:len(package.split(".")) - node.level + 1]
                base = ".".join(anchor + ([base] if base else []))
            found |= {f"{base}.{a.name}" for a in node.names} | {base}
    return {name for name in found if name.split(".")[0] in ("structbench", *PACKAGES)}


def sources(folder: str) -> list[Path]:
    return sorted((ROOT / folder).rglob("*.py"))


def under(name: str, *prefixes: str) -> bool:
    return any(name == p or name.startswith(p + ".") for p in prefixes)


def test_nothing_imports_the_old_top_level_names():
    bad = {str(p.relative_to(ROOT)): sorted(n for n in imports(p) if not under(n, "structbench"))
           for folder in (*PACKAGES, "tests", "benchmarks") for p in sources(folder)}
    assert not {k: v for k, v in bad.items() if v}


@pytest.mark.parametrize("folder, allowed", [
    ("models", ("structbench.models",)),
    ("fmus", ("structbench.fmus", "structbench.models")),
    ("identifier", ("structbench.identifier", "structbench.models")),
])
def test_layer_imports_only_what_it_may(folder, allowed):
    bad = {str(p.relative_to(ROOT)): sorted(n for n in imports(p) if not under(n, *allowed)) for p in sources(folder)}
    assert not {k: v for k, v in bad.items() if v}


def test_the_cli_imports_only_the_api():
    bad = {str(p.relative_to(ROOT)): sorted(n for n in imports(p)
                                            if not under(n, "structbench.cli", "structbench.api") and n != "structbench")
           for p in sources("bench/cli")}
    assert not {k: v for k, v in bad.items() if v}


def test_harness_and_identification_keep_to_their_side():
    harness = {n for p in sources("bench/harness") for n in imports(p)}
    identification = {n for p in sources("bench/dispatch") for n in imports(p)}
    assert not [n for n in harness if under(n, "structbench.identifier", "structbench.dispatch",
                                             "structbench.evaluation", "structbench.cli")]
    assert not [n for n in identification if under(n, "structbench.harness", "structbench.fmus",
                                                   "structbench.evaluation", "structbench.cli")]


def test_labdata_writes_and_reads_traces_only_through_the_trace_modules():
    allowed = ("structbench.labdata", "structbench.harness.trace_writer", "structbench.models.channels",
               "structbench.identifier.io.traces", "structbench.models.errors")
    bad = {str(p.relative_to(ROOT)): sorted(n for n in imports(p) if not under(n, *allowed))
           for p in sources("bench/labdata")}
    assert not {k: v for k, v in bad.items() if v}


def test_every_package_init_says_what_it_owns_and_may_import():
    for init in [ROOT / f / "__init__.py" for f in PACKAGES] + sorted((ROOT / "bench").glob("*/__init__.py")):
        doc = ast.get_docstring(ast.parse(init.read_text()))
        assert doc and "import" in doc.lower(), init


def test_no_module_above_400_lines():
    long = {str(p.relative_to(ROOT)): n for folder in PACKAGES for p in sources(folder)
            if (n := len(p.read_text().splitlines())) > 400}
    assert not long


def test_no_two_modules_differ_only_in_form():
    """score/scores, check/checks, report/reporting ... would make a reader guess."""
    def stem(name: str) -> str:
        for suffix in ("ing", "es", "s"):
            if name.endswith(suffix) and len(name) > len(suffix) + 2:
                return name[:-len(suffix)]
        return name

    for folder in [ROOT / f for f in PACKAGES] + sorted(p for p in (ROOT / "bench").iterdir() if p.is_dir()):
        names = [p.stem for p in folder.glob("*.py") if p.stem not in ("__init__", "__main__")]
        stems = [stem(n) for n in names]
        assert len(set(stems)) == len(stems), (folder, sorted(names))


def test_identifiers_never_name_the_truth_file():
    """No string in identifier/ code (docstrings aside) names truth.json."""
    for path in sources("identifier"):
        tree = ast.parse(path.read_text())
        docstrings = {id(node.value) for node in ast.walk(tree) if isinstance(node, ast.Expr)}
        strings = [node.value for node in ast.walk(tree) if isinstance(node, ast.Constant)
                   and isinstance(node.value, str) and id(node) not in docstrings]
        assert not [s for s in strings if "truth" in s], path


def test_no_import_cycles():
    """No module reaches itself through imports (those under TYPE_CHECKING
    included): package __init__ files aside, each module only depends on
    modules that do not depend on it."""
    files = {module_name(p): p for folder in PACKAGES for p in sources(folder)}
    modules = {name for name, path in files.items() if path.name != "__init__.py"}

    def targets(name: str) -> set[str]:
        found = set()
        for imported in imports(files[name]):
            while imported and imported not in modules:
                imported = imported.rpartition(".")[0]
            if imported and imported != name:
                found.add(imported)
        return found

    graph = {name: targets(name) for name in modules}
    cycles, state = [], {}

    def visit(name: str, path: list[str]) -> None:
        state[name] = "open"
        for nxt in sorted(graph[name]):
            if state.get(nxt) == "open":
                cycles.append(path[path.index(nxt):] + [nxt] if nxt in path else [name, nxt])
            elif nxt not in state:
                visit(nxt, path + [nxt])
        state[name] = "done"

    for name in sorted(graph):
        if name not in state:
            visit(name, [name])
    assert not cycles


GARBAGE_CAMPAIGN = """name = "frame-prior"
structure = "frame.toml"
seed = 7

[prior]
scale = [0.5, 2.0]
seed = 11

[[tests]]
name = "random"
dt = 0.01
duration = 60.0
sensors = [{nodes = [1, 2, 3], dirs = ["x"], quantities = ["displacement", "velocity", "acceleration"]},
           {nodes = [3], dirs = ["x"], quantities = ["force"]}]
noise = {sensor = 0.01}
[[tests.excitation]]
kind = "random"
node = 3
dir = "x"
rms = 1000.0
band = [0.5, 100.0]
"""


def test_identification_never_reads_the_true_values(tmp_path):
    """Issue 23: the same results (least squares from the topology, modal,
    updating from the campaign's [prior]) when the stored true values -
    truth.json and the values of the TOML model the traces name - are
    replaced by garbage afterwards. Before the prior, updating started from
    the structure's own (true) values and its results changed."""
    import json
    import re

    import numpy as np
    import structbench as sb

    frame = (ROOT / "docs" / "examples" / "shear-frame-3.toml").read_text()
    (tmp_path / "frame.toml").write_text(frame)
    (tmp_path / "camp.toml").write_text(GARBAGE_CAMPAIGN)
    out = tmp_path / "out"
    assert sb.run_campaign(tmp_path / "camp.toml", out, jobs=0).failed == 0
    assert (out / "prior.json").is_file()

    def identify_all() -> dict[str, list]:
        docs = {"least-squares": sb.identify(out, "least-squares", jobs=1),
                "modal": sb.identify(out, "modal", jobs=1, quantity="displacement")}
        docs["updating"] = sb.identify(out, "updating", jobs=1)
        return {k: d["runs"] for k, d in docs.items()}

    before = identify_all()
    rng = np.random.default_rng(0)
    garbage = re.sub(r"^(\s*[mkc] = )[0-9.e+]+", lambda m: f"{m.group(1)}{rng.uniform(1, 1e7):.6e}", frame,
                     flags=re.M)
    assert garbage != frame
    (tmp_path / "frame.toml").write_text(garbage)
    truth = json.loads((out / "truth.json").read_text())
    for p in truth["parameters"]:
        p["value"] = float(rng.uniform(1, 1e7))
    (out / "truth.json").write_text(json.dumps(truth))
    after = identify_all()
    for method in before:
        assert json.dumps(before[method]) == json.dumps(after[method]), method
    assert before["updating"][0]["parameters"][0]["initial"] != truth["parameters"][0]["value"]
