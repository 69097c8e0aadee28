"""Reading a TOML file the command line names, with one-line errors."""

from __future__ import annotations

from streamseg.exceptions import ParameterError


def read_toml(path, name: str, missing: str = "no such file") -> dict:
    """The document of TOML file ``path``; ``name`` starts each error's line (e.g. the option
    and the path), ``missing`` says what a missing file is."""
    try:
        import tomllib
    except ModuleNotFoundError:  # Python 3.10: the same parser, installed as a dependency
        import tomli as tomllib
    try:
        with open(path, "rb") as fh:
            return tomllib.load(fh)
    except FileNotFoundError:
        raise ParameterError(f"{name}: {missing}") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as err:
        raise ParameterError(f"{name}: not valid TOML ({err})") from None
