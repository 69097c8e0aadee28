"""Pictures (matplotlib, imported only when a picture is drawn; ``pip install streamseg[plot]``).

- :func:`plot_curve`: a score curve (LOF) with cuts and human segments;
- :func:`timeline`: several segmentations of one recording as coloured rows;
- :func:`plot_segments`: features with (H)ACA segments;
- :func:`plot_repetitions`: a repetition segmentation.
"""

from streamseg.plotting.curve import plot_curve
from streamseg.plotting.repetitions import plot_repetitions
from streamseg.plotting.segments import plot_segments
from streamseg.plotting.timeline import timeline

__all__ = ["plot_curve", "plot_repetitions", "plot_segments", "timeline"]
