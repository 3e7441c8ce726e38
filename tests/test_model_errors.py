"""Bad model input: clear errors naming the field; the CLI exits 2 without a traceback."""
import subprocess
import sys

import numpy as np
import pytest

from structbench.cli import main
from structbench.models import ModelError, load_model
from structbench.models.library import beam

FRAME = """
name = "f"
[[nodes]]
id = 1
[[nodes]]
id = 2
x = 1.0
[[elements]]
type = "{etype}"
nodes = [1, {other}]
dir = "x"
{param} = {value}
"""


def write(tmp_path, text):
    path = tmp_path / "model.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize("etype, other, param, value, field, words", [
    ("mass", "", "m", "-1.0", "elements[1].m", "positive"),
    ("mass", "", "m", "0.0", "elements[1].m", "positive"),
    ("girder", "2", "m", "1.0", "elements[1].type", "unknown element type"),
    ("spring", "3", "k", "1.0", "elements[1].nodes", "node 3 is referenced but not defined"),
    ("spring", "2", "k", '"stiff"', "elements[1].k", "expected a number"),
])
def test_bad_fields_are_named(tmp_path, etype, other, param, value, field, words):
    text = FRAME.format(etype=etype, other=other, param=param, value=value).replace("[1, ]", "[1]")
    with pytest.raises(ModelError) as err:
        load_model(write(tmp_path, text))
    assert err.value.field == field
    assert words in str(err.value)


def test_malformed_toml_names_the_line(tmp_path):
    with pytest.raises(ModelError, match="malformed TOML.*line 2"):
        load_model(write(tmp_path, 'name = "x"\n[[nodes]\nid = 1\n'))


def test_an_oversized_model_file_is_refused_unread(tmp_path, capsys):
    path = write(tmp_path, FRAME.format(etype="spring", other="2", param="k", value="1.0") + "#" * 2**22)
    assert main(["modes", str(path)]) == 2
    assert (f"model.toml: model file of {path.stat().st_size} bytes, over the limit of 4194304 (4 MiB)"
            in capsys.readouterr().err)


def test_unknown_key_is_named(tmp_path):
    text = FRAME.format(etype="spring", other="2", param="k", value="1.0") + "colour = 'red'\n"
    with pytest.raises(ModelError, match=r"elements\[1\]\.colour"):
        load_model(write(tmp_path, text))


def test_parameter_list_of_the_wrong_length():
    with pytest.raises(ModelError, match="parameters"):
        beam("b", [1.0, 2.0], [1.0], 2.0)
    model = load_model("ch4-cantilever-case1")
    with pytest.raises(ModelError, match="length 3, expected 18"):
        model.mass(np.ones(3))


def test_cli_reports_user_errors_with_status_2(tmp_path, capsys):
    path = write(tmp_path, FRAME.format(etype="mass", other="", param="m", value="-2").replace("[1, ]", "[1]"))
    assert main(["modes", str(path)]) == 2
    err = capsys.readouterr().err
    assert "elements[1].m" in err and "Traceback" not in err


def test_cli_subprocess_has_no_traceback(tmp_path):
    res = subprocess.run([sys.executable, "-m", "structbench.cli", "modes", "no-such-structure"],
                         capture_output=True, text=True)
    assert res.returncode == 2
    assert "unknown structure 'no-such-structure'" in res.stderr
    assert "Traceback" not in res.stderr


def test_cli_json_prints_table_3_4(capsys):
    import json
    assert main(["modes", "ch3-free-free-beam", "--json"]) == 0
    omega = json.loads(capsys.readouterr().out)["omega"]
    assert omega[:2] == [0.0, 0.0]
    assert round(omega[9], 6) == 2.575960
