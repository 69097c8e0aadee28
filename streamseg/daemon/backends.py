"""The relabel backend a daemon's options ask for (``relabel_backend``)."""

from __future__ import annotations


def relabel_worker(algorithms, config):
    """A worker with :class:`~streamseg.daemon.worker.RelabelWorker`'s interface.

    ``thread`` (with ``relabel_processes = 0``), ``process`` (a pool of
    ``max(relabel_processes, 1)`` processes; ``relabel_processes > 0`` alone also means it,
    as before the option existed) or ``dask`` (:class:`~streamseg.daemon.dask_worker.
    DaskRelabelWorker`; raises ParameterError naming ``pip install streamseg[dask]`` when
    Dask is not installed).
    """
    from streamseg.daemon.worker import RelabelWorker

    backend = config.relabel_backend
    if backend == "dask":
        from streamseg.daemon.dask_worker import DaskRelabelWorker

        return DaskRelabelWorker(algorithms, config.relabel_scheduler, share=config.relabel_share)
    processes = config.relabel_processes
    if backend == "process":
        processes = max(processes, 1)
    return RelabelWorker(algorithms, processes=processes, share=config.relabel_share)
