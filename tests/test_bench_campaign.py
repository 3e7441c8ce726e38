"""Campaign files: validation before any simulation, with key and line."""
from __future__ import annotations

from pathlib import Path

import pytest

import structbench.harness.fmu_session
from structbench.harness.campaign import CampaignError, load_campaign
from structbench.cli import main
from structbench import run_campaign
from structbench.harness.toml_lines import key_lines

CAMPAIGNS = Path(__file__).resolve().parent.parent / "campaigns"

GOOD = """\
name = "good"
structure = "ch4-cantilever-case1"
seed = 1

[check]
rms_max = 0.05

[defaults]
dt = 0.01
sensors = [{nodes = "all", quantities = ["displacement"]},
           {nodes = [7], dirs = ["w"], quantities = ["force"]}]

[[tests]]
name = "sine"
duration = 2.0
[[tests.excitation]]
kind = "harmonic"
node = 7
dir = "w"
amplitude = 1.0
omega = 0.5

[[tests]]
name = "stepped"
[tests.noise]
sensor = 0.01
[[tests.excitation]]
kind = "stepped-sine"
node = 7
dir = "w"
amplitude = 1.0
omegas = [0.5, 1.0, 1.5]
ramp = 1.0
settle = 0.5
window = 1.005
"""

# (replace this, by that) -> the key and line the error must name
BAD = {
    "unknown structure": (('structure = "ch4-cantilever-case1"', 'structure = "ch4-cantilever-case9"'),
                          "structure", 2),
    "unknown node": (("node = 7\ndir = \"w\"\namplitude = 1.0\nomega", "node = 70\ndir = \"w\"\namplitude = 1.0\nomega"),
                     "tests[1].excitation[1].node", 18),
    "unknown sensor node": (("nodes = [7]", "nodes = [8]"), "defaults.sensors[2].nodes", 11),
    "clamped node": (('nodes = [7], dirs = ["w"], quantities = ["force"]', 'nodes = [1], dirs = ["w"], '
                      'quantities = ["displacement"]'), "defaults.sensors[2].dirs", 11),
    "negative duration": (("duration = 2.0", "duration = -2.0"), "tests[1].duration", 15),
    "sampling slower than the step": (("dt = 0.01\n", "dt = 0.01\nstep = 0.02\n"), "defaults.dt", 9),
    "step not dividing dt": (("dt = 0.01\n", "dt = 0.01\nstep = 0.003\n"), "defaults.dt", 9),
    "unknown key": (("omega = 0.5", "omega = 0.5\nfrequency = 3.0"), "tests[1].excitation[1].frequency", 22),
    "unknown top key": (("seed = 1", "seed = 1\nseeds = 2"), "seeds", 4),
    "unknown noise key": (("sensor = 0.01", "sensor = 0.01\nratio = 0.02"), "tests[2].noise.ratio", 27),
    "unknown quantity": (('quantities = ["displacement"]}', 'quantities = ["strain"]}'),
                         "defaults.sensors[1].quantities[1]", 10),
    "load cell without actuator": (('nodes = [7], dirs = ["w"], quantities = ["force"]',
                                    'nodes = [6], dirs = ["w"], quantities = ["force"]'),
                                   "defaults.sensors[2].quantities", 11),
    "duplicate name": (("window = 1.005\n", 'window = 1.005\n[[tests]]\nname = "sine"\nduration = 1.0\n'
                                             'excitation = [{kind = "impulse", node = 7, dir = "w", impulse = 1.0}]\n'),
                       "tests[3].name", 37),
    "negative frequency": (("omegas = [0.5, 1.0, 1.5]", "omegas = [0.5, -1.0, 1.5]"),
                           "tests[2].excitation[1].omegas[2]", 32),
    "bad mode": (("sensor = 0.01", 'sensor = 0.01\nmode = "gain"'), "tests[2].noise.mode", 27),
    "bad realisation": (("window = 1.005\n", 'window = 1.005\n[[tests]]\nname = "ambient"\nduration = 1.0\n'
                                              '[[tests.excitation]]\nkind = "random"\nnode = 7\ndir = "w"\n'
                                              'rms = 1.0\nband = [0.0, 10.0]\nrealisation = "each"\n'),
                        "tests[3].excitation[1].realisation", 45),
}


