"""streamseg: live motion-capture segmentation.

Online cuts by Local Outlier Factor over sliding-window bone-angle histograms (Xing et al.
2015), relabelling by Aligned Cluster Analysis (Zhou et al. 2008), repetition counting (Wang
et al. 2015), served over ZeroMQ. Importing the package is light: no sockets, no numba
compilation.
"""

from __future__ import annotations

from streamseg.io import read
from streamseg.recording import Recording, Skeleton

__version__ = "0.1.0"
__all__ = ["Recording", "Skeleton", "__version__", "read"]
