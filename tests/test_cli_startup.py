"""The command line starts fast: ``--help`` (of structbench and of every
command) and ``import structbench`` load no numerical library, the public
names load on first use; and output piped into a reader that stops early
ends quietly."""
from __future__ import annotations

import json
import subprocess
import sys

import pytest

from structbench.cli.main import COMMANDS

HEAVY = ("numpy", "scipy", "h5py", "matplotlib", "fmpy", "dask")
LOADED = f"import sys, json; print(json.dumps(sorted(m for m in sys.modules if m.split('.')[0] in {HEAVY!r})))"


def loaded_after(code: str) -> list[str]:
    """The heavy modules a fresh interpreter holds after running ``code``."""
    res = subprocess.run([sys.executable, "-c", f"{code}\n{LOADED}"], capture_output=True, text=True, timeout=60)
    assert res.returncode == 0, res.stderr
    return json.loads(res.stdout.splitlines()[-1])


@pytest.mark.parametrize("argv", [["--help"]] + [[command, "--help"] for command in COMMANDS])
def test_help_loads_no_numerical_library(argv):
    code = (f"from structbench.cli import main\ntry:\n    main({argv!r})\nexcept SystemExit as end:\n"
            f"    assert end.code == 0, end.code")
    assert loaded_after(code) == []


def test_help_lists_every_command_and_the_methods():
    res = subprocess.run([sys.executable, "-m", "structbench.cli", "--help"], capture_output=True, text=True)
    assert res.returncode == 0 and all(command in res.stdout for command in COMMANDS)
    res = subprocess.run([sys.executable, "-m", "structbench.cli", "identify", "--help"], capture_output=True,
                         text=True)
    assert res.returncode == 0 and "{least-squares,perturbation,rayleigh,modal" in res.stdout
    assert "--estimator {bias-compensated,ols}" in res.stdout and "default 80" in res.stdout


def test_import_structbench_is_lazy_and_complete():
    code = ("import structbench as sb\n"
            "assert 'numpy' not in sys.modules\n"
            "assert set(sb.__all__) <= set(dir(sb))\n"
            "from structbench.harness.run import run_campaign\n"  # loads numpy: checked before
            "assert sb.run_campaign is run_campaign and callable(sb.identify)\n"
            "from structbench import *\n"
            "assert UserError is sb.UserError and Campaign is sb.Campaign")
    res = subprocess.run([sys.executable, "-c", "import sys\n" + code], capture_output=True, text=True)
    assert res.returncode == 0, res.stderr
    assert loaded_after("import structbench, structbench.api, structbench.cli") == []


def test_unknown_public_name_is_an_attribute_error():
    import structbench
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        structbench.nope  # noqa: B018


def test_identify_help_table_matches_the_method_registry():
    """--help shows the built-in methods' options from a table in the CLI
    (no identifier imported); it must say what api.methods() does."""
    from structbench import api
    from structbench.cli.identify import BUILTIN, PLUGIN_GROUP
    from structbench.dispatch.methods import GROUP

    known = api.methods()
    assert PLUGIN_GROUP == GROUP
    for name, (about, defaults, choices) in BUILTIN.items():
        assert (about, defaults, choices) == (known[name].help, dict(known[name].defaults),
                                              dict(known[name].choices)), name
    assert [m for m in known if m in BUILTIN] == list(BUILTIN)


def test_output_into_a_closed_pipe_ends_quietly():
    """``structbench ... | head``: the reader is gone before the command
    prints. Convention: no traceback, nothing on stderr, exit status 141
    (128 + SIGPIPE, what the shell reports for a Unix tool killed by SIGPIPE,
    so ``set -o pipefail`` scripts see the same as with ``cat``)."""
    proc = subprocess.Popen([sys.executable, "-m", "structbench.cli", "modes", "ch3-free-free-beam", "--count", "30"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.close()  # before the command has printed anything (importing the model takes longer)
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=60) == 141
    assert err == ""


def test_output_into_head_through_a_shell():
    res = subprocess.run(f"'{sys.executable}' -m structbench.cli modes --count 30 | head -n 1", shell=True,
                         capture_output=True, text=True, timeout=60)
    assert res.stdout.startswith("ch3-free-free-beam") and res.stdout.count("\n") == 1
    assert "Traceback" not in res.stderr and "BrokenPipe" not in res.stderr
