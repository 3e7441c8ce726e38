"""``structbench check --junit-xml``: one JUnit test case per gate, valid
against the common JUnit schema (the Jenkins/Ant junit-4 layout; a minimal
XSD is embedded below), a failing gate's message naming value, threshold
and campaign."""
from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import pytest
from junitparser import Failure, JUnitXml
from lxml import etree

import structbench as sb
from structbench.cli import main
from structbench.evaluation.junit import junit_xml

ROOT = Path(__file__).resolve().parents[1]

# The junit-4 layout (Jenkins' dtkit junit-4.xsd, Ant's XMLJUnitResultFormatter)
# restated, stricter where structbench promises more: a testsuite's name, tests,
# failures, errors, skipped and time and a testcase's name, classname and time
# are required here; a failure's type is optional as in junit-4 (pytest's own
# reports leave it out), and structbench's own reports are checked for it apart.
JUNIT_XSD = b"""<?xml version="1.0" encoding="UTF-8"?>
<xs:schema xmlns:xs="http://www.w3.org/2001/XMLSchema" elementFormDefault="qualified">
  <xs:simpleType name="seconds">
    <xs:restriction base="xs:decimal"><xs:minInclusive value="0"/></xs:restriction>
  </xs:simpleType>
  <xs:simpleType name="hostname">
    <xs:restriction base="xs:token"><xs:minLength value="1"/></xs:restriction>
  </xs:simpleType>
  <xs:complexType name="problem" mixed="true">
    <xs:attribute name="message" type="xs:string"/>
    <xs:attribute name="type" type="xs:string"/>
  </xs:complexType>
  <xs:complexType name="output">
    <xs:simpleContent><xs:extension base="xs:string"/></xs:simpleContent>
  </xs:complexType>
  <xs:element name="properties">
    <xs:complexType>
      <xs:sequence>
        <xs:element name="property" minOccurs="0" maxOccurs="unbounded">
          <xs:complexType>
            <xs:attribute name="name" type="xs:token" use="required"/>
            <xs:attribute name="value" type="xs:string" use="required"/>
          </xs:complexType>
        </xs:element>
      </xs:sequence>
    </xs:complexType>
  </xs:element>
  <xs:element name="testcase">
    <xs:complexType>
      <xs:choice minOccurs="0" maxOccurs="unbounded">
        <xs:element name="skipped" type="problem"/>
        <xs:element name="error" type="problem"/>
        <xs:element name="failure" type="problem"/>
        <xs:element name="system-out" type="output"/>
        <xs:element name="system-err" type="output"/>
        <xs:element ref="properties"/>
      </xs:choice>
      <xs:attribute name="name" type="xs:token" use="required"/>
      <xs:attribute name="classname" type="xs:token" use="required"/>
      <xs:attribute name="time" type="seconds" use="required"/>
      <xs:attribute name="assertions" type="xs:string"/>
      <xs:attribute name="status" type="xs:string"/>
      <xs:attribute name="file" type="xs:string"/>
      <xs:attribute name="line" type="xs:string"/>
    </xs:complexType>
  </xs:element>
  <xs:element name="testsuite">
    <xs:complexType>
      <xs:sequence>
        <xs:element ref="properties" minOccurs="0"/>
        <xs:element ref="testcase" minOccurs="0" maxOccurs="unbounded"/>
        <xs:element name="system-out" type="output" minOccurs="0"/>
        <xs:element name="system-err" type="output" minOccurs="0"/>
      </xs:sequence>
      <xs:attribute name="name" type="xs:token" use="required"/>
      <xs:attribute name="tests" type="xs:nonNegativeInteger" use="required"/>
      <xs:attribute name="failures" type="xs:nonNegativeInteger" use="required"/>
      <xs:attribute name="errors" type="xs:nonNegativeInteger" use="required"/>
      <xs:attribute name="skipped" type="xs:nonNegativeInteger" use="required"/>
      <xs:attribute name="time" type="seconds" use="required"/>
      <xs:attribute name="disabled" type="xs:nonNegativeInteger"/>
      <xs:attribute name="timestamp" type="xs:dateTime"/>
      <xs:attribute name="hostname" type="hostname"/>
      <xs:attribute name="id" type="xs:string"/>
      <xs:attribute name="package" type="xs:token"/>
    </xs:complexType>
  </xs:element>
  <xs:element name="testsuites">
    <xs:complexType>
      <xs:sequence>
        <xs:element ref="testsuite" minOccurs="0" maxOccurs="unbounded"/>
      </xs:sequence>
      <xs:attribute name="name" type="xs:string"/>
      <xs:attribute name="time" type="seconds"/>
      <xs:attribute name="tests" type="xs:nonNegativeInteger"/>
      <xs:attribute name="failures" type="xs:nonNegativeInteger"/>
      <xs:attribute name="disabled" type="xs:nonNegativeInteger"/>
      <xs:attribute name="errors" type="xs:nonNegativeInteger"/>
    </xs:complexType>
  </xs:element>
</xs:schema>
"""

