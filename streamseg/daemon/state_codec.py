"""The checkpoints' serialisation: a small, closed format (no pickle).

:func:`dump` copies a stream's state in the loop thread (arrays become private copies,
nothing is shared with the live stream); :func:`packable` turns the copy into msgpack-able
values in the writer thread, an array of more than :data:`CHUNK` bytes as the digests of its
content-addressed chunks (XXH3-128 of :data:`CHUNK` bytes each, trailing zero bytes not
stored); :func:`load` rebuilds it. Only plain values, numpy arrays, tuples, deques, dicts,
``streamseg`` dataclasses (values: events, configs, skeletons; their fields) and
:class:`~streamseg.state.Stateful` components (their versioned ``to_state()``, rebuilt by
``from_state()``, older versions migrated by :mod:`streamseg.state_migrations`) are written
or read.
"""

from __future__ import annotations

import collections
import dataclasses
import importlib

import numpy as np
import xxhash

from streamseg.state import Stateful
from streamseg.state_migrations import FORMAT, implied_version, name_of, upgrade

CHUNK = 4096  # bytes of an array chunk: smaller ones store less per round, more rows


def dump(obj):
    """A msgpack-able copy of ``obj``: plain values, arrays (as bytes), deques, tuples and
    objects of ``streamseg`` classes (their ``__dict__`` / ``__slots__``)."""
    if obj is None or isinstance(obj, (bool, int, float, str, bytes)):
        return obj
    if isinstance(obj, np.ndarray):  # a copy; the writer thread turns it into bytes (trimmed)
        return {"__nd__": [obj.dtype.str, list(obj.shape), np.array(obj, order="C")]}
    if isinstance(obj, np.generic):
        return obj.item()
    if isinstance(obj, list):
        return [dump(x) for x in obj]
    if isinstance(obj, tuple):
        return {"__t__": [dump(x) for x in obj]}
    if isinstance(obj, collections.deque):
        return {"__dq__": [obj.maxlen, [dump(x) for x in obj]]}
    if isinstance(obj, dict):
        return {"__d__": [[dump(k), dump(v)] for k, v in obj.items()]}
    cls = type(obj)
    if not cls.__module__.startswith("streamseg."):
        raise TypeError(f"cannot checkpoint a {cls.__module__}.{cls.__qualname__}")
    if isinstance(obj, Stateful):
        state = obj.to_state()
        return {
            "__obj__": name_of(cls),
            "v": state["version"],
            "s": {n: dump(v) for n, v in state["fields"].items()},
        }
    if dataclasses.is_dataclass(obj):
        return {
            "__obj__": name_of(cls),
            "s": {f.name: dump(getattr(obj, f.name)) for f in dataclasses.fields(obj)},
        }
    raise TypeError(
        f"cannot checkpoint a {cls.__qualname__}: neither a Stateful component "
        "(streamseg.state) nor a dataclass"
    )


def load(obj, chunks=None, fmt: int = FORMAT):
    """Inverse of :func:`packable` after msgpack, given the stream's ``chunks`` (a mapping
    of digest to stored bytes); ``fmt``: the checkpoint row's format (components of rows
    before 7 carry no version of their own)."""
    if isinstance(obj, list):
        return [load(x, chunks, fmt) for x in obj]
    if not isinstance(obj, dict):
        return obj
    if "__nd__" in obj:
        dtype, shape, data = obj["__nd__"]
        dtype = np.dtype(dtype)
        n = int(np.prod(shape)) * dtype.itemsize
        if isinstance(data, list):  # chunk digests (packable), each without trailing zeros
            data = b"".join(
                chunks[d].ljust(min(CHUNK, n - i * CHUNK), b"\0") for i, d in enumerate(data)
            )
        return np.frombuffer(data.ljust(n, b"\0"), dtype=dtype).reshape(shape).copy()
    if "__t__" in obj:
        return tuple(load(x, chunks, fmt) for x in obj["__t__"])
    if "__dq__" in obj:
        maxlen, items = obj["__dq__"]
        return collections.deque((load(x, chunks, fmt) for x in items), maxlen=maxlen)
    if "__d__" in obj:
        return {load(k, chunks, fmt): load(v, chunks, fmt) for k, v in obj["__d__"]}
    if "__obj__" in obj:
        module, qual = obj["__obj__"].split(":")
        if not module.startswith("streamseg."):
            raise TypeError(f"refusing to build {module}.{qual} from a checkpoint")
        cls = importlib.import_module(module)
        for part in qual.split("."):
            cls = getattr(cls, part)
        fields = {k: load(v, chunks, fmt) for k, v in obj["s"].items()}
        if isinstance(cls, type) and issubclass(cls, Stateful):
            version = obj.get("v", implied_version(fmt, obj["__obj__"]) if fmt < 7 else None)
            return upgrade(cls, {"version": version, "fields": fields})
        if not dataclasses.is_dataclass(cls):
            raise TypeError(
                f"refusing to build {module}.{qual} from a checkpoint: neither a "
                "Stateful component nor a dataclass"
            )
        out = cls.__new__(cls)
        for k, v in fields.items():
            object.__setattr__(out, k, v)  # also frozen dataclasses
        for f in dataclasses.fields(cls):  # a field added since the checkpoint: its default
            if f.name not in fields:
                if f.default is not dataclasses.MISSING:
                    object.__setattr__(out, f.name, f.default)
                elif f.default_factory is not dataclasses.MISSING:
                    object.__setattr__(out, f.name, f.default_factory())
        return out
    raise TypeError(f"unknown checkpoint value with keys {sorted(obj)[:5]}")


def packable(obj, chunks: dict, pause=None):
    """:func:`dump`'s output with its arrays as bytes; an array of more than :data:`CHUNK`
    bytes becomes the list of its chunks' digests, and ``chunks`` gains ``{digest: chunk}``
    (memoryviews into the dumped copy: :func:`stored` turns the new ones into bytes).
    ``pause()``, if given, is called after each such array. Writer thread."""
    if isinstance(obj, list):
        return [packable(x, chunks, pause) for x in obj]
    if not isinstance(obj, dict):
        return obj
    if "__nd__" in obj:
        dtype, shape, a = obj["__nd__"]
        raw = memoryview(a.reshape(-1)).cast("B")
        if raw.nbytes <= CHUNK:
            return {"__nd__": [dtype, shape, stored(raw)]}
        digests = []
        for i in range(0, raw.nbytes, CHUNK):
            part = raw[i : i + CHUNK]
            # content addressing, not security: a changed chunk gets a new key. XXH3-128 reads
            # 745 kB in 0.03 ms, SHA-1 in 0.6 ms (a round hashes every open stream's state)
            d = xxhash.xxh3_128_digest(part)
            chunks[d] = part
            digests.append(d)
        if pause is not None:
            pause()
        return {"__nd__": [dtype, shape, digests]}
    return {k: packable(v, chunks, pause) for k, v in obj.items()}


def stored(chunk: memoryview) -> bytes:
    """The bytes stored for an array or chunk: trailing zero bytes dropped (a young stream's
    buffers are mostly unused; :func:`load` pads them back)."""
    return chunk.tobytes().rstrip(b"\0")
