"""The contracts: what a plugin implements and what the core hands it. Imports nothing else of
pftrack (the lowest layer).

* :mod:`~pftrack.contracts.components`: the exchange types (:class:`~.components.Frame`,
  :class:`~.components.Detections`, :class:`~.components.Target`,
  :class:`~.components.TrackRecord`, :class:`~.components.RunContext`) and the component base
  classes, one per kind;
* :mod:`~pftrack.contracts.params`: parameter declarations (:class:`~.params.Param`, groups of
  them: :class:`~.params.Group`, :class:`~.params.ParamGroup`), re-exported by ``components``;
* :mod:`~pftrack.contracts.stages`: the track lifecycle stages' views, decisions and roles;
* :mod:`~pftrack.contracts.kinds`: each kind's name and base class;
* :mod:`~pftrack.contracts.extensions`: benchmarks, commands, demos and report writers;
* :mod:`~pftrack.contracts.hookspecs`: the plugin hooks (``pftrack_register_*``).

Plugin authors import these from the stable paths :mod:`pftrack.components`,
:mod:`pftrack.lifecycle`, :mod:`pftrack.extensions` and :mod:`pftrack.hookspecs`.
"""