CAMPAIGN = f'''
name = "frame-junit"
structure = "{ROOT / "docs" / "examples" / "shear-frame-3.toml"}"
seed = 1

[check.modal]
freq_error_pct_max = 0.5
mac_min = 0.99
coverage_max = 0.5

[[tests]]
name = "impulse"
dt = 0.002
duration = 30.0

[[tests.excitation]]
kind = "impulse"
node = 1
dir = "x"
impulse = 100.0
method = "initial-velocity"

[[tests.sensors]]
nodes = "all"
quantities = ["acceleration"]
'''


def validated(data: bytes) -> etree._Element:
    """The parsed document, after it validated against :data:`JUNIT_XSD`."""
    schema = etree.XMLSchema(etree.fromstring(JUNIT_XSD))
    document = etree.fromstring(data)
    schema.assertValid(document)
    return document


@pytest.fixture(scope="module")
def frame(tmp_path_factory) -> Path:
    """A free-decay frame campaign identified by the modal method: two of
    its three gates pass, ``coverage_max = 0.5`` fails (coverage is 1)."""
    base = tmp_path_factory.mktemp("junit")
    (base / "frame.toml").write_text(CAMPAIGN)
    assert sb.run_campaign(base / "frame.toml", base / "out", jobs=0).failed == 0
    sb.identify(base / "out", "modal", jobs=1)
    return base / "out"


def test_check_writes_one_valid_testcase_per_gate(frame, tmp_path, capsys):
    report = tmp_path / "gates.xml"
    assert main(["check", str(frame), "--junit-xml", str(report)]) == 1
    printed = capsys.readouterr().out.splitlines()
    document = validated(report.read_bytes())
    suites = document.findall("testsuite")
    assert len(suites) == 1 and suites[0].get("name") == "structbench check frame-junit"
    assert (suites[0].get("tests"), suites[0].get("failures"), suites[0].get("errors")) == ("3", "1", "0")
    cases = {c.get("name"): c for c in suites[0].findall("testcase")}
    assert sorted(cases) == ["coverage_max", "freq_error_pct_max", "mac_min"]
    assert {c.get("classname") for c in cases.values()} == {"structbench.frame-junit.modal"}
    failure = cases["coverage_max"].find("failure")
    assert failure is not None and failure.get("type") == "structbench.GateFailed"
    assert failure.get("message") == "modal coverage_max = 1 > 0.5 (threshold) in campaign frame-junit"
    assert "threshold: 0.5" in failure.text and "campaign: frame-junit" in failure.text
    assert cases["mac_min"].find("failure") is None and cases["freq_error_pct_max"].find("failure") is None
    assert len(printed) == 4 and printed[-1] == "2 passed, 1 failed"  # the text output is unchanged


def test_rows_name_their_campaign_and_can_be_limited_to_results(frame):
    rows = sb.check(frame, results=["modal"])
    assert {r["campaign"] for r in rows} == {"frame-junit"} and len(rows) == 3
    with pytest.raises(sb.UserError, match="no results file modal-x.json"):
        sb.check(frame, results=["modal-x"])


def test_the_schema_rejects_what_ci_servers_would_not_read():
    """Negative controls: the validator does fail."""
    good = junit_xml([{"campaign": "c", "results": "r", "gate": "rms_max", "value": 0.1, "threshold": 0.2,
                       "ok": True}])
    validated(good)
    for bad in (good.replace(b' tests="1" failures="0" errors="0" skipped', b' failures="0" errors="0" skipped'),
                good.replace(b'classname="structbench.c.r" ', b""),
                good.replace(b"<testcase ", b"<testcas ").replace(b"</testcase>", b"</testcas>")):
        assert bad != good
        with pytest.raises(etree.DocumentInvalid):
            validated(bad)


