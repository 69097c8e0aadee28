"""The streamseg daemon: sockets and lifecycle (what each stream runs:
:mod:`streamseg.daemon.pipeline`, :mod:`streamseg.daemon.algorithms`).

Start one with :class:`Daemon` (``bind()`` then ``run()`` until ``stop()``), or from the command
line with ``streamseg serve``. See ``docs/architecture.md`` and ``docs/protocol.md``.
"""

from streamseg.daemon.options import load_config
from streamseg.daemon.server import Daemon

__all__ = ["Daemon", "load_config"]
