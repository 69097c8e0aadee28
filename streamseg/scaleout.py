"""Dask, the optional scale-out engine: import it or say what to install; a loopback cluster.

``pip install streamseg[dask]`` adds ``dask[distributed]``; the core install and the daemon's
thread and process relabel backends do not need it.
"""

from __future__ import annotations

import logging
import os

from streamseg.exceptions import ParameterError

INSTALL_HINT = "pip install streamseg[dask]"


def require_distributed():
    """The ``distributed`` module, or ParameterError saying how to install it."""
    try:
        import distributed
    except ImportError:
        raise ParameterError(
            f"the Dask backend needs dask[distributed], which is not installed: {INSTALL_HINT}"
        ) from None
    return distributed


def local_cluster(
    n_workers: int | None = None, processes: bool = True, threads_per_worker: int = 1
):
    """A :class:`distributed.LocalCluster` on 127.0.0.1 (random ports, no dashboard).

    Parameters
    ----------
    n_workers : int or None
        Workers (None: one per core).
    processes : bool
        Worker processes (True: each its own GIL) or threads of this process.
    threads_per_worker : int
        Tasks one worker runs at once; 1 because the kernels are single-threaded numba.
    """
    distributed = require_distributed()
    n = n_workers or os.cpu_count() or 1
    return distributed.LocalCluster(
        n_workers=n,
        threads_per_worker=threads_per_worker,
        processes=processes,
        host="127.0.0.1",
        protocol="tcp://",
        dashboard_address="127.0.0.1:0",
        silence_logs=logging.ERROR,
    )


def connect(address: str, timeout: float = 10.0):
    """A :class:`distributed.Client` of the scheduler at ``address``; ParameterError naming
    the address when it cannot be reached in ``timeout`` seconds."""
    distributed = require_distributed()
    try:
        return distributed.Client(address, timeout=timeout, set_as_default=False)
    except (OSError, TimeoutError) as err:
        raise ParameterError(
            f"cannot reach the Dask scheduler at {address} within "
            f"{timeout:g} s ({type(err).__name__}: {err}); start one with "
            "`dask scheduler` or leave out --scheduler for a local "
            "cluster"
        ) from None
