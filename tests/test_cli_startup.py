"""`streamseg --help` loads only the command table: no numpy, numba or ZeroMQ, and no command
module (each is imported when its command runs). Checked on the modules a fresh interpreter
loaded, not on a clock."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from streamseg.commands import COMMANDS

PROBE = """
import json, sys
from streamseg.cli import main
try:
    main({argv!r})
except SystemExit:
    pass
print(json.dumps(sorted(sys.modules)), file=sys.stderr)
"""


def loaded_modules(argv) -> set:
    run = subprocess.run(
        [sys.executable, "-c", PROBE.format(argv=argv)], capture_output=True, text=True, timeout=120
    )
    return set(json.loads(run.stderr.strip().splitlines()[-1]))


def test_top_level_help_imports_no_heavy_module():
    loaded = loaded_modules(["--help"])
    assert "streamseg.cli" in loaded
    heavy = {"numpy", "numba", "scipy", "zmq", "msgpack"} & loaded
    assert not heavy
    commands = {m for m, _ in COMMANDS.values()} & loaded
    assert not commands


def test_a_command_imports_its_own_module_only():
    loaded = loaded_modules(["keys", "--help"])
    others = {m for name, (m, _) in COMMANDS.items() if name != "keys"} & loaded
    assert "streamseg.commands.keys" in loaded
    assert not others


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_every_command_parser_builds_on_its_own(command, capsys):
    from streamseg.cli import main

    with pytest.raises(SystemExit) as info:
        main([command, "--help"])
    assert info.value.code == 0
    assert f"usage: streamseg {command}" in capsys.readouterr().out


def test_segment_with_aca_loads_neither_the_cut_detector_nor_the_daemons_parts():
    """What ``segment --method aca`` imports is what it runs: no LOF kernels, no sockets, no
    Dask, no sklearn, no plotting, no scipy.linalg (numba's BLAS check and the spectral
    embedding's LAPACK call are met without it) (each would add to the command's start)."""
    data = Path(__file__).resolve().parents[1] / "data" / "cmu86"
    loaded = loaded_modules(
        [
            "segment",
            str(data / "86_01.amc.gz"),
            "--skeleton",
            str(data / "86.asf"),
            "--method",
            "aca",
            "--json",
        ]
    )
    assert "streamseg.offline.haca" in loaded  # it ran
    unused = {
        "streamseg.offline.lof",
        "streamseg._kernels.lof",
        "zmq",
        "dask",
        "distributed",
        "sklearn",
        "matplotlib",
        "aiohttp",
        "scipy.sparse",
        "scipy.linalg",
        "scipy.optimize",
    } & loaded
    assert not unused
