"""pftrack.render: pictures of tracks, volumes and particles.

* :mod:`pftrack.render.topview` -- the ground plane from above (pyvista, parallel projection).
* :mod:`pftrack.render.view3d` -- volumes and particle clouds in 3D (pyvista, fixed camera).
* :mod:`pftrack.render.overlay` -- OpenCV overlays on video frames through a camera: boxes with
  ids, projected particles, volume edges and pitch lines, ground positions.
* :mod:`pftrack.render.colours` -- stable colours per track id, shared by all of them.

Renders are deterministic (same input, same pixels) and PNGs are written atomically.
"""
