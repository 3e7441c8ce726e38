"""Every ```python example of README.md and docs/ runs the three ways people
run it: saved as a script (``python example.py``, no ``__main__`` guard),
with ``python -c``, and as a notebook cell (``exec`` in an interpreter that
already ran other cells, whose ``__main__`` has no ``__file__``). Each way
runs in its own temporary folder that links the repository's ``campaigns/``
and ``docs/``, so the examples' relative paths work and their outputs stay
out of the checkout. A new example is found by itself; it then needs its
expected output in :data:`EXPECTED`."""
from __future__ import annotations

import re
import subprocess
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCUMENTS = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
LINKED = ("campaigns", "docs")  # what the examples read, relative to the repository's folder
WAYS = ("script", "-c", "notebook")
TIMEOUT = 600.0  # s per run

# A notebook kernel, roughly: the user's namespace is a __main__ module without
# __file__ (as IPython's), a thread runs beside the cells, an earlier cell has
# already run, and a cell's last expression is displayed.
KERNEL = '''\
import ast, sys, threading, types

user = types.ModuleType("__main__")
sys.modules["__main__"] = user
threading.Thread(target=threading.Event().wait, daemon=True).start()


def run_cell(source):
    tree = ast.parse(source)
    last = tree.body.pop() if tree.body and isinstance(tree.body[-1], ast.Expr) else None
    exec(compile(tree, "<cell>", "exec"), user.__dict__)
    if last is not None:
        value = eval(compile(ast.Expression(last.value), "<cell>", "eval"), user.__dict__)
        if value is not None:
            print(repr(value))


run_cell("import numpy as np\\nwarm = np.linalg.eigvalsh(np.diag(np.arange(50.0))).sum()")
with open(sys.argv[1]) as cell:
    run_cell(cell.read())
'''


@dataclass(frozen=True)
class Example:
    """One ```python block: the document, the heading it is under, its code."""

    document: str
    heading: str
    code: str

    @property
    def key(self) -> str:
        return f"{self.document}: {self.heading}"


def examples(path: Path) -> list[Example]:
    """The ```python blocks of a Markdown file, each under its nearest heading."""
    found: list[Example] = []
    per_heading: dict[str, int] = {}
    heading, fence, body = "", None, []
    for line in path.read_text().splitlines():
        if line.startswith("```"):
            if fence is None:
                fence, body = line[3:].strip(), []
                continue
            if fence == "python":
                per_heading[heading] = n = per_heading.get(heading, 0) + 1
                found.append(Example(str(path.relative_to(ROOT)), heading + (f" ({n})" if n > 1 else ""),
                                     "\n".join(body) + "\n"))
            fence = None
        elif fence is not None:
            body.append(line)
        elif line.startswith("#"):
            heading = line.lstrip("#").strip()
    return found


EXAMPLES = [e for path in DOCUMENTS for e in examples(path)]


def readme_from_python(lines: list[str], way: str, cwd: Path) -> None:
    assert lines[0] == "2 tests done, 0 failed"
    assert "'label': 'mass[1]'" in lines[1] and "'unit': 'kg/m'" in lines[1]
    rms = float(lines[2].split(":")[1])
    assert 0.005 < rms < 0.027  # chapter 3, m = 8: the campaign's own gate (dissertation 0.0183)
    assert lines[3:] and all(line.startswith("least-squares-m8 ") and line.endswith("PASS") for line in lines[3:])
    assert (cwd / "out" / "ch3" / "results" / "least-squares-m8.json").is_file()


def campaign_format_from_python(lines: list[str], way: str, cwd: Path) -> None:
    assert lines == (["(0, 'done')"] if way == "notebook" else [])  # only a notebook shows the last value
    assert len(list((cwd / "runs" / "ch3" / "traces").glob("*.h5"))) == 120


def openblas_registers(lines: list[str], way: str, cwd: Path) -> None:
    assert lines[:-1] and all(len(line.split()) == 3 for line in lines[:-1])  # BLAS: API, version, architecture
    assert re.fullmatch(r"irfft after zgemm: [\d.]+ ms; with the registers cleared: [\d.]+ ms; ratio [\d.]+",
                        lines[-1])


def plan_verify(lines: list[str], way: str, cwd: Path) -> None:
    parameter, ratio = lines[0].rsplit("} ", 1)
    assert len(lines) == 1 and parameter.startswith("{'label': 'mass[1]', 'unit': 'kg/m', 'value': 8.4, ")
    assert 0.0 < float(parameter.rsplit(": ", 1)[1]) < 0.05  # kg/m: the bound on the 8.4 kg/m element mass
    assert 0.7 < float(ratio) < 1.4  # achieved / predicted spread over 20 repetitions (median over parameters)


# what each example prints (its stdout lines), by "document: heading"
EXPECTED: dict[str, Callable[[list[str], str, Path], None]] = {
    "README.md: From Python": readme_from_python,
    "docs/campaign-format.md: From Python": campaign_format_from_python,
    "docs/openblas-dirty-avx.md: OpenBLAS's AVX-512 complex kernels leave the vector registers dirty":
        openblas_registers,
    "docs/plan.md: Planning a test (`structbench plan`)": plan_verify,
}


def run(example: Example, way: str, tmp_path: Path) -> subprocess.CompletedProcess:
    """``example`` run one way, in a fresh folder that looks like the repository's."""
    cwd = tmp_path / "cwd"
    cwd.mkdir()
    for name in LINKED:
        (cwd / name).symlink_to(ROOT / name)
    if way == "script":
        (cwd / "example.py").write_text(example.code)
        command = [sys.executable, "example.py"]
    elif way == "-c":
        command = [sys.executable, "-c", example.code]
    else:
        (tmp_path / "kernel.py").write_text(KERNEL)
        (tmp_path / "cell.py").write_text(example.code)
        command = [sys.executable, str(tmp_path / "kernel.py"), str(tmp_path / "cell.py")]
    return subprocess.run(command, cwd=cwd, capture_output=True, text=True, timeout=TIMEOUT)


def test_every_example_states_its_output():
    assert sorted(e.key for e in EXAMPLES) == sorted(EXPECTED)


@pytest.mark.parametrize("way", WAYS)
@pytest.mark.parametrize("example", EXAMPLES, ids=lambda e: e.key)
def test_example_runs(example, way, tmp_path):
    done = run(example, way, tmp_path)
    assert done.returncode == 0, done.stderr
    assert "Traceback" not in done.stderr, done.stderr  # also none from a worker process
    EXPECTED[example.key](done.stdout.splitlines(), way, tmp_path / "cwd")
