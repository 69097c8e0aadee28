"""numba kernels, private: the validating Python APIs of :mod:`streamseg.online` and
:mod:`streamseg.offline` call them.

Importing this package first gives numba the one piece of scipy it checks for at start-up
(:func:`_numba_blas_check_without_scipy_linalg`), so a command that needs no scipy.linalg
does not pay for importing it.
"""

from __future__ import annotations

import sys

import numpy as np


def _numba_blas_check_without_scipy_linalg() -> None:
    """Load ``scipy.linalg.cython_blas`` and ``cython_lapack`` alone, under their own names,
    before numba starts.

    The first call of any numba function (compiled or loaded from the cache) imports
    ``numba.np.arraymath``, which runs ``import scipy.linalg.cython_blas`` only to learn
    whether BLAS is there. That import executes ``scipy/linalg/__init__.py`` (0.17 s on this
    project's machine, most of it scipy's array-API layer cloning numpy), a quarter of a
    whole ``segment --method aca`` of 86_01; no kernel here calls BLAS. The extension module
    modules themselves are what numba and every Cython ``cimport`` of them use (their
    ``__pyx_capi__``; :mod:`streamseg._kernels.lapack` calls ``dsyevr`` of the LAPACK one),
    and they import nothing of scipy.linalg; with them in ``sys.modules`` numba's check
    passes and ``import scipy.linalg`` later imports the package as usual (``from
    scipy.linalg import cython_blas`` finds the loaded module). Where scipy lays its files
    out otherwise, nothing is loaded and numba imports scipy.linalg itself.
    """
    if "scipy.linalg" in sys.modules or "numba.np.arraymath" in sys.modules:
        return
    import importlib.machinery
    import importlib.util

    try:
        scipy_spec = importlib.util.find_spec("scipy")  # finds, does not execute scipy
        roots = [f"{p}/linalg" for p in (scipy_spec.submodule_search_locations or ())]
        for name in ("scipy.linalg.cython_blas", "scipy.linalg.cython_lapack"):
            if name in sys.modules:
                continue
            spec = importlib.machinery.PathFinder.find_spec(name, roots)
            if spec is None or not isinstance(spec.loader, importlib.machinery.ExtensionFileLoader):
                return
            module = importlib.util.module_from_spec(spec)
            spec.loader.exec_module(module)
            sys.modules[name] = module
    except (ImportError, AttributeError, OSError):
        return


_numba_blas_check_without_scipy_linalg()


def frames_in(a) -> np.ndarray:
    """``a`` as a C-contiguous float64 array the kernel only reads, always read-only.

    numba compiles a kernel apart for a read-only argument: a decoded packet is read-only, a
    packet the gap filler joined or a counter's selection of frames is not. One type means
    one compiled version, the one warmed at start, and never a compile in the daemon's loop.
    """
    a = np.ascontiguousarray(a, dtype=np.float64)
    if a.flags.writeable:
        a = a.view()
        a.flags.writeable = False
    return a
