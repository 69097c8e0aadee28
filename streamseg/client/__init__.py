"""The Python client of the daemon's protocol (docs/protocol.md).

Control requests (:func:`request`), subscriptions that are known to be live
(:func:`subscribe`: :func:`subscriber` then :func:`handshake`), the event log
(:func:`fetch_since`) and the event iterator with its stop conditions, late-joiner filtering
and hole filling (:func:`listen`). ``streamseg listen`` is this with a command line and
printing; programs (the demo, the tests, a client of your own) import it from here.
"""

from streamseg.client.control import Refusal, request, sending_context
from streamseg.client.events import listen
from streamseg.client.history import count_in as count_in  # streamseg listen's, not public
from streamseg.client.history import fetch_since, takes
from streamseg.client.subscription import Subscription, handshake, subscribe, subscriber

__all__ = [
    "Refusal",
    "Subscription",
    "fetch_since",
    "handshake",
    "listen",
    "request",
    "takes",
    "sending_context",
    "subscribe",
    "subscriber",
]
