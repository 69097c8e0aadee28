"""The speed suite: run it, keep its results, compare them with the recorded run.

Run: ``.venv/bin/python benchmarks/speed.py [--bench REGEX] [--against COMMIT]``
(``pip install -e '.[bench]'`` brings asv; the whole suite takes about five minutes: run it
on a quiet machine, ``uptime`` first).

The benchmarks are an airspeed velocity suite (``benchmarks/speed/suite/``, one module per
area: ``aca``, ``lof``, ``daemon``, ``scaleout``, ``misc``), run with asv in this very environment
(``--python=same``) and recorded under the current commit in
``benchmarks/speed/results/streamseg-vm/`` (JSON, committed with the change that made them).
This script then prints one table: every figure, the recorded run's (the newest result of
another commit, or ``--against``), their ratio, and ``WORSE`` where a figure got more than
20 % worse (lower is better except for rates, ratios over a baseline and fractions taken).
Exit code 1 when any did. Tests never depend on these timings.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import math
import subprocess
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent / "speed"
MACHINE = "streamseg-vm"
RESULTS = HERE / "results" / MACHINE
#: units whose figures are better when higher; every other figure is a cost
HIGHER_IS_BETTER = {"frames/s", "jobs/s", "x raw", "x Octave", "of offered"}
TOLERANCE = 0.20


def asv(*args) -> None:
    cmd = [sys.executable, "-m", "asv", *args]
    subprocess.run(cmd, cwd=HERE, check=True)


def load(path: Path) -> dict:
    """``{(benchmark, param): value}`` of one asv result file."""
    data = json.loads(path.read_text())
    cols = data["result_columns"]
    out = {}
    for name, row in data["results"].items():
        values = row[cols.index("result")]
        params = row[cols.index("params")] or [[None]]
        combos = [[]]
        for plist in params:
            combos = [c + [p] for c in combos for p in plist]
        for combo, value in zip(combos, values or [], strict=False):
            key = (name, ",".join(str(p) for p in combo if p is not None))
            out[key] = value
    return {"commit": data["commit_hash"], "date": data["date"], "values": out}


def runs() -> list:
    return sorted(
        (load(p) for p in RESULTS.glob("*.json") if p.name != "machine.json"),
        key=lambda r: r["date"],
    )


def units() -> dict:
    path = HERE / "results" / "benchmarks.json"
    meta = json.loads(path.read_text()) if path.exists() else {}
    return {name: b.get("unit", "") for name, b in meta.items() if isinstance(b, dict)}


def compare(new: dict, old: dict | None, unit_of: dict) -> tuple[list, list]:
    """Table rows ``(benchmark, param, value, unit, recorded, ratio, flag)`` and the keys of
    the figures more than :data:`TOLERANCE` worse than the recorded ones."""
    rows, worse = [], []
    for key in sorted(new["values"]):
        value = new["values"][key]
        if value is None or (isinstance(value, float) and math.isnan(value)):
            continue
        unit = unit_of.get(key[0], "")
        before = (old or {}).get("values", {}).get(key)
        ratio, flag = None, ""
        if isinstance(before, (int, float)) and before and not math.isnan(before):
            ratio = value / before
            higher = unit in HIGHER_IS_BETTER
            if (ratio < 1 / (1 + TOLERANCE)) if higher else (ratio > 1 + TOLERANCE):
                flag = "WORSE"
                worse.append(key)
        rows.append((key[0], key[1], value, unit, before, ratio, flag))
    return rows, worse


def fmt(v) -> str:
    if v is None:
        return "-"
    if isinstance(v, float):
        return f"{v:,.0f}" if abs(v) >= 1000 else f"{v:.3g}"
    return str(v)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bench", help="only the benchmarks matching this regular expression")
    ap.add_argument(
        "--against",
        help="compare with this commit's results (default: the newest run of another commit)",
    )
    ap.add_argument("--no-run", action="store_true", help="compare the newest results only")
    args = ap.parse_args(argv)
    commit = subprocess.run(
        ["git", "rev-parse", "HEAD"], cwd=HERE, check=True, capture_output=True, text=True
    ).stdout.strip()
    if not args.no_run and importlib.util.find_spec("asv") is None:
        print(
            "speed.py: asv is not installed in this environment: pip install -e '.[bench]' "
            "(or pip install asv), or --no-run to compare the recorded results only",
            file=sys.stderr,
        )
        return 2
    if not args.no_run:
        asv("machine", "--machine", MACHINE, "--yes")
        asv(
            "run",
            "--python=same",
            "--set-commit-hash",
            commit,
            "--machine",
            MACHINE,
            "--show-stderr",
            *(["--bench", args.bench] if args.bench else []),
        )
    done = runs()
    new = next((r for r in reversed(done) if r["commit"] == commit), None) or done[-1]
    if args.against:
        old = next((r for r in done if r["commit"].startswith(args.against)), None)
        if old is None:
            raise SystemExit(f"no recorded results for {args.against} in {RESULTS}")
    else:
        old = next((r for r in reversed(done) if r["commit"] != new["commit"]), None)
    rows, worse = compare(new, old, units())
    print(
        f"\nspeed suite at {new['commit'][:10]}, against "
        f"{old['commit'][:10] if old else 'nothing recorded'}"
    )
    print("| benchmark | param | value | unit | recorded | ratio | |")
    print("|---|---|---|---|---|---|---|")
    for name, param, value, unit, before, ratio, flag in rows:
        print(
            f"| {name} | {param} | {fmt(value)} | {unit} | {fmt(before)} | "
            f"{'-' if ratio is None else f'{ratio:.2f}'} | {flag} |"
        )
    if worse:
        print(
            f"\n{len(worse)} figure(s) more than {TOLERANCE:.0%} worse than recorded: "
            + ", ".join(f"{n}[{p}]" if p else n for n, p in worse)
        )
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
