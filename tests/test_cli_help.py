"""Every command's --help works, and every daemon option is described."""

from __future__ import annotations

import dataclasses

import pytest

from streamseg.cli import main
from streamseg.commands.serve import field_help
from streamseg.config import DaemonConfig


def test_every_daemon_option_is_described():
    described = field_help(DaemonConfig)
    missing = [f.name for f in dataclasses.fields(DaemonConfig) if not described.get(f.name)]
    assert not missing, f"DaemonConfig fields without a description: {missing}"


@pytest.mark.parametrize("command", ["info", "segment", "eval", "serve", "replay", "listen",
                                     "demo"])
def test_help(command, capsys):
    with pytest.raises(SystemExit) as info:
        main([command, "--help"])
    assert info.value.code == 0
    assert "usage: streamseg " + command in capsys.readouterr().out
