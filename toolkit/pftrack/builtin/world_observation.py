"""Ground-plane particles seen through a calibrated camera (the soccer paper's sec. 3.1, 3.4).

:class:`CameraBoxObservation` is the tracker's observation model for world state: a particle's
image window comes from the camera, not from the state. For each particle the foot point
``(p_x, p_y, 0)`` and the head point ``(p_x, p_y, height_m)`` (world metres, z up, ground z = 0)
are projected through the camera; the box stands on the projected foot point (bottom centre),
reaches up to the projected head row, and its width is a fixed ratio of its height (or a width
in metres). Boxes therefore shrink with distance exactly as the camera says.

The inverse, used for births, back-projects a box's foot point (bottom centre) onto the ground
(:meth:`pftrack.geometry.camera.Camera.image_to_ground`).

People are not all 1.75 m tall: with ``adapt_height`` each target keeps its own height factor in
the model's ``height_scales_`` (by target id; 1 = ``height_m``), set from the box it was born
from and moved towards each matched detection's height by :meth:`CameraBoxObservation.update_target`
(a running mean), within ``height_scale_range``.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from typing import TYPE_CHECKING

import numpy as np

from pftrack.contracts.components import ObservationModel, Param, RunContext, Target
from pftrack.geometry.boxes import foot_points

if TYPE_CHECKING:
    from pftrack.geometry.camera import Camera, CameraSpec

__all__ = ["CameraBoxObservation", "CameraVolumeObservation"]


class CameraBoxObservation(ObservationModel):
    """Image boxes of ground-plane states through a camera.

    {params}

    Notes
    -----
    ``to_boxes`` is vectorised: one projection of 2N points per call.
    """

    camera: CameraSpec | None = Param(
        None, "A pftrack.geometry.camera.Camera (world metres, z up) or a camera file path "
        "(anything pftrack.geometry.formats.load_camera reads, e.g. PETS Tsai XML). None: the "
        "run's camera (setup takes it from the RunContext; pftrack run --camera).")
    height_m: float = Param(1.75, "Height of the tracked objects (about 1.75 m for people).",
                            unit="m", low=0.0, low_open=True)
    width_m: float | None = Param(None, "Width of the tracked objects; the box width is "
                                  "height_px * width_m / height_m. None: width_ratio is used.",
                                  unit="m", low=0.0, low_open=True)
    width_ratio: float = Param(0.355, "Box width as a fraction of its height (PETS 2009 ground "
                               "truth: median 0.355).", unit="1", low=0.0, low_open=True)
    position_dims: tuple[int, int] = Param(
        (0, 1), "Entries of the state vector that hold (p_x, p_y) in metres (default the "
        "first two, the layout of the soccer paper's eq. 1).", unit="none", low=0, length=2)
    min_visible: float = Param(0.5, "in_view is true while at least this fraction of the "
                               "box's area is inside the image (a person stepping out of the "
                               "picture dies once mostly out).", unit="1", low=0.0, high=1.0)
    adapt_height: bool = Param(False, "Keep a height factor per target (module docstring).")
    height_scale_range: tuple[float, float] = Param(
        (0.85, 1.2), "Bounds (low, high) of the per-target height factor, low <= 1 <= high.",
        unit="1", low=0.0, low_open=True, length=2)

    def _check_relations(self) -> None:
        lo, hi = (float(v) for v in self.height_scale_range)
        if not lo <= 1 <= hi:
            raise ValueError(f"CameraBoxObservation: height_scale_range must satisfy "
                             f"low <= 1 <= high, got {self.height_scale_range}")

    @classmethod
    def _conformance_example(cls):
        """For :mod:`pftrack.testing`: the run's camera (through the context) 5 m up, 10 m
        back, looking at the origin of the ground, and people standing around the origin."""
        from pftrack.geometry.camera import Camera

        cam = Camera.look_at((0.0, -10.0, 5.0), (0.0, 0.0, 0.0), (160, 120), fx=150.0)
        xy = np.linspace(-1.0, 1.0, 32)
        states = np.column_stack([xy, xy[::-1], np.zeros((32, 4))])
        return cls(), {"states": states, "context": RunContext(camera=cam)}

    def _checked(self) -> None:
        """Load a camera path and derive ``camera_``, ``dims_``, ``scale_range_``, once, on
        first use."""
        if "dims_" in self.__dict__:
            return
        lo, hi = (float(v) for v in self.height_scale_range)
        self.camera_ = _resolve_camera(self, required=False)
        self.scale_range_ = (lo, hi)
        self.dims_ = tuple(int(d) for d in self.position_dims)

    def setup(self, context: RunContext) -> None:
        """The run's camera when none was given; with a lens, the compiled projection
        (:meth:`~pftrack.geometry.camera.Camera.project_rows`'s, checked bit for bit against
        numpy's when loaded) loaded now, so that :meth:`foot_head_px` does not run Tsai's
        Newton iterations in numpy every frame (the same numbers)."""
        if self.camera is None and context.camera is not None:
            self.__dict__.pop("dims_", None)
            self.camera_ = context.camera
        cam = _resolve_camera(self, required=False)
        if cam is not None and not cam.distortion.is_identity:
            from pftrack.geometry.camera import _rows_kernel

            _rows_kernel()

    def get_camera(self) -> Camera:
        """The camera in use (``camera``, loaded when a path, or the run's)."""
        self._checked()
        return _required_camera(self)

    _cam = get_camera

    @property
    def aspect(self) -> float:
        """Box width / height."""
        if self.width_m is None:
            return float(self.width_ratio)
        return float(self.width_m) / float(self.height_m)

    def ground_points(self, states: np.ndarray) -> np.ndarray:
        """States (N, D) -> foot points (N, 3) in world metres (z = 0)."""
        s = np.asarray(states, dtype=np.float64)
        out = np.zeros((len(s), 3))
        out[:, 0] = s[:, self.position_dims[0]]
        out[:, 1] = s[:, self.position_dims[1]]
        return out

    def height_of(self, target: Target | None) -> float:
        """The height (m) used for ``target``: ``height_m`` times its height factor."""
        if target is None or not self.adapt_height:
            return float(self.height_m)
        return float(self.height_m) * self._scales().get(target.id, 1.0)

    def foot_head_px(self, states: np.ndarray, height_m: float | None = None
                     ) -> tuple[np.ndarray, np.ndarray]:
        """Projected foot and head points, each (N, 2) pixels.

        A point in front of the camera always has a pixel, also beyond the field where the
        lens model has a value (:meth:`~pftrack.geometry.camera.Camera.project_beyond_lens`:
        outside the image, continuing the lens outward), so that a person partly out of the
        frame -- the head of someone taller than the picture, a particle beside the image --
        still has a finite box. Only a point at or behind the camera's centre plane is NaN.
        """
        g = self.ground_points(states)
        n = len(g)
        pts = np.concatenate([g, g])
        pts[n:, 2] = float(self.height_m) if height_m is None else height_m
        px = self._cam().project_beyond_lens(pts)
        return px[:n], px[n:]

    def init_target(self, target: Target, box_xywh_px: np.ndarray | None) -> None:
        """With ``adapt_height``, the height factor of the box the target is born from."""
        if self.adapt_height and box_xywh_px is not None:
            self._scales()[target.id] = 1.0
            self.update_target(target, box_xywh_px, rate=1.0)

    def update_target(self, target: Target, box_xywh_px: np.ndarray, rate: float = 0.1) -> None:
        """Move the target's height factor towards the one ``box_xywh_px`` (a matched
        detection) shows at the target's current position: ``s <- (1 - rate) s + rate *
        box_height / model_height``, clipped to ``height_scale_range``. No-op unless
        ``adapt_height``."""
        if not self.adapt_height:
            return
        ref = self.to_boxes(np.asarray(target.state, dtype=np.float64)[None])[0, 3]
        h = float(np.asarray(box_xywh_px, dtype=np.float64)[3])
        if not (np.isfinite(ref) and ref > 0 and h > 0):
            return
        self._checked()
        lo, hi = self.scale_range_
        old = self._scales().get(target.id, 1.0)
        new = (1.0 - rate) * old + rate * (h / ref)
        self._scales()[target.id] = float(np.clip(new, lo, hi))

    def _scales(self) -> dict[int, float]:
        """Per-target height factors (``height_scales_``), created on first use."""
        scales = self.__dict__.get("height_scales_")
        if scales is None:
            scales = {}
            self.height_scales_: dict[int, float] = scales
        return scales

    def end_target(self, target: Target) -> None:
        """Forget the target's height factor."""
        self._scales().pop(target.id, None)

    def to_boxes(self, states: np.ndarray, target: Target | None = None) -> np.ndarray:
        """States (N, D) -> boxes (N, 4) (left, top, width, height) in pixels.

        The box's bottom centre is the projected foot point; its height is the image distance
        from foot to head (the target's own height with ``adapt_height``).

        A state whose foot or head lies at or behind the camera's centre plane (a person
        beside or behind a camera at head or waist height: the ground there is not in the
        picture) has no image box: its row is NaN, all four numbers. The composite likelihood
        (``people-ground``'s) gives such a particle zero likelihood (-inf), the filter turns
        any NaN log-weight into -inf too (:func:`pftrack.filter.core.normalize_log_weights`),
        and :meth:`in_view` reads it as not in view: such particles are never resampled and a
        track whose estimate goes there ends, so no NaN box reaches a track record. Every state
        in front of the camera gets a finite box (:meth:`foot_head_px`).
        """
        foot, head = self.foot_head_px(states, self.height_of(target))
        h = np.hypot(foot[:, 0] - head[:, 0], foot[:, 1] - head[:, 1])
        w = h * self.aspect
        out = np.empty((len(foot), 4))
        out[:, 0] = foot[:, 0] - 0.5 * w
        out[:, 1] = foot[:, 1] - h
        out[:, 2] = w
        out[:, 3] = h
        return out

    def position_from_box(self, box_xywh_px: np.ndarray) -> np.ndarray:
        """Ground position (p_x, p_y) in metres under a box's foot point (bottom centre);
        NaN when the foot point's ray does not meet the ground in front of the camera (a foot
        point on or above the horizon: a sign, a reflection, a person whose feet the camera
        puts above its horizon).

        Such a box cannot be placed on the ground, and the callers leave it out of what needs
        a ground position rather than guess one (a guess would put a track metres or
        kilometres away): it starts no track (the birth initiators skip non-finite positions)
        and proposes no particles (the detection proposal skips it), while a track it matches
        in the image still takes it in its image likelihood. A finite position is what every
        caller gets or nothing."""
        b = np.asarray(box_xywh_px, dtype=np.float64).reshape(4)
        g = self._cam().image_to_ground(foot_points(b)[None])[0]
        return g[:2].copy()

    def world_position(self, state: np.ndarray) -> np.ndarray:
        """Ground position (x, y, 0) in world metres of a state (D,)."""
        return self.ground_points(np.asarray(state, dtype=np.float64)[None])[0]

    def in_view(self, states: np.ndarray, image_size_wh: tuple[int, int],
                target: Target | None = None) -> np.ndarray:
        """Boolean (N,): at least ``min_visible`` of the box lies inside the image and the foot
        point is in front of the camera."""
        frac = _visible_fraction(self.to_boxes(states, target), image_size_wh)
        return np.isfinite(frac) & (frac >= float(self.min_visible))


class CameraVolumeObservation(ObservationModel):
    """Points in a 3-D volume seen through a camera (the coastal paper: intruders in cuboids over a
    coast, particles spread through the volume in world metres).

    A state's entries ``position_dims`` are the centre (x, y, z) of an object of size ``size_m``
    (along world x, y, z); its box is the image bounding box of that axis-aligned cuboid's eight
    projected corners (NaN when a corner is behind the camera). :meth:`position_from_box`
    assumes the object rests on the plane ``z = support_z_m`` (sea level, the ground): the
    box's bottom centre is back-projected onto that plane.

    {params}
    """

    camera: CameraSpec | None = Param(None, "As CameraBoxObservation's (None: the run's "
                                      "camera).")
    size_m: tuple[float, float, float] = Param(
        (1.0, 1.0, 1.0), "Object size along world x, y and z.", unit="m", low=0.0,
        low_open=True, length=3)
    position_dims: tuple[int, int, int] = Param(
        (0, 1, 2), "Entries of the state vector holding (x, y, z) in metres (default the first "
        "three, the layout of constant-velocity-3d).", unit="none", low=0, length=3)
    support_z_m: float = Param(0.0, "Height of the plane objects rest on (births from boxes).",
                               unit="m")
    min_visible: float = Param(0.5, "in_view is true while at least this fraction of the box "
                               "is inside the image.", unit="1", low=0.0, high=1.0)
    particle_box: str = Param(
        "cuboid", "point: a state's box is its projected point (width and height 0), one "
        "projection per particle instead of eight; for the coastal paper, where each particle "
        "is a point on the intruder and its size comes from the particles' spread (eq. 10), "
        "not from a box per particle; likelihoods of points read the box's corner as the "
        "pixel.", choices=("cuboid", "point"))

    @classmethod
    def _conformance_example(cls):
        """For :mod:`pftrack.testing`: the run's camera 20 m up, 40 m back, over a 4 x 2 x 3 m
        object near the origin."""
        from pftrack.geometry.camera import Camera

        cam = Camera.look_at((0.0, -40.0, 20.0), (0.0, 0.0, 0.0), (160, 120), fx=150.0)
        xyz = np.linspace(-2.0, 2.0, 32)
        states = np.column_stack([xyz, xyz[::-1], 1.5 + 0.1 * xyz, np.zeros((32, 3))])
        return cls(size_m=(4.0, 2.0, 3.0)), {"states": states,
                                             "context": RunContext(camera=cam)}

    def setup(self, context: RunContext) -> None:
        """The run's camera when none was given; with ``particle_box="point"``, the compiled
        projection (:meth:`~pftrack.geometry.camera.Camera.project_rows`) loaded now, before
        the first frame."""
        if self.camera is None and context.camera is not None:
            self.__dict__.pop("half_size_", None)
            self.camera_ = context.camera
        if self.particle_box == "point":
            from pftrack.geometry.camera import _rows_kernel

            _rows_kernel()

    def get_camera(self) -> Camera:
        """The camera in use (``camera``, loaded when a path, or the run's)."""
        if "half_size_" not in self.__dict__:  # parameters checked once, on first use
            size = np.asarray(self.size_m, dtype=np.float64).reshape(-1)
            self.camera_ = _required_camera(self)
            self.half_size_ = 0.5 * size
        return self.camera_

    def points(self, states: np.ndarray) -> np.ndarray:
        """States (N, D) -> object centres (N, 3) in world metres."""
        s = np.asarray(states, dtype=np.float64)
        return s[:, list(self.position_dims)]

    def to_boxes(self, states: np.ndarray, target: Target | None = None) -> np.ndarray:
        """States (N, D) -> boxes (N, 4): the bounding boxes of the projected cuboids, one
        projection of 8N corners."""
        cam = self.get_camera()
        c = self.points(states)
        if self.particle_box == "point":
            out = np.zeros((len(c), 4))
            out[:, :2] = cam.project(c)  # NaN behind the camera
            return out
        half = self.half_size_
        signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)],
                         dtype=np.float64)
        corners = (c[:, None, :] + signs[None] * half).reshape(-1, 3)
        px = cam.project(corners).reshape(len(c), 8, 2)
        behind = ~cam.in_front(corners).reshape(len(c), 8).all(axis=1)
        lo, hi = px.min(axis=1), px.max(axis=1)
        out = np.concatenate([lo, hi - lo], axis=1)
        out[behind] = np.nan
        return out

    def to_boxes_rows(self, states: np.ndarray, targets: Sequence[Target]) -> np.ndarray:
        """(T, N, D) -> (T, N, 4), equal to :meth:`to_boxes` row by row; with
        ``particle_box="point"`` every target's particles in one projection
        (:meth:`~pftrack.geometry.camera.Camera.project_rows`)."""
        s = np.asarray(states, dtype=np.float64)
        if self.particle_box != "point" or s.ndim != 3:
            return super().to_boxes_rows(s, targets)
        cam = self.get_camera()
        out = np.zeros(s.shape[:2] + (4,))
        out[:, :, :2] = cam.project_rows(s[:, :, list(self.position_dims)])
        return out

    def position_from_box(self, box_xywh_px: np.ndarray) -> np.ndarray:
        """The centre (x, y, z) of an object resting on ``z = support_z_m`` whose bottom
        centre is the box's; NaN when that ray misses the plane in front of the camera."""
        b = np.asarray(box_xywh_px, dtype=np.float64).reshape(4)
        g = self.get_camera().image_to_ground(foot_points(b)[None],
                                              z_m=float(self.support_z_m))[0]
        return np.array([g[0], g[1], float(self.support_z_m) + 0.5 * float(self.size_m[2])])

    def world_position(self, state: np.ndarray) -> np.ndarray:
        """The object's centre (x, y, z) in world metres."""
        return self.points(np.asarray(state, dtype=np.float64)[None])[0]

    def in_view(self, states: np.ndarray, image_size_wh: tuple[int, int],
                target: Target | None = None) -> np.ndarray:
        """Boolean (N,): at least ``min_visible`` of the box lies inside the image."""
        frac = _visible_fraction(self.to_boxes(states, target), image_size_wh)
        return np.isfinite(frac) & (frac >= float(self.min_visible))


