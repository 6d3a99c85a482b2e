"""The observation models the core ships: :class:`~pftrack.builtin.image_box.ImageBoxObservation`
(``image-box``, image-plane state) and the camera models of
:mod:`~pftrack.builtin.world_observation` (``camera-box``, ``camera-volume``: ground-plane or
3-D state seen through a calibrated camera). The built-in plugin ``basic`` registers them by
name, through the same hooks a third-party plugin uses.
"""
