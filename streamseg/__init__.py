"""streamseg: live motion-capture segmentation.

Online cuts by Local Outlier Factor over sliding-window bone-angle histograms (Xing et al.
2015), relabelling by Aligned Cluster Analysis (Zhou et al. 2008), repetition counting (Wang
et al. 2015), served over ZeroMQ. Importing the package is light: no sockets, no numba
compilation, not even numpy until ``read``, ``Recording`` or ``Skeleton`` is first used (the
command line starts without them).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from streamseg._lazy import lazy_exports

__version__ = "0.1.0"
if TYPE_CHECKING:  # what documentation tools and type checkers read
    from streamseg.io import read
    from streamseg.recording import Recording, Skeleton

_EXPORTS = {
    "read": "streamseg.io",
    "Recording": "streamseg.recording",
    "Skeleton": "streamseg.recording",
}
__all__ = ["Recording", "Skeleton", "__version__", "read"]
__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
