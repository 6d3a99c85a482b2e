"""The workflows behind the commands, each a whole job from inputs to files:
:mod:`~pftrack.workflows.pipeline` (``pftrack run``: a configuration on a video),
:mod:`~pftrack.workflows.track` (``pftrack track``: a video, no configuration),
:mod:`~pftrack.workflows.batch` (``pftrack batch``: many runs), :mod:`~pftrack.workflows.stream`
(:class:`pftrack.Tracker`: your detections, frame by frame),
:mod:`~pftrack.workflows.static_tracks` (flagging tracks that never move) and
:mod:`~pftrack.workflows.spread` (each record's uncertainty from the particle clouds).
"""
