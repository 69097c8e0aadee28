"""Lab Streaming Layer in and out (``pip install 'streamseg[lsl]'``).

* :mod:`streamseg.lsl.meta`: the skeleton of a motion-capture stream from its XML
  description (the XDF/LSL mocap meta-data: one channel per coordinate);
* :mod:`streamseg.lsl.bridge`: LSL mocap streams fed to the daemon as streams
  (``streamseg lsl``, ``serve --lsl-type``), on LSL's clock, reconnecting when an outlet
  comes back;
* :mod:`streamseg.lsl.markers`: the daemon's events as an LSL marker stream
  (``serve --lsl-markers``), stamped with the LSL time of the frame each concerns, so
  LabRecorder records them beside the mocap.

liblsl reads its configuration from the file ``LSLAPICFG`` names (discovery scope, ports,
session id; docs/guide/formats.md shows one that keeps everything on this machine).
"""

from __future__ import annotations

from streamseg.exceptions import ParameterError


def pylsl():
    """The ``pylsl`` module, or a ParameterError saying how to install it."""
    try:
        import pylsl as module
    except ImportError:
        raise ParameterError("LSL needs pylsl: pip install 'streamseg[lsl]'") from None
    except RuntimeError as err:  # pylsl found no liblsl it can load
        raise ParameterError(
            f"pylsl could not load liblsl ({err}): reinstall pylsl (its "
            "wheels ship liblsl) or set PYLSL_LIB"
        ) from None
    return module
