"""``streamseg view``: a live web page of every stream a daemon serves (optional extra
``view``: aiohttp).

The view is one more subscriber of the daemon (late join through the control ``state``
request, then the event stream): :mod:`~streamseg.view.model` keeps what each stream looks
like, :mod:`~streamseg.view.feed` talks ZeroMQ to the daemon, :mod:`~streamseg.view.server`
serves the static page (``static/``: plain JavaScript and SVG, nothing fetched from elsewhere)
and pushes coalesced updates over a WebSocket.
"""

from __future__ import annotations

__all__ = ["ViewServer", "ViewThread"]


def __getattr__(name):  # aiohttp is optional: import it only when the server is asked for
    if name in __all__:
        from streamseg.view import server

        return getattr(server, name)
    raise AttributeError(name)
