"""The API pages' cross-references: Sphinx roles in docstrings become optional autorefs
(docs/api/sphinx_roles.py, the griffe extension mkdocs.yml loads)."""

from __future__ import annotations

from pathlib import Path

import pytest

griffe = pytest.importorskip("griffe")
ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def package():
    ext = griffe.load_extensions(f"{ROOT / 'docs' / 'api' / 'sphinx_roles.py'}:SphinxRoles")
    return griffe.load(
        "streamseg", search_paths=[str(ROOT)], extensions=ext, docstring_parser="numpy"
    )


def _docstrings(obj, seen=None):
    seen = set() if seen is None else seen
    if id(obj) in seen:
        return
    seen.add(id(obj))
    if obj.docstring is not None:
        yield obj.path, obj.docstring.value
    for m in obj.members.values():
        if not m.is_alias:
            yield from _docstrings(m, seen)


def test_no_role_is_left_as_text(package):
    from importlib.util import module_from_spec, spec_from_file_location

    spec = spec_from_file_location("sphinx_roles", ROOT / "docs" / "api" / "sphinx_roles.py")
    mod = module_from_spec(spec)
    spec.loader.exec_module(mod)
    left = [(path, m[0]) for path, text in _docstrings(package) for m in mod.ROLE.finditer(text)]
    assert not left, left[:5]


def test_roles_resolve_to_full_paths_relative_names_included(package):
    lof = package["offline.lof.LOFSegmenter"].docstring.value
    # ``:meth:`fit``` in the class's docstring names its own method
    assert (
        '<autoref identifier="streamseg.offline.lof.LOFSegmenter.fit" optional><code>fit'
        "</code></autoref>"
    ) in lof
    text = "\n".join(t for _, t in _docstrings(package))
    assert text.count("<autoref identifier=") >= 300
