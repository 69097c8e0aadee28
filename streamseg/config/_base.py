"""Validation helpers shared by the config dataclasses."""

from __future__ import annotations

from dataclasses import fields

from streamseg.exceptions import ParameterError


def _check(name: str, value, ok: bool, expected: str) -> None:
    """Raise a ParameterError naming the field, the value and what was expected."""
    if not ok:
        raise ParameterError(f"{name}={value!r} is invalid: expected {expected}")


def config_from_dict(cls, values: dict):
    """Build config ``cls`` from a mapping (e.g. a TOML table), rejecting unknown keys."""
    known = {f.name for f in fields(cls)}
    unknown = sorted(set(values) - known)
    if unknown:
        raise ParameterError(
            f"unknown {cls.__name__} option(s) {', '.join(unknown)}; "
            f"known: {', '.join(sorted(known))}"
        )
    return cls(**values)
