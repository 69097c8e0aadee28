"""Helpers shared by the benchmark scripts: where things are, the labelled sets, tables.

Every script runs on its own (``.venv/bin/python benchmarks/NAME.py``) and prints the table
of ``docs/results.md`` it owns; this module only saves them repeating themselves (timing:
``streamseg.evaluation.corpus.timed``).
"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "data"
if str(ROOT) not in sys.path:  # run from a clone without installing: the package beside us
    sys.path.insert(0, str(ROOT))


def labelled(sets=None):
    """The labelled recordings of ``data/`` (``eval --all data``'s), optionally some sets."""
    from streamseg.evaluation.labelled_sets import labelled_sets

    return labelled_sets(DATA, sets=sets)


def markdown_table(header, rows) -> str:
    """A markdown table of ``header`` (strings) and ``rows`` (sequences of cells)."""
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)
