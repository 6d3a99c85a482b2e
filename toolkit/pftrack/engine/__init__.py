"""The tracking engine: :mod:`~pftrack.engine.tracker` (:class:`MultiTargetTracker`, one step
per frame: predict, associate, weight, estimate, resample), :mod:`~pftrack.engine.lifecycle`
(the runner of the track lifecycle stages) and :mod:`~pftrack.engine.runner` (the one loop of
frames through the detector and the engine). The particle-filter numerics it calls are in
:mod:`pftrack.filter`.
"""
