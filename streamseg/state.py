"""The versioned state contract of the components whose state outlives a process.

A stateful component (the live cut detector, its speed columns and root speeds, the
repetition counter, the gap filler, the label memory, a daemon's stream pipeline and stream
bookkeeping) derives from :class:`Stateful`:

- ``obj.to_state()`` is ``{"version": STATE_VERSION, "fields": {name: value}}``: every
  attribute but the ``_transient`` ones (rebuilt by ``_restored()`` or given back by the
  owner), values not copied;
- ``Cls.from_state(state)`` builds the component from a state of its own version;
  :func:`streamseg.state_migrations.upgrade` (the one place that knows how earlier releases
  differ) brings an older one up to date first; a newer or unknown version raises
  :class:`StateVersionError`.

A class that renames, adds or changes the meaning of a stored field bumps its
``STATE_VERSION`` and adds the migration from the previous version
(``tests/test_state_contract.py`` holds the stored fields of every version and fails until
both are done). Serialisation (arrays, chunks, msgpack) is the daemon's
(:mod:`streamseg.daemon.state_codec`).
"""

from __future__ import annotations


class StateVersionError(ValueError):
    """A stored state this release cannot read (newer than it, or without a migration)."""


class Stateful:
    """Base of a component with a versioned state (see the module's description)."""

    __slots__ = ()
    STATE_VERSION = 1
    _transient: tuple = ()  # attributes not stored

    def to_state(self) -> dict:
        """``{"version": int, "fields": dict}``: this component's stored state (not copied)."""
        cls = type(self)
        names = [n for c in cls.__mro__ for n in getattr(c, "__slots__", ())]
        names += list(getattr(self, "__dict__", ()))
        skip = set(cls._transient)
        return {
            "version": cls.STATE_VERSION,
            "fields": {
                n: getattr(self, n)
                for n in dict.fromkeys(names)
                if n not in skip and hasattr(self, n)
            },
        }

    @classmethod
    def from_state(cls, state: dict):
        """The component a :meth:`to_state` of this version described (an earlier version:
        :func:`streamseg.state_migrations.upgrade`)."""
        if state["version"] != cls.STATE_VERSION:
            raise StateVersionError(
                f"{cls.__qualname__} state version {state['version']!r}: "
                f"from_state reads version {cls.STATE_VERSION}; an earlier "
                "one goes through streamseg.state_migrations.upgrade"
            )
        fields = state["fields"]
        out = cls.__new__(cls)
        for name, value in fields.items():
            object.__setattr__(out, name, value)  # also frozen dataclasses
        out._restored()
        return out

    def _restored(self) -> None:
        """Recompute what :meth:`to_state` leaves out (called by :meth:`from_state`)."""