def write(tmp_path: Path, text: str, name: str = "campaign.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


@pytest.fixture
def no_simulation(monkeypatch):
    """Any FMU session opened fails the test."""
    def forbidden(*args, **kwargs):
        raise AssertionError("an FMU was opened before validation finished")
    monkeypatch.setattr(structbench.harness.fmu_session, "FmuSession", forbidden)


def test_good_campaign_parses(tmp_path):
    campaign = load_campaign(write(tmp_path, GOOD))
    assert [t.name for t in campaign.tests] == ["sine", "stepped-01", "stepped-02", "stepped-03"]
    sine, stepped = campaign.tests[0], campaign.tests[2]
    assert sine.n_samples == 201 and sine.group == "sine"
    assert [c.name for c in sine.channels][:2] == ["displacement_2_w", "displacement_2_theta"]
    assert sine.channels[-1].name == "force_7_w" and len(sine.channels) == 13
    assert stepped.group == "stepped" and stepped.excitation[0].omega == 1.0
    assert stepped.duration == pytest.approx(2.51) and stepped.n_samples == 252  # ramp + settle + window, rounded up
    assert stepped.noise.ratio("displacement") == 0.01 and sine.noise.ratio("displacement") == 0.0
    assert campaign.check == {"rms_max": 0.05}
    assert len({t.seed(0) for t in campaign.tests}) == 4


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_campaign_fails_before_simulation(case, tmp_path, no_simulation):
    (old, new), key, line = BAD[case]
    assert old in GOOD
    path = write(tmp_path, GOOD.replace(old, new, 1))
    with pytest.raises(CampaignError) as err:
        run_campaign(path, tmp_path / "out", jobs=0)
    assert f"campaign.toml:{line}: {key}:" in str(err.value)
    assert not (tmp_path / "out").exists()


def test_cli_reports_key_and_line(tmp_path, capsys, no_simulation):
    path = write(tmp_path, GOOD.replace("duration = 2.0", "duration = -1"))
    assert main(["run", str(path), "--out", str(tmp_path / "out")]) == 2
    assert "campaign.toml:15: tests[1].duration: must be positive" in capsys.readouterr().err


def test_toml_syntax_error_names_the_line(tmp_path):
    with pytest.raises(CampaignError, match="line 3"):
        load_campaign(write(tmp_path, 'name = "x"\nstructure = "ch5-membrane"\ntests = = [\n'))


def test_key_lines_follow_tables_arrays_and_inline_tables():
    text = ('a = 1  # c\n[t]\nb = {c = 2, "d.e" = [1, {f = 3}]}\nx = [\n  1,\n  {y = 2},\n]\n'
            '[[u]]\nv = 1\n[[u]]\n[u.w]\nz = "s # not a comment"\n[[u.q]]\nr = 1\n')
    lines = key_lines(text)
    assert lines[("a",)] == 1
    assert lines[("t", "b", "c")] == 3 and lines[("t", "b", "d.e", 1, "f")] == 3
    assert lines[("t", "x", 1, "y")] == 6
    assert lines[("u", 0, "v")] == 9 and lines[("u", 1)] == 10
    assert lines[("u", 1, "w", "z")] == 12 and lines[("u", 1, "q", 0, "r")] == 14


def test_structure_from_a_toml_model(tmp_path):
    model = (Path(__file__).resolve().parent.parent / "docs" / "examples" / "shear-frame-3.toml").read_text()
    write(tmp_path, model, "frame.toml")
    campaign = load_campaign(write(tmp_path, 'structure = "frame.toml"\n[[tests]]\nname = "kick"\ndt = 0.01\n'
                                             'duration = 1.0\nexcitation = [{kind = "initial", node = 3, dir = "x", '
                                             'displacement = 0.01}]\nsensors = [{nodes = "all", '
                                             'quantities = ["acceleration"]}]\n'))
    assert campaign.structure == "shear-frame-3"
    assert [c.name for c in campaign.tests[0].channels] == [f"acceleration_{n}_x" for n in (1, 2, 3)]


@pytest.mark.parametrize("name, tests, channels, samples", [
    ("ch3", 2, {97}, {4001}), ("ch4-case1", 24, {12}, {8001}), ("ch4-case2", 24, {1}, {8001}),
    ("ch5-beam", 3, {20}, {10001, 120001}), ("ch5-membrane", 2, {32}, {10001}),
    ("ch5-damped", 2, {30, 10}, {20001, 288001})])
def test_dissertation_campaigns_load(name, tests, channels, samples):
    campaign = load_campaign(CAMPAIGNS / f"{name}.toml")
    assert len(campaign.tests) == tests
    assert {len(t.channels) for t in campaign.tests} == channels
    assert {t.n_samples for t in campaign.tests} == samples


def test_campaign_size_counts_traces_bytes_and_steps(tmp_path):
    size = load_campaign(write(tmp_path, GOOD)).size
    # sine: 201 samples; stepped: 3 tests of 252; each trace holds time, 13 channels and 1 commanded force
    assert (size.tests, size.trace_files) == (4, 4)
    assert size.total_bytes == 8 * (1 + 13 + 1) * (201 + 3 * 252)
    assert size.steps == 200 + 3 * 251
    assert str(size) == "4 tests, 4 trace files (about 115 kB), 953 FMU steps"


# [limits] appended to GOOD -> the [[tests]] entry and line named, and words of the message
LIMITS = {
    "trace_files = 3": ("tests[2]", 23, "stepped-03: 4 trace files so far (tests x repetitions), over "
                                        "limits.trace_files = 3"),
    "trace_bytes = 1e4": ("tests[1]", 13, "sine: a trace of 201 samples x 15 arrays is 24.1 kB, over "
                                          "limits.trace_bytes = 10000"),
    "total_bytes = 5e4": ("tests[2]", 23, "stepped-01: 54.4 kB of traces so far, over limits.total_bytes = 50000"),
    "model_dofs = 11": ("structure", 2, "ch4-cantilever-case1 has 12 free DOF, over limits.model_dofs = 11"),
    "files = 3": ("limits.files", 38, "unknown key in limits"),
    "trace_files = 0": ("limits.trace_files", 38, "must be at least 1"),
}


@pytest.mark.parametrize("limit", sorted(LIMITS))
def test_a_campaign_over_its_limits_fails_naming_the_test(limit, tmp_path, no_simulation):
    key, line, words = LIMITS[limit]
    with pytest.raises(CampaignError) as err:
        run_campaign(write(tmp_path, GOOD + f"\n[limits]\n{limit}\n"), tmp_path / "out", jobs=0)
    assert f"campaign.toml:{line}: {key}: {words}" in str(err.value)
    assert not (tmp_path / "out").exists()


def test_a_limit_can_be_raised(tmp_path):
    big = GOOD.replace('name = "sine"\n', 'name = "sine"\nrepetitions = 100000\n')
    with pytest.raises(CampaignError, match=r"tests\[2\]: stepped-01: 100001 trace files so far"):
        load_campaign(write(tmp_path, big))
    raised = load_campaign(write(tmp_path, big + "\n[limits]\ntrace_files = 200000\n"))
    assert raised.size.trace_files == 100003


def test_an_oversized_or_binary_campaign_file_is_refused_unread(tmp_path, capsys):
    path = write(tmp_path, GOOD + "#" * (4 * 2**20))
    assert main(["run", str(path), "--out", str(tmp_path / "out")]) == 2
    assert (f"campaign.toml: campaign file of {path.stat().st_size} bytes, over the limit of 4194304 (4 MiB)"
            in capsys.readouterr().err)
    path.write_bytes(GOOD.encode() + b"# \xff\n")
    assert main(["run", str(path), "--out", str(tmp_path / "out")]) == 2
    assert f"campaign.toml: campaign file is not UTF-8 text (byte {len(GOOD) + 2}: b'\\xff')" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()
