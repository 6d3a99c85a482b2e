"""Built-in plugin ``network``: the camera-network paper, people across non-overlapping cameras
(Kawanishi, Deguchi, Ide and Murase: Camera Dropout and Trajectory Ensemble).

Python API (imported on use; nothing heavy at plugin load):

* :mod:`pftrack_network.network`: the exchange types :class:`~pftrack_network.network.Tracklet`
  and :class:`~pftrack_network.network.CameraNetwork` (file format, picture) and
  :func:`~pftrack_network.network.camera_dropout` (sec. 3.2);
* :mod:`pftrack_network.similarity`: eq. 6-9 (HSV-histogram appearance, gamma transit) and the
  stripes appearance (`feature="stripes"`, a change of method);
* :mod:`pftrack_network.linkers`: :class:`~pftrack_network.linkers.TrackletLinker` and the
  built-ins ``greedy``, ``min-cost-flow`` (OR-Tools) and ``trajectory-ensemble`` (sec. 3.4);
* :mod:`pftrack_network.virtual`: the virtual experiment of sec. 4.1 on real CAVIAR4REID images;
* :mod:`pftrack_network.video`: tracklets cut out of a video with pftrack's ``tracks.txt``.

The paper's Tables 1 and 3 are the benchmark ``camera-network`` of the repository's benchmark
package (``pftrack_bench``, not part of the installed product); this plugin registers no
component.
Linkers are not a pftrack component kind (they partition tracklets offline, not frame by
frame); they are plain classes, listed in :data:`pftrack_network.linkers.LINKERS`.
"""

from __future__ import annotations

__version__ = "0.1.0"

