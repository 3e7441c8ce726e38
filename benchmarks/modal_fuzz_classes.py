"""Why the modal method invents modes and misses supported ones on the
held-out profile of :mod:`modal_fuzz` (``--kind unseen``): every invented
mode and every missed supported mode classified by mechanism, by record
kind (random response or free decay) and sensor count.

    python benchmarks/modal_fuzz_classes.py --first 100000 --seeds 200 [--save rows.jsonl] [--load rows.jsonl]

Run it on tuning seeds only (``modal_fuzz.TUNING``, or a fresh range such
as 300,000+ then counted as tuning): the classes steer changes of the
method. ``--save`` keeps each record's identification (modes, rejected
candidates, harmonics, stable poles near the true modes) so that the
classes can be recomputed (``--load``) without identifying again.

Invented (a reported mode the scoring of :func:`modal_fuzz.unseen` does not
match one to one to a true mode):

- ``duplicate``: within 5 % (or 4 se) of a true mode that a nearer reported
  mode took;
- ``biased``: the nearest true mode is untaken and within 25 %, but further
  than ``max(5 %, 4 se)``;
- ``below`` / ``above``: under 0.75 x the lowest true mode or over 1.25 x
  the highest;
- ``noise``: none of these (a pole of the noise between true modes).

Missed (a supported true mode no reported mode took):

- ``close pair``: another true mode within ``max(3 %, 2 (zeta_a omega_a +
  zeta_b omega_b))``;
- ``off``: a reported mode lies within 25 % but further than the matching
  tolerance (counted invented as ``biased`` too);
- ``rejected: <reason>``: a candidate within ``max(2 %, 3 zeta omega)`` is
  in ``details.rejected`` (reason's first words) or ``details.harmonics``;
- ``unclustered``: stable poles lie within that band but never formed a
  mode of ``min_fraction`` of the orders;
- ``unstable``: poles lie there at some orders, none stable;
- ``absent``: no pole of any order lies there.
"""
from __future__ import annotations

import argparse
import json
import sys
from collections import Counter
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
import modal_fuzz  # noqa: E402

from structbench.identifier import modal  # noqa: E402
from structbench.identifier.errors import IdentificationError  # noqa: E402


def identify(seed: int) -> dict:
    """One record of the held-out profile identified: the truth, the record's
    kind and size, the reported modes, rejected candidates, harmonics and the
    stabilisation diagram's poles (all orders), as plain lists."""
    rec = modal_fuzz.unseen_record(seed)
    row = {"seed": seed, "kind": rec["kind"], "sensors": int(rec["y"].shape[0]), "samples": int(rec["y"].shape[1]),
           "quantities": sorted(set(rec["quantities"])), "omega": rec["omega"].tolist(),
           "zeta": rec["zeta"].tolist(), "snr": rec["snr"].tolist(), "periods": rec["periods"].tolist(),
           "decays": rec["decays"].tolist()}
    try:
        res = modal.identify([modal_fuzz.unseen_trace(rec)], **modal_fuzz.OPTIONS)
    except IdentificationError as exc:
        return row | {"error": str(exc)}
    d = res.details
    return row | {"w": res.omega, "se": res.omega_std, "z": res.damping, "sz": res.damping_std,
                  "support": d["support"], "coherence": d["coherence"], "record_s": d["record_s"],
                  "rejected": d["rejected"], "harmonics": [h["omega"] for h in d["harmonics"]],
                  "diagram": {k: d["stabilisation"][k] for k in ("omega", "stable", "order")}}


REASONS = {"periods in": "periods", "decay times": "decay times", "jackknife": "not found again",
           "no finite": "no finite error", "x omega (over": "imprecise", "of the model orders": "stable < 50 %, loose",
           "duplicate": "duplicate", "coherence": "temporal coherence", "matched-filter": "under the noise"}


def reason(text: str) -> str:
    """The class of a ``details.rejected`` reason (its numbers dropped)."""
    return next((name for key, name in REASONS.items() if key in text), text)


