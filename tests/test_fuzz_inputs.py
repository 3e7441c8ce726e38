"""Fuzzing of every input format (hypothesis, profile "ci" of conftest.py):
mutated campaign and model files, damaged trace files, damaged results and
truth files, random external-FMU mappings. Every case succeeds or exits 2
with one error line; none raises (tests/fuzz_cases.py holds the properties)."""
from __future__ import annotations

import json

import pytest
from hypothesis import given, strategies as st

import fuzz_cases as cases
from fuzz_strategies import mappings, mutated_json, mutated_toml, trace_damage

CAMPAIGN_TEXTS = [cases.parsed(p) for p in cases.CAMPAIGNS]
MODEL_TEXTS = [cases.parsed(p) for p in cases.MODELS]


@pytest.fixture(scope="module")
def scratch(tmp_path_factory):
    return tmp_path_factory.mktemp("fuzz")


@pytest.fixture(scope="module")
def fmu_dir(tmp_path_factory):
    return tmp_path_factory.mktemp("fuzz-fmus")


@pytest.fixture(scope="module")
def trace_seed(tmp_path_factory):
    return cases.trace_seed(tmp_path_factory.mktemp("fuzz-traces"))


@pytest.fixture(scope="module")
def score_seed(tmp_path_factory):
    return cases.score_seed(tmp_path_factory.mktemp("fuzz-score"))


@pytest.fixture(scope="module")
def external_seed(tmp_path_factory):
    return cases.external_seed(tmp_path_factory.mktemp("fuzz-external"))


@given(text=st.sampled_from(CAMPAIGN_TEXTS).flatmap(lambda c: mutated_toml(*c)))
def test_campaign_files(text, scratch, fmu_dir):
    cases.campaign_case(text, scratch, fmu_dir)


@given(text=st.sampled_from(MODEL_TEXTS).flatmap(lambda m: mutated_toml(*m)))
def test_model_files(text, scratch):
    cases.model_case(text, scratch)


@given(damage=trace_damage(), which=st.integers(0, 3), method=st.sampled_from(["least-squares", "rayleigh"]))
def test_trace_files(damage, which, method, trace_seed, scratch):
    cases.trace_case(damage, which, method, trace_seed, scratch)


@given(data=st.data())
def test_results_and_truth_files(data, score_seed, scratch):
    target = data.draw(st.sampled_from(["results/least-squares.json", "results/rayleigh.json", "truth.json"]))
    text = data.draw(mutated_json(json.loads((score_seed / target).read_text())))
    cases.results_case(text, target, data.draw(st.sampled_from(["score", "check"])), score_seed, scratch)


@given(mapping=mappings())
def test_external_fmu_mappings(mapping, external_seed, scratch):
    cases.mapping_case(mapping, external_seed, scratch)


def test_the_seeds_themselves_pass(scratch, fmu_dir, trace_seed, score_seed, external_seed):
    """The unmutated inputs succeed, so the properties test damage, not broken seeds."""
    text, _ = CAMPAIGN_TEXTS[0]
    assert cases.campaign_case(text, scratch, fmu_dir) == 0
    assert cases.model_case(MODEL_TEXTS[0][0], scratch) == 0
    assert cases.trace_case(("attribute", {"index": 0, "value": "synthetic"}), 0, "least-squares",
                            trace_seed, scratch) in (0, 2)
    assert cases.results_case((score_seed / "truth.json").read_text(), "truth.json", "score", score_seed, scratch) == 0
    assert cases.mapping_case({"force": "F_{node}_{dir}", "displacement": "u_{node}_{dir}",
                               "acceleration": "a_{node}_{dir}"}, external_seed, scratch) == 0