def _visible_fraction(b: np.ndarray, image_size_wh: tuple[int, int]) -> np.ndarray:
    """Fraction (N,) of each box (N, 4) inside a ``(w, h)`` image (NaN for a NaN box)."""
    w, h = image_size_wh
    x0 = np.clip(b[:, 0], 0, w)
    x1 = np.clip(b[:, 0] + b[:, 2], 0, w)
    y0 = np.clip(b[:, 1], 0, h)
    y1 = np.clip(b[:, 1] + b[:, 3], 0, h)
    area = b[:, 2] * b[:, 3]
    inside = np.clip(x1 - x0, 0, None) * np.clip(y1 - y0, 0, None)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(area > 0, inside / area, 0.0)


def _resolve_camera(model: ObservationModel, required: bool = True) -> Camera | None:
    """``model``'s camera: the one :meth:`setup` took from the run (``camera_``) or its
    ``camera`` parameter, loaded when a path; ValueError naming the model when there is none
    and ``required``."""
    cam = model.__dict__.get("camera_", model.camera)  # type: ignore[attr-defined]
    if isinstance(cam, (str, os.PathLike)):
        from pftrack.geometry.formats import load_camera

        cam = load_camera(cam)
    if cam is None and required:
        raise ValueError(f"{type(model).__name__}: no camera; give camera=... or run with a "
                         "camera (pftrack run --camera PATH)")
    return cam


def _required_camera(model: ObservationModel) -> Camera:
    """:func:`_resolve_camera` when there must be a camera (ValueError naming ``model`` if not)."""
    cam = _resolve_camera(model, required=True)
    assert cam is not None  # _resolve_camera raised otherwise
    return cam
