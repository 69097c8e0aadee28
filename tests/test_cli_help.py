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


@pytest.mark.parametrize(
    "command", ["info", "segment", "eval", "serve", "replay", "listen", "demo"]
)
def test_help(command, capsys):
    with pytest.raises(SystemExit) as info:
        main([command, "--help"])
    assert info.value.code == 0
    assert "usage: streamseg " + command in capsys.readouterr().out


def test_example_config_is_valid_and_spells_out_the_defaults():
    from pathlib import Path

    from streamseg.config import ACAConfig, LOFConfig, RepetitionConfig
    from streamseg.daemon import load_config

    path = Path(__file__).resolve().parents[1] / "docs" / "streamseg.toml"
    daemon, lof, aca, rep = load_config(path)
    assert daemon == DaemonConfig()
    assert lof == LOFConfig()
    assert aca == ACAConfig()
    assert rep == RepetitionConfig()
    # every key spelled out (an option whose default is unset, as a comment), so the file
    # documents every option
    import dataclasses
    import re

    text = path.read_text()
    tables = dict(re.findall(r"^\[(\w+)\]\n(.*?)(?=^\[|\Z)", text, re.M | re.S))
    for name, cls in (
        ("daemon", DaemonConfig),
        ("lof", LOFConfig),
        ("aca", ACAConfig),
        ("repetitions", RepetitionConfig),
    ):
        keys = set(re.findall(r"^#? ?(\w+) =", tables[name], re.M))
        missing = {f.name for f in dataclasses.fields(cls)} - keys
        assert not missing, f"[{name}] lacks {sorted(missing)}"
