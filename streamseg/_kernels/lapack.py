"""The leading eigenpairs of a small dense symmetric matrix: LAPACK ``dsyevr`` called through
scipy's public Cython LAPACK (``scipy.linalg.cython_lapack``), the driver and the arguments
``scipy.linalg.eigh(a, subset_by_index=[n - k, n - 1])`` uses, so the answers are the same
numbers. Called this way a command that needs nothing else of scipy.linalg does not import
it (see :mod:`streamseg._kernels`: 0.17 s, a quarter of ``segment --method aca`` of 86_01).
"""

from __future__ import annotations

import ctypes
import functools

import numpy as np

_INT = ctypes.POINTER(ctypes.c_int)
_DBL = ctypes.POINTER(ctypes.c_double)
_CHAR = ctypes.c_char_p


@functools.cache
def _dsyevr():
    import importlib

    capsule = importlib.import_module("scipy.linalg.cython_lapack").__pyx_capi__["dsyevr"]
    # own prototypes: setting restype on ctypes.pythonapi's would change them for everyone
    get_name = ctypes.PYFUNCTYPE(ctypes.c_char_p, ctypes.py_object)(
        ("PyCapsule_GetName", ctypes.pythonapi)
    )
    get_pointer = ctypes.PYFUNCTYPE(ctypes.c_void_p, ctypes.py_object, ctypes.c_char_p)(
        ("PyCapsule_GetPointer", ctypes.pythonapi)
    )
    addr = get_pointer(capsule, get_name(capsule))
    # jobz, range, uplo, n, a, lda, vl, vu, il, iu, abstol, m, w, z, ldz, isuppz,
    # work, lwork, iwork, liwork, info
    proto = ctypes.CFUNCTYPE(
        None, _CHAR, _CHAR, _CHAR, _INT, _DBL, _INT, _DBL, _DBL, _INT, _INT, _DBL, _INT,
        _DBL, _DBL, _INT, _INT, _DBL, _INT, _INT, _INT, _INT,
    )  # fmt: skip
    return proto(addr)


def leading_eigh(a: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """The ``k`` largest eigenvalues, ascending, and their eigenvectors of symmetric ``a``.

    Parameters
    ----------
    a : ndarray, shape (n, n)
        Symmetric; its lower triangle is read (as ``scipy.linalg.eigh`` reads it).
    k : int
        ``1 <= k <= n``.

    Returns
    -------
    w : ndarray, shape (k,)
    v : ndarray, shape (n, k)
        Column ``j`` is the unit eigenvector of ``w[j]``.
    """
    a = np.asarray(a, dtype=np.float64)
    n = a.shape[0]
    if a.ndim != 2 or a.shape[1] != n or not 1 <= k <= n:
        raise ValueError(f"expected a square matrix and 1 <= k <= n, got {a.shape} and k={k}")
    if not np.isfinite(a).all():
        raise ValueError("array must not contain infs or NaNs")
    f = _dsyevr()
    A = np.array(a, dtype=np.float64, order="F")  # overwritten by LAPACK
    c_int = ctypes.c_int
    n_, il, iu, m = c_int(n), c_int(n - k + 1), c_int(n), c_int(0)
    vl, vu, abstol = ctypes.c_double(0.0), ctypes.c_double(0.0), ctypes.c_double(0.0)
    w = np.zeros(n)
    z = np.zeros((n, k), order="F")
    isuppz = np.zeros(2 * max(1, k), dtype=np.intc)
    info = c_int(0)

    def call(work, lwork, iwork, liwork):
        f(
            b"V", b"I", b"L", ctypes.byref(n_), _ptr(A, _DBL), ctypes.byref(n_),
            ctypes.byref(vl), ctypes.byref(vu), ctypes.byref(il), ctypes.byref(iu),
            ctypes.byref(abstol), ctypes.byref(m), _ptr(w, _DBL), _ptr(z, _DBL),
            ctypes.byref(n_), _ptr(isuppz, _INT), _ptr(work, _DBL), ctypes.byref(lwork),
            _ptr(iwork, _INT), ctypes.byref(liwork), ctypes.byref(info),
        )  # fmt: skip

    # workspace query first, as scipy does: the optimal size chooses LAPACK's blocked code
    work, iwork = np.zeros(1), np.zeros(1, dtype=np.intc)
    call(work, c_int(-1), iwork, c_int(-1))
    if info.value != 0:
        raise np.linalg.LinAlgError(f"dsyevr workspace query failed (info={info.value})")
    lwork, liwork = int(work[0]), int(iwork[0])
    work, iwork = np.zeros(max(1, lwork)), np.zeros(max(1, liwork), dtype=np.intc)
    call(work, c_int(lwork), iwork, c_int(liwork))
    if info.value != 0 or m.value != k:
        raise np.linalg.LinAlgError(f"dsyevr did not converge (info={info.value})")
    return w[:k].copy(), np.ascontiguousarray(z)


def _ptr(arr: np.ndarray, kind):
    return arr.ctypes.data_as(kind)