def test_odd_names_and_values_stay_valid():
    rows = [{"campaign": 'a <b> & "c"', "results": "peaks-ci", "gate": "freq_error_pct_max", "value": math.nan,
             "threshold": 1.0, "ok": False},
            {"campaign": 'a <b> & "c"', "results": "peaks-ci", "gate": "mac_min", "value": math.inf,
             "threshold": 0.9, "ok": True},
            {"campaign": "other", "results": "modal", "gate": "mac_min", "value": 0.5, "threshold": 0.9, "ok": False}]
    document = validated(junit_xml(rows, time=1.5))
    assert [s.get("tests") for s in document.findall("testsuite")] == ["2", "1"]
    assert document.get("tests") == "3" and document.get("failures") == "2"
    messages = [f.get("message") for f in document.iter("failure")]
    assert messages == ['peaks-ci freq_error_pct_max = nan > 1 (threshold) in campaign a <b> & "c"',
                        "modal mac_min = 0.5 < 0.9 (threshold) in campaign other"]
    validated(junit_xml([]))


def test_a_report_that_cannot_be_written_is_a_user_error(frame, tmp_path, capsys):
    assert main(["check", str(frame), "--junit-xml", str(tmp_path / "missing" / "gates.xml")]) == 2
    err = capsys.readouterr().err
    assert "--junit-xml" in err and "missing" in err and "Traceback" not in err
    assert main(["check", str(frame), "--junit-xml", str(tmp_path)]) == 2
    assert "is a folder" in capsys.readouterr().err


def test_pytest_own_junit_report_passes_the_same_schema(tmp_path):
    """The schema is the one CI servers read pytest's reports with: a report
    pytest writes itself (a pass and a failure) validates too."""
    (tmp_path / "test_two.py").write_text("def test_ok():\n    pass\n\n\ndef test_bad():\n    assert 1 == 2\n")
    subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "--junitxml", "pytest.xml",
                    "test_two.py"], cwd=tmp_path, capture_output=True, timeout=120)
    document = validated((tmp_path / "pytest.xml").read_bytes())
    assert document.find("testsuite").get("failures") == "1"


def test_a_junit_reader_reads_the_gates_as_it_reads_pytest_reports(tmp_path):
    """junitparser (a JUnit reader of CI-side tools) reads pytest's own report
    and structbench's alike: per case its name, class, pass or failure and the
    failure's message; totals as the documents state them."""
    (tmp_path / "test_two.py").write_text("def test_ok():\n    pass\n\n\ndef test_bad():\n    assert 1 == 2\n")
    subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "--junitxml", "pytest.xml",
                    "test_two.py"], cwd=tmp_path, capture_output=True, timeout=120)
    theirs = JUnitXml.fromfile(str(tmp_path / "pytest.xml"))
    assert [(c.name, c.is_passed) for s in theirs for c in s] == [("test_ok", True), ("test_bad", False)]
    rows = [{"campaign": "beam", "results": "modal", "gate": "mac_min", "value": 0.97, "threshold": 0.9, "ok": True},
            {"campaign": "beam", "results": "modal", "gate": "freq_error_pct_max", "value": 2.5, "threshold": 1.0,
             "ok": False},
            {"campaign": "frame", "results": "least-squares", "gate": "rms_max", "value": 0.01, "threshold": 0.02,
             "ok": True}]
    (tmp_path / "gates.xml").write_bytes(junit_xml(rows, time=3.0))
    ours = JUnitXml.fromfile(str(tmp_path / "gates.xml"))
    assert (ours.tests, ours.failures, ours.errors) == (3, 1, 0)
    read = [(s.name, c.classname, c.name, c.is_passed, [r.message for r in c.result if isinstance(r, Failure)])
            for s in ours for c in s]
    assert read == [("structbench check beam", "structbench.beam.modal", "mac_min", True, []),
                    ("structbench check beam", "structbench.beam.modal", "freq_error_pct_max", False,
                     ["modal freq_error_pct_max = 2.5 > 1 (threshold) in campaign beam"]),
                    ("structbench check frame", "structbench.frame.least-squares", "rms_max", True, [])]


def test_a_check_that_cannot_be_made_is_an_error_case(tmp_path, capsys):
    """No gates to evaluate (here: no truth.json): exit 2, and the report says why."""
    folder = tmp_path / "bare"
    folder.mkdir()
    (folder / "campaign.toml").write_text('name = "bare"\n[check]\nrms_max = 0.1\n')
    report = tmp_path / "gates.xml"
    assert main(["check", str(folder), "--junit-xml", str(report)]) == 2
    err = capsys.readouterr().err.strip()
    document = validated(report.read_bytes())
    (suite,) = document.findall("testsuite")
    assert (suite.get("tests"), suite.get("errors"), suite.get("failures")) == ("1", "1", "0")
    error = suite.find("testcase").find("error")
    assert error.get("type") == "structbench.UserError" and error.get("message") in err and "no truth.json" in err