def classify(row: dict) -> tuple[list[str], list[str], list[tuple[bool, bool]], int]:
    """The invented modes' and the missed supported modes' classes of one
    identified record (module docstring), whether the 95 % intervals of
    the matched modes cover omega and zeta, and the count of supported modes."""
    if "error" in row:
        return [], [], [], 0
    omega, zeta = np.array(row["omega"]), np.array(row["zeta"])
    w, se = np.array(row["w"]), np.array(row["se"])
    z, sz = np.array(row["z"]), np.array(row["sz"])
    cover: list[tuple[bool, bool]] = []
    taken: dict[int, int] = {}
    invented = []
    order = np.argsort(np.abs(w[:, None] - omega[None, :]).min(axis=1)) if w.size else []
    for i in order:
        j = int(np.argmin(np.abs(omega - w[i])))
        tol = max(0.05 * omega[j], 4 * se[i])
        if abs(w[i] - omega[j]) <= tol and j not in taken:
            taken[j] = i
            cover.append((abs(w[i] - omega[j]) <= 1.96 * se[i], abs(z[i] - zeta[j]) <= 1.96 * sz[i]))
            continue
        if abs(w[i] - omega[j]) <= tol:
            invented.append("duplicate")
        elif abs(w[i] / omega[j] - 1) < 0.25 and j not in taken:
            invented.append("biased")
        elif w[i] < 0.75 * omega.min():
            invented.append("below")
        elif w[i] > 1.25 * omega.max():
            invented.append("above")
        else:
            invented.append("noise")
    supported = (np.array(row["periods"]) >= 20) & (np.array(row["decays"]) >= 5) & (np.array(row["snr"]) >= 1)
    missed = []
    dg = row["diagram"]
    pw, stable = np.array(dg["omega"]), np.array(dg["stable"], bool)
    for j in np.flatnonzero(supported):
        if j in taken:
            continue
        band = max(0.02, 3 * zeta[j]) * omega[j]
        others = np.delete(np.arange(omega.size), j)
        gap = np.abs(omega[others] - omega[j])
        if others.size and np.any(gap < np.maximum(0.03 * omega[j], 2 * (zeta[others] * omega[others]
                                                                          + zeta[j] * omega[j]))):
            missed.append("close pair")
        elif (w.size and np.min(np.abs(w / omega[j] - 1)) < 0.25
              and np.argmin(np.abs(w - omega[j])) not in taken.values()):
            missed.append("off")
        elif any(abs(r["omega"] - omega[j]) < band for r in row["rejected"]):
            r = min(row["rejected"], key=lambda r: abs(r["omega"] - omega[j]))
            missed.append("rejected: " + reason(r["reason"]))
        elif any(abs(h - omega[j]) < band for h in row["harmonics"]):
            missed.append("rejected: harmonic")
        elif np.any(stable & (np.abs(pw - omega[j]) < band)):
            missed.append("unclustered")
        elif np.any(np.abs(pw - omega[j]) < band):
            missed.append("unstable")
        else:
            missed.append("absent")
    return invented, missed, cover, int(supported.sum())


def group(row: dict) -> str:
    m = row["sensors"]
    return f"{row['kind']}, {'1 sensor' if m == 1 else '2-5 sensors' if m <= 5 else '6+ sensors'}"


def report(rows: list[dict]) -> str:
    """The classes' counts, over all records and by record group."""
    inv, mis = Counter(), Counter()
    by_group: dict[str, Counter] = {}
    cover, supported, records = [], 0, 0
    for row in rows:
        a, b, c, s = classify(row)
        cover += c
        supported += s
        records += bool(a)
        inv.update(a)
        mis.update(b)
        g = by_group.setdefault(group(row), Counter())
        g.update("invented " + x for x in a)
        g.update("missed " + x for x in b)
    cw, cz = (100 * np.mean([c[k] for c in cover]) if cover else np.nan for k in (0, 1))
    lines = [f"{len(rows)} records ({sum('error' in r for r in rows)} refused): invented {sum(inv.values())} in "
             f"{records} records; found {supported - sum(mis.values())}/{supported} = "
             f"{100 * (1 - sum(mis.values()) / max(supported, 1)):.1f} %; coverage omega {cw:.1f} %, zeta {cz:.1f} % "
             f"(of {len(cover)})",
             f"invented {sum(inv.values())}: " + ", ".join(f"{k} {v}" for k, v in inv.most_common()),
             f"missed supported {sum(mis.values())}: " + ", ".join(f"{k} {v}" for k, v in mis.most_common())]
    count = Counter(group(row) for row in rows if "error" not in row)
    lines += [f"  {g} ({count[g]} records): " + ", ".join(f"{k} {v}" for k, v in c.most_common())
              for g, c in sorted(by_group.items())]
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--first", type=int, default=modal_fuzz.TUNING.start)
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--list", type=int, nargs="*", default=[], help="these seeds instead of --first/--seeds")
    parser.add_argument("--save", type=Path)
    parser.add_argument("--load", type=Path, action="append", default=[])
    parser.add_argument("--option", action="append", default=[], metavar="KEY=VALUE")
    parser.add_argument("--verbose", action="store_true", help="one line per record with a class")
    args = parser.parse_args(argv)
    modal_fuzz.OPTIONS.update(item.split("=", 1) for item in args.option)
    if args.load:
        rows = [json.loads(line) for path in args.load for line in path.read_text().splitlines()]
    else:
        seeds = args.list or list(range(args.first, args.first + args.seeds))
        if any(seed in modal_fuzz.HELD_OUT for seed in seeds):
            parser.error("held-out seeds are not for diagnosis")
        rows = []
        for seed in seeds:
            rows.append(identify(seed))
            if args.save:
                with args.save.open("a") as out:
                    out.write(json.dumps(rows[-1]) + "\n")
    if args.verbose:
        for row in rows:
            a, b, _, _ = classify(row)
            if a or b:
                print(row["seed"], group(row), "invented", a, "missed", b)
    print(report(rows))


if __name__ == "__main__":
    main()
