"""A griffe extension for the API pages: the docstrings' Sphinx roles as cross-references.

The docstrings are numpydoc, written for readers of the source and of ``help()`` too, so they
keep Sphinx's ``:func:`name```, ``:class:`~a.b.C```, ``:mod:`a.b``` ... mkdocstrings does not
read roles (they would show as ``:func: name``). This turns each one into an ``autoref``
marked optional: a link where the target is on an API page, plain code where it is not (a
private helper, a module without a page), never a broken link.
"""

from __future__ import annotations

import html
import re

import griffe

ROLE = re.compile(r":(?:py:)?(func|meth|class|mod|data|attr|obj|exc|const|type):`([^`]+)`")


class SphinxRoles(griffe.Extension):
    """Rewrite the roles of every docstring of a package once it is loaded."""

    def on_package(self, *, pkg, loader, **kwargs) -> None:
        collection = loader.modules_collection
        for obj in _walk(pkg):
            doc = obj.docstring
            if doc is not None and ":" in doc.value:
                doc.value = ROLE.sub(lambda m, o=obj: _ref(m, o, collection), doc.value)


def _walk(obj, seen=None):
    seen = set() if seen is None else seen
    if id(obj) in seen:
        return
    seen.add(id(obj))
    yield obj
    for member in list(obj.members.values()):
        if not member.is_alias:
            yield from _walk(member, seen)


def _ref(match, obj, collection) -> str:
    text = match[2].strip()
    short = text.startswith("~")
    target = text.lstrip("~.")
    if target.endswith("()"):
        target = target[:-2]
    title = target.rsplit(".", 1)[-1] if short else target
    path = _resolve(target, obj, collection)
    code = f"<code>{html.escape(title)}</code>"
    if path is None:
        return code
    return f'<autoref identifier="{html.escape(path)}" optional>{code}</autoref>'


def _resolve(target: str, obj, collection) -> str | None:
    """The full path ``target`` names from ``obj``'s docstring, or None."""
    try:
        collection.get_member(target)
        return target
    except (KeyError, ValueError, AttributeError, griffe.AliasResolutionError):
        pass
    scope = obj
    while scope is not None:  # a method or attribute of the class, a name of the module
        head = target.split(".", 1)[0]
        if head in scope.members:
            return f"{scope.path}.{target}"
        try:
            return scope.resolve(target)
        except (griffe.NameResolutionError, KeyError, AttributeError):
            pass
        scope = scope.parent
    return None
