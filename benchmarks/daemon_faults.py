"""The daemon's fault catalogue: every case of every module in ``benchmarks/faults/`` against
a real ``streamseg serve`` subprocess, one table row per case: case, result, figure, pass.

Run: ``.venv/bin/python benchmarks/daemon_faults.py [--cases NAME,...] [--list]``

``--cases`` takes module names (``service``, ``log``, ...), case names (``"kill -9 and
restart"``) or the cases' function names; each case runs in a fresh temporary directory.
A module adds cases by listing them in its ``CASES`` (see ``benchmarks/faults/__init__.py``).
Exit status 1 when a case fails.
"""

from __future__ import annotations

import argparse
import importlib
import os
import pkgutil
import sys
import tempfile
import threading
import time
import traceback
from pathlib import Path

import faults
from _common import markdown_table


def all_cases() -> list:
    """``(module, function)`` of every case, modules in name order, cases in list order."""
    out = []
    for m in sorted(pkgutil.iter_modules(faults.__path__), key=lambda m: m.name):
        if not m.name.startswith("_"):
            mod = importlib.import_module(f"faults.{m.name}")
            out += [(m.name, fn) for fn in getattr(mod, "CASES", [])]
    return out


def name_of(fn) -> str:
    return getattr(fn, "case", fn.__name__)


def pick(cases: list, wanted: str | None) -> list:
    if not wanted:
        return cases
    keys = [w.strip() for w in wanted.split(",") if w.strip()]
    chosen = [(m, fn) for m, fn in cases if any(k in (m, name_of(fn), fn.__name__) for k in keys)]
    unknown = [k for k in keys if not any(k in (m, name_of(fn), fn.__name__) for m, fn in cases)]
    if unknown:
        sys.exit(f"daemon_faults: no case or module {', '.join(unknown)} (--list shows them)")
    return chosen


def run(fn) -> dict:
    """One case in a fresh directory; a case that raises is a failed row saying why."""
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.monotonic()
        try:
            r = fn(Path(tmp))
        except Exception as err:  # the table still gets its row
            traceback.print_exc()
            r = {
                "case": name_of(fn),
                "result": f"the case failed: {type(err).__name__}: {err}",
                "figure": "",
                "passed": False,
            }
        r["wall"] = time.monotonic() - t0
    return r


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", help="comma-separated modules or cases (default: all)")
    ap.add_argument("--list", action="store_true", help="list the cases and exit")
    args = ap.parse_args()
    cases = all_cases()
    if args.list:
        for m, fn in cases:
            print(f"{m}: {name_of(fn)}")
        return 0
    rows = []
    for _, fn in pick(cases, args.cases):
        rows.append(run(fn))
        r = rows[-1]
        print(
            f"{r['case']}: {'pass' if r['passed'] else 'FAIL'} ({r['wall']:.0f} s): "
            f"{r['result']}; {r['figure']}",
            file=sys.stderr,
        )
    print(
        markdown_table(
            ["case", "result", "figure", "pass"],
            [
                (r["case"], r["result"], r["figure"], "pass" if r["passed"] else "**FAIL**")
                for r in rows
            ],
        )
    )
    return 0 if all(r["passed"] for r in rows) else 1


if __name__ == "__main__":
    os.environ.setdefault("PYTHONUNBUFFERED", "1")
    threading.current_thread().name = "daemon-faults"
    sys.exit(main())
