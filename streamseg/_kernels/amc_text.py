"""AMC frame text to numbers in one pass (numba). Private: :func:`streamseg.io.amc.read_amc`
calls it and reads the file line by line whenever it declines."""

from __future__ import annotations

import numpy as np
from numba import njit

#: slot kinds of one frame's tokens
FRAME, NAME, VALUE = 0, 1, 2
#: 10**0 .. 10**22, every one exact in float64 (the range of the exact conversion below)
_POW10 = np.array([10.0**k for k in range(23)])
_MANTISSA_MAX = 2**53


@njit(cache=True, nogil=True)
def _is_space(c):
    return c == 32 or 9 <= c <= 13


@njit(cache=True, nogil=True)
def count_tokens(buf):
    """Runs of non-space bytes in ``buf`` (uint8); -1 when a byte is not printable ASCII or
    ASCII whitespace (where ``str.split`` would split otherwise)."""
    n, inside = 0, False
    for c in buf:
        if _is_space(c):
            inside = False
            continue
        if c < 33 or c > 126:
            return -1
        if not inside:
            n += 1
            inside = True
    return n


@njit(cache=True, nogil=True)
def _number(buf, i, j, pow10):
    """``float(buf[i:j])`` when the token is a decimal number whose digits make an integer
    of at most 2**53 and whose decimal exponent is within +-22: then it is that integer
    times or divided by an exact power of ten, one correctly rounded operation, the same
    double as ``float`` gives. ``(ok, value)``; not ok for anything else."""
    neg = False
    if buf[i] == 45 or buf[i] == 43:  # - +
        neg = buf[i] == 45
        i += 1
    mantissa, digits, scale, point = 0, 0, 0, False
    while i < j:
        c = buf[i]
        if 48 <= c <= 57:
            digits += 1
            mantissa = mantissa * 10 + (c - 48)
            if mantissa > _MANTISSA_MAX:
                return False, 0.0
            if point:
                scale -= 1
        elif c == 46 and not point:  # .
            point = True
        else:
            break
        i += 1
    if digits == 0:
        return False, 0.0
    if i < j:
        if buf[i] != 101 and buf[i] != 69:  # e E
            return False, 0.0
        i += 1
        eneg = False
        if i < j and (buf[i] == 45 or buf[i] == 43):
            eneg = buf[i] == 45
            i += 1
        if i == j or j - i > 4:
            return False, 0.0
        e = 0
        while i < j:
            c = buf[i]
            if not 48 <= c <= 57:
                return False, 0.0
            e = e * 10 + (c - 48)
            i += 1
        scale += -e if eneg else e
    if mantissa == 0:
        value = 0.0
    elif scale > 22 or scale < -22:
        return False, 0.0
    elif scale >= 0:
        value = float(mantissa) * pow10[scale]
    else:
        value = float(mantissa) / pow10[-scale]
    return True, -value if neg else value


@njit(cache=True, nogil=True)
def parse_frames(buf, kinds, name_start, name_len, names, n_frames, out):
    """Fill ``out`` with the values of ``n_frames`` frames laid out as ``kinds`` says.

    Parameters
    ----------
    buf : uint8 (n_bytes,)
        The text from the first frame number on; ``count_tokens(buf) == n_frames *
        len(kinds)``.
    kinds : int64 (width,)
        Each token slot of a frame: :data:`FRAME` (its number: digits, an optional sign, at
        most 15 characters, one more than the previous frame's), :data:`NAME` or
        :data:`VALUE`.
    name_start, name_len : int64 (width,)
        Where a NAME slot's bytes are in ``names``.
    names : uint8 (total,)
        The bone names, concatenated.
    n_frames : int
    out : float64 (n_frames, n_values), written
        The VALUE slots of each frame in order.

    Returns
    -------
    int
        -1 when every token was as expected, else the index of the first token that was not.
    """
    width = kinds.shape[0]
    n = buf.shape[0]
    i, tok, previous = 0, 0, 0
    for f in range(n_frames):
        col = 0
        for s in range(width):
            while i < n and _is_space(buf[i]):
                i += 1
            j = i
            while j < n and not _is_space(buf[j]):
                j += 1
            kind = kinds[s]
            if kind == VALUE:
                ok, value = _number(buf, i, j, _POW10)
                if not ok:
                    return tok
                out[f, col] = value
                col += 1
            elif kind == NAME:
                if j - i != name_len[s]:
                    return tok
                for k in range(j - i):
                    if buf[i + k] != names[name_start[s] + k]:
                        return tok
            else:
                k, neg = i, False
                if buf[k] == 45 or buf[k] == 43:
                    neg = buf[k] == 45
                    k += 1
                if k == j or j - i > 15:
                    return tok
                number = 0
                while k < j:
                    c = buf[k]
                    if not 48 <= c <= 57:
                        return tok
                    number = number * 10 + (c - 48)
                    k += 1
                if neg:
                    number = -number
                if f > 0 and number != previous + 1:
                    return tok
                previous = number
            i = j
            tok += 1
    return -1
