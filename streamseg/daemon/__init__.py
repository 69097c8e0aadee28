"""The streamseg daemon: sockets and lifecycle (algorithms: :mod:`streamseg.daemon.pipeline`).

Start one with :class:`Daemon` (``bind()`` then ``run()`` until ``stop()``), or from the command
line with ``streamseg serve``. See ``docs/architecture.md`` and ``docs/protocol.md``.
"""

from streamseg.daemon.options import load_config
from streamseg.daemon.server import Daemon

__all__ = ["Daemon", "load_config"]
