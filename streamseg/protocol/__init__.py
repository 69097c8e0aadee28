"""The streamseg wire protocol, version 1 (specified field by field in ``docs/protocol.md``).

Every message is a ZeroMQ multipart message of exactly two frames ``[topic, body]``:

- ``topic`` is ASCII ``<type>/<stream>/`` (``<type>/*/`` for daemon-wide messages). Type comes
  first so that one SUB prefix selects one event type across all streams (``cut/``); one
  stream's events of every type are ``len(EVENT_TYPES)`` subscriptions (``cut/s1/``,
  ``segments/s1/``, ...). The trailing ``/`` stops ``cut/s1/`` from matching stream ``s10``.
- ``body`` is a msgpack map holding ``v`` (the protocol version), ``type`` and the fields of
  the message. The body is authoritative; the topic is only for routing.

Arrays travel as a map ``{"dtype": "<f4" | "<f8", "shape": [n, J, 3], "data": <bytes>}``
(little-endian, C order), never pickle.

:func:`encode` turns a message object into the two frames; :func:`decode` validates and turns
them back, raising :class:`WireError` (a :class:`~streamseg.exceptions.ProtocolError` with a
``kind`` for counting) with a message that says what was wrong and what was expected.
"""

from __future__ import annotations

from streamseg.protocol.codec import (
    MAX_INT,
    decode,
    decode_array,
    encode,
    encode_array,
    frames_fields,
    from_body,
    to_json,
    unpack_body,
)
from streamseg.protocol.messages import (
    CHANGING_OPS,
    DAEMON_WIDE,
    EVENT_TYPES,
    INGEST_TYPES,
    MESSAGES,
    PROTOCOL_VERSION,
    SEQ_SKIP,
    Announce,
    Closed,
    Confirm,
    Cut,
    End,
    Error,
    Frames,
    Gap,
    Hello,
    Rep,
    Segments,
    Stats,
    WireError,
    Withdraw,
    subscriptions,
    topic,
    valid_stream_id,
)

__all__ = [
    "CHANGING_OPS",
    "DAEMON_WIDE",
    "EVENT_TYPES",
    "INGEST_TYPES",
    "MAX_INT",
    "MESSAGES",
    "PROTOCOL_VERSION",
    "SEQ_SKIP",
    "Announce",
    "Closed",
    "Confirm",
    "Cut",
    "End",
    "Error",
    "Frames",
    "Gap",
    "Hello",
    "Rep",
    "Segments",
    "Stats",
    "WireError",
    "Withdraw",
    "decode",
    "decode_array",
    "encode",
    "encode_array",
    "frames_fields",
    "from_body",
    "subscriptions",
    "to_json",
    "topic",
    "unpack_body",
    "valid_stream_id",
]
