"""``structbench check``: exit 1 when a threshold of the campaign's ``[check]`` table fails."""
from __future__ import annotations

import argparse
import tomllib
from pathlib import Path

from models.errors import UserError

from .check import evaluate
from .score import score_campaign

HELP = "gate: exit 1 if the campaign's [check] thresholds are not met by its scores"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("campaign_dir", type=Path, metavar="CAMPAIGN_DIR")


def run(args: argparse.Namespace) -> int:
    copy = args.campaign_dir / "campaign.toml"
    if not copy.is_file():
        raise UserError(f"no campaign.toml in {args.campaign_dir}", field="CAMPAIGN_DIR")
    check = tomllib.loads(copy.read_text()).get("check", {})
    if not check:
        raise UserError("the campaign file has no [check] table: nothing to gate on", field="check")
    rows = evaluate(check, score_campaign(args.campaign_dir))
    if not rows:
        raise UserError("no [check] threshold applies to the results present", field="check")
    for r in rows:
        print(f"{'PASS' if r['ok'] else 'FAIL'}  {r['results']:36s} {r['gate']:22s} "
              f"{r['value']:.4g} (threshold {r['threshold']:g})")
    failed = [r for r in rows if not r["ok"]]
    print(f"{len(rows) - len(failed)} passed, {len(failed)} failed")
    return 1 if failed else 0
