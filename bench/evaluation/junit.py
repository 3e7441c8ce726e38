"""The ``[check]`` gates as a JUnit XML report (``structbench check --junit-xml``).

The common JUnit layout that CI servers read (the Jenkins/Ant junit-4 schema):
``testsuites > testsuite`` (one per campaign) ``> testcase`` (one per gate,
``classname`` ``structbench.<campaign>.<results file stem>``, ``name`` the
gate) ``> failure`` for a gate that is not met, its ``message`` naming the
value, the threshold and the campaign. When the gates cannot be evaluated
(no results, a damaged file), the report holds one test case ``check`` with
an ``error`` carrying that message, so the CI server shows why.
"""
from __future__ import annotations

import math
import os
import socket
import xml.etree.ElementTree as ET
from collections.abc import Mapping, Sequence
from datetime import datetime, timezone
from pathlib import Path
from typing import Any

from structbench.models.errors import UserError

FAILURE_TYPE = "structbench.GateFailed"
ERROR_TYPE = "structbench.UserError"


def _number(value: float) -> str:
    return f"{value:.6g}" if math.isfinite(value) else str(value)


def failure_message(row: Mapping[str, Any]) -> str:
    """One line: ``peaks freq_error_pct_max = 0.0712 > 0.001 (threshold) in campaign frame-peaks``."""
    relation = "<" if row["gate"].endswith("_min") else ">"
    if row["ok"]:
        relation = {"<": ">=", ">": "<="}[relation]
    return (f"{row['results']} {row['gate']} = {_number(row['value'])} {relation} "
            f"{_number(row['threshold'])} (threshold) in campaign {row.get('campaign', '?')}")


def error_xml(campaign: str, message: str, time: float = 0.0) -> bytes:
    """A JUnit XML document of one test case ``check`` of ``campaign`` in error (``message``)."""
    root = ET.Element("testsuites", name="structbench check", tests="1", failures="0", errors="1", time=f"{time:.3f}")
    suite = ET.SubElement(root, "testsuite", name=f"structbench check {campaign}", tests="1", failures="0",
                          errors="1", skipped="0", time=f"{time:.3f}",
                          timestamp=datetime.now(timezone.utc).replace(microsecond=0, tzinfo=None).isoformat(),
                          hostname=socket.gethostname() or "localhost", id="0", package=f"structbench.{campaign}")
    case = ET.SubElement(suite, "testcase", name="check", classname=f"structbench.{campaign}", time=f"{time:.3f}")
    ET.SubElement(case, "error", message=message, type=ERROR_TYPE).text = message + "\n"
    ET.indent(root)
    return ET.tostring(root, encoding="utf-8", xml_declaration=True) + b"\n"


def junit_xml(rows: Sequence[Mapping[str, Any]], time: float = 0.0, timestamp: datetime | None = None) -> bytes:
    """The gate rows of :func:`~structbench.evaluation.gates.check_campaign`
    (each with ``campaign``, ``results``, ``gate``, ``value``, ``threshold``,
    ``ok``) as a JUnit XML document, UTF-8; ``time`` (s) is the check's
    duration, spread evenly over the test cases."""
    stamp = (timestamp or datetime.now(timezone.utc)).replace(microsecond=0, tzinfo=None).isoformat()
    per_case = time / len(rows) if rows else 0.0
    campaigns: dict[str, list[Mapping[str, Any]]] = {}
    for row in rows:
        campaigns.setdefault(str(row.get("campaign", "campaign")), []).append(row)
    failed = sum(not r["ok"] for r in rows)
    root = ET.Element("testsuites", name="structbench check", tests=str(len(rows)), failures=str(failed),
                      errors="0", time=f"{time:.3f}")
    for index, (campaign, group) in enumerate(campaigns.items()):
        suite = ET.SubElement(root, "testsuite", name=f"structbench check {campaign}", tests=str(len(group)),
                              failures=str(sum(not r["ok"] for r in group)), errors="0", skipped="0",
                              time=f"{per_case * len(group):.3f}", timestamp=stamp,
                              hostname=socket.gethostname() or "localhost", id=str(index),
                              package=f"structbench.{campaign}")
        for row in group:
            case = ET.SubElement(suite, "testcase", name=row["gate"],
                                 classname=f"structbench.{campaign}.{row['results']}", time=f"{per_case:.3f}")
            detail = (f"campaign: {campaign}\nresults: {row['results']}\ngate: {row['gate']}\n"
                      f"value: {row['value']!r}\nthreshold: {row['threshold']!r}\n")
            if not row["ok"]:
                ET.SubElement(case, "failure", message=failure_message(row), type=FAILURE_TYPE).text = detail
            else:
                ET.SubElement(case, "system-out").text = detail
    ET.indent(root)
    return ET.tostring(root, encoding="utf-8", xml_declaration=True) + b"\n"


def write_junit(rows: Sequence[Mapping[str, Any]], path: str | Path, time: float = 0.0,
                error: tuple[str, str] | None = None) -> Path:
    """Write :func:`junit_xml` of ``rows`` to ``path`` (atomically: a reader
    never sees half a file), or with ``error`` = (campaign, message)
    :func:`error_xml`; its folder must exist."""
    path = Path(path)
    if path.is_dir():
        raise UserError("is a folder, expected a file name", field=f"--junit-xml {path}")
    if not path.parent.is_dir():
        raise UserError(f"no folder {path.parent} to write the report into", field=f"--junit-xml {path}")
    partial = path.with_name(f".{path.name}.{os.getpid()}.partial")
    try:
        partial.write_bytes(junit_xml(rows, time) if error is None else error_xml(*error, time))
        os.replace(partial, path)
    except OSError as err:
        partial.unlink(missing_ok=True)
        raise UserError(f"cannot write: {err.strerror}", field=f"--junit-xml {path}") from None
    return path
