"""``structbench methods``: the identification methods, what each needs and its options."""
from __future__ import annotations

import argparse
import json
import textwrap
from typing import Any

from structbench import api

HELP = "list the identification methods (plugins included): the channels each needs, its model and options"
MODEL = {"required": "a model (--model, or the campaign's structure)", "optional": "a model is optional",
         "none": "no model"}


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--json", action="store_true", help="print the methods as JSON")


def describe(method: Any) -> dict[str, Any]:
    """One method as plain data: name, help, channels, model, prior, options {name: {default, choices}}."""
    return {"name": method.name, "help": method.help, "channels": method.channels, "model": method.model,
            "needs_prior": method.postulated,
            "options": {k: {"default": v, "choices": list(method.choices.get(k, ())) or None}
                        for k, v in method.defaults.items()}}


def _text(doc: dict[str, Any]) -> str:
    wrap = lambda head, text: textwrap.fill(text, 100, initial_indent=f"  {head:9s}",  # noqa: E731
                                            subsequent_indent=" " * 11)
    model = MODEL.get(doc["model"], doc["model"])
    if doc["needs_prior"]:
        model += "; starting values from a prior (--prior, prior=, a campaign [prior] or a -postulated variant)"
    options = "; ".join(f"{k}={o['default']}" + (f" ({'|'.join(map(str, o['choices']))})" if o["choices"] else "")
                        for k, o in doc["options"].items()) or "none"
    return "\n".join([doc["name"], wrap("what", doc["help"]), wrap("needs", doc["channels"]), wrap("model", model),
                      wrap("options", options)])


def run(args: argparse.Namespace) -> int:
    docs = [describe(m) for m in api.methods().values()]
    print(json.dumps(docs, indent=1, default=str) if args.json else "\n\n".join(map(_text, docs)))
    return 0
