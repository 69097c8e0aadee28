"""The daemon's fault cases, one module per area; ``benchmarks/daemon_faults.py`` runs them.

Each module (not starting with ``_``) has ``CASES``: functions ``case(tmp: Path) -> dict``
that run one fault against a real ``streamseg serve`` subprocess (helpers in
:mod:`faults._served`) in the fresh directory ``tmp`` and return one row: ``case`` (its
name), ``result`` (what happened, in words), ``figure`` (the numbers: events lost, RSS peak,
times) and ``passed`` (bool).
"""
