"""Tracklet similarity of the camera-network paper (eq. 6-9): appearance times transit likelihood.

* Appearance (eq. 7): the maximum, over every pair of images of the two tracklets, of the
  intersection of their HSV histograms. Each image's histogram is taken once, on its central
  half (half the height, half the width, centred) after CLAHE (contrast-limited adaptive
  histogram equalisation) of each of its B, G, R channels, as a joint H x S x V histogram
  (8 x 4 x 4 bins) normalised to sum 1; CLAHE per channel separates CAVIAR4REID's people
  across its two real cameras best of the variants compared
  (docs/decisions/stripes-appearance.md). All image pairs are intersected
  in blocks of one broadcast ``minimum(...).sum(-1)``; the per-tracklet maximum is one
  ``maximum.reduceat`` per axis. No Python loop over image pairs.
* Appearance ``"stripes"`` (a change of method, not the paper's; chosen on CAVIAR4REID's
  even-numbered people only, reported on the odd ones, see
  docs/decisions/stripes-appearance.md): the image without 15 % of its width on each side,
  resized to 128 x 48, CLAHE per B, G, R channel, in HSV; 12 horizontal stripes, each with its
  own hue, saturation and value histograms (16 bins each, each normalised to sum 1; the 128 x 48
  pixels are split into 12 runs of 512, row after row, so a stripe is 10 2/3 rows); the
  similarity of two images is
  the mean over stripes of the stripes' histogram intersections (each in [0, 1]), and that of
  two tracklets the **mean** over all their image pairs (not the maximum), to the power
  :data:`STRIPE_POWER` (8; a monotone calibration chosen with min-cost flow on the bench's
  tuning seeds). In [0, 1], so eq. 6
  and every linker are unchanged. Pair-ranking probability (AUC, 3 random images per real
  camera, 10 draws) on the odd-numbered people: 0.806 across the two real cameras (the paper's
  0.648), 0.948 within one camera between disjoint images (the paper's 0.860).
* Transit (eq. 8-9): the maximum, over every edge joining the two tracklets' cameras, of the
  gamma pdf (shape k, scale theta, ``scipy.stats.gamma``) of the time from the end of the first
  tracklet to the start of the second; 0 with no edge or a time <= 0. One pdf call for all the
  pairs of all the edges. Units: 1/seconds.
* Similarity (eq. 6): ``appearance * transit``; ``S[i, j]`` scores "j follows i".
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from pftrack_network.network import CameraNetwork, Tracklet

__all__ = ["APPEARANCES", "appearance_matrix", "hsv_histograms", "image_histogram",
           "image_stripes", "pair_ranking_auc", "similarity_matrix", "stripe_histograms",
           "transit_matrices", "transit_matrix"]

#: the appearance features of :func:`appearance_matrix`: the paper's eq. 7 and the stripes
APPEARANCES = ("paper", "stripes")

#: histogram bins of hue (OpenCV's 0-180), saturation and value
BINS = (8, 4, 4)
CLAHE_CLIP = 2.0
CLAHE_TILES = (4, 4)
#: the stripes feature: stripes, bins per channel (H, S, V), the share of the width cut off each
#: side and the size (height, width) each image is resized to
STRIPES = 12
STRIPE_BINS = 16
STRIPE_CROP_W = 0.15
STRIPE_SIZE = (128, 48)
#: the stripes appearance is the mean intersection to this power (a monotone calibration: the
#: ranking, hence the AUC, is the mean's; it sets the weight of appearance against transit in
#: eq. 6's ``-log S``): the mean intersections of tracklets lie in 0.45-0.75, so at power 1
#: appearance hardly moves a link's cost. Chosen on the tuning datasets (seeds 1000-1002) of
#: ``pftrack bench camera-network`` (docs/decisions/stripes-appearance.md).
STRIPE_POWER = 8.0
_BLOCK_ELEMENTS = 8_000_000  # float32 elements per broadcast block (32 MB)


def image_histogram(image_bgr: np.ndarray, bins: tuple[int, int, int] = BINS) -> np.ndarray:
    """One person image's appearance feature.

    Parameters
    ----------
    image_bgr : ndarray (H, W, 3) uint8
        BGR, H and W at least 2.
    bins : (int, int, int)
        Bins of hue, saturation and value.

    Returns
    -------
    ndarray (bins[0] * bins[1] * bins[2],) float32
        The joint HSV histogram of the central half after per-channel CLAHE, summing
        to 1.
    """
    import cv2

    h, w = image_bgr.shape[:2]
    crop = np.ascontiguousarray(image_bgr[h // 4: h // 4 + max(h // 2, 1),
                                          w // 4: w // 4 + max(w // 2, 1)])
    clahe = cv2.createCLAHE(clipLimit=CLAHE_CLIP, tileGridSize=CLAHE_TILES)
    eq = np.dstack([clahe.apply(np.ascontiguousarray(crop[:, :, c])) for c in range(3)])
    hsv = cv2.cvtColor(eq, cv2.COLOR_BGR2HSV)
    hist = cv2.calcHist([hsv], [0, 1, 2], None, list(bins), [0, 180, 0, 256, 0, 256])
    hist = hist.ravel().astype(np.float32)
    return hist / max(float(hist.sum()), 1.0)


def image_stripes(image_bgr: np.ndarray) -> np.ndarray:
    """One person image's stripes feature (``appearance="stripes"``).

    Parameters
    ----------
    image_bgr : ndarray (H, W, 3) uint8
        BGR, H and W at least 2.

    Returns
    -------
    ndarray (STRIPES * 3 * STRIPE_BINS,) float32
        Stripe after stripe (top to bottom), the H, S and V histograms of the stripe after
        per-channel CLAHE, each summing to ``1 / (3 * STRIPES)``: the whole sums to 1, and the
        intersection of two features is the mean over stripes of each stripe's mean
        per-channel intersection.
    """
    import cv2

    if image_bgr.ndim != 3 or image_bgr.shape[2] != 3 or min(image_bgr.shape[:2]) < 2:
        raise ValueError(f"image_stripes: expected an (H, W, 3) image with H, W >= 2, got "
                         f"shape {image_bgr.shape}")
    w = image_bgr.shape[1]
    c = int(round(w * STRIPE_CROP_W))
    crop = image_bgr[:, c: w - c] if 0 < c and w - 2 * c >= 2 else image_bgr
    im = cv2.resize(np.ascontiguousarray(crop), (STRIPE_SIZE[1], STRIPE_SIZE[0]),
                    interpolation=cv2.INTER_AREA)
    clahe = cv2.createCLAHE(clipLimit=CLAHE_CLIP, tileGridSize=CLAHE_TILES)
    eq = np.dstack([clahe.apply(np.ascontiguousarray(im[:, :, k])) for k in range(3)])
    hsv = cv2.cvtColor(eq, cv2.COLOR_BGR2HSV).reshape(STRIPES, -1, 3)  # rows split evenly
    top = np.array([180, 256, 256])
    b = np.minimum(hsv.astype(np.int64) * STRIPE_BINS // top, STRIPE_BINS - 1)
    # one bincount for every stripe and channel: index (stripe, channel, bin)
    idx = (np.arange(STRIPES)[:, None, None] * 3 + np.arange(3)) * STRIPE_BINS + b
    hist = np.bincount(idx.ravel(), minlength=STRIPES * 3 * STRIPE_BINS).astype(np.float32)
    return hist / (hsv.shape[1] * 3 * STRIPES)


def stripe_histograms(tracklets: Sequence[Tracklet]) -> tuple[np.ndarray, np.ndarray]:
    """:func:`image_stripes` of every image, stacked tracklet after tracklet (as
    :func:`hsv_histograms`)."""
    counts = _image_counts(tracklets)
    feat = np.stack([image_stripes(im) for t in tracklets for im in t.images])
    return feat, np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(int)


def _image_counts(tracklets: Sequence[Tracklet]) -> list[int]:
    counts = [len(t.images) for t in tracklets]
    for i, c in enumerate(counts):
        if c == 0:
            raise ValueError(f"tracklet {i} (camera {tracklets[i].camera!r}) has no image")
    return counts


def hsv_histograms(tracklets: Sequence[Tracklet], bins: tuple[int, int, int] = BINS
                   ) -> tuple[np.ndarray, np.ndarray]:
    """Every image's histogram, once, stacked tracklet after tracklet.

    Returns
    -------
    hist : ndarray (n_images, n_bins) float32
    offsets : ndarray (n_tracklets,) int
        Row of each tracklet's first image in ``hist``.
    """
    counts = _image_counts(tracklets)
    hist = np.stack([image_histogram(im, bins) for t in tracklets for im in t.images])
    offsets = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(int)
    return hist, offsets


def appearance_matrix(tracklets: Sequence[Tracklet], bins: tuple[int, int, int] = BINS,
                      histograms: tuple[np.ndarray, np.ndarray] | None = None,
                      feature: str = "paper") -> np.ndarray:
    """Eq. 7 (or the stripes appearance) for every pair of tracklets.

    Parameters
    ----------
    tracklets : sequence of Tracklet, length n
    bins : (int, int, int)
        The paper's feature's bins.
    histograms : (hist, offsets), optional
        :func:`hsv_histograms`'s (``feature="paper"``) or :func:`stripe_histograms`'s
        (``"stripes"``) result, when already computed.
    feature : {"paper", "stripes"}
        ``"paper"``: eq. 7, the maximum over image pairs of the central half's HSV-histogram
        intersection. ``"stripes"``: the mean over image pairs of the stripes' intersection
        (:func:`image_stripes`; a change of method, see the module's docstring).

    Returns
    -------
    ndarray (n, n) float
        ``A[i, j]`` = max (paper) or mean (stripes, then to the power :data:`STRIPE_POWER`)
        over images a of i and b of j of ``sum(min(h_a, h_b))``, in [0, 1]; symmetric.
    """
    if feature not in APPEARANCES:
        raise ValueError(f"appearance_matrix: feature must be one of {APPEARANCES}, got "
                         f"{feature!r}")
    if histograms is not None:
        hist, offsets = histograms
    elif feature == "stripes":
        hist, offsets = stripe_histograms(tracklets)
    else:
        hist, offsets = hsv_histograms(tracklets, bins)
    m = hist.shape[0]
    inter = np.empty((m, m), dtype=np.float32)
    rows = max(1, _BLOCK_ELEMENTS // max(m * hist.shape[1], 1))
    for r0 in range(0, m, rows):  # blocks of rows, bounded memory
        inter[r0:r0 + rows] = np.minimum(hist[r0:r0 + rows, None, :], hist[None, :, :]).sum(-1)
    if feature == "stripes":
        counts = np.diff(np.append(offsets, m)).astype(float)
        sums = np.add.reduceat(np.add.reduceat(inter.astype(float), offsets, axis=0), offsets,
                               axis=1)
        return np.clip(sums / np.outer(counts, counts), 0.0, 1.0) ** STRIPE_POWER
    per_row = np.maximum.reduceat(inter, offsets, axis=0)
    return np.maximum.reduceat(per_row, offsets, axis=1).astype(float)


def pair_ranking_auc(first: Sequence[Tracklet], second: Sequence[Tracklet],
                     feature: str = "paper") -> float:
    """How well an appearance ranks true pairs above false ones: the probability (AUC) that
    ``A(first[i], second[i])`` exceeds ``A(first[i], second[j])`` and ``A(first[j],
    second[i])``, j != i (ties count half), over every i and j.

    Parameters
    ----------
    first, second : sequence of Tracklet, the same length n >= 2
        ``first[i]`` and ``second[i]`` are the same person (e.g. as seen by two cameras).
    feature : {"paper", "stripes"}
        :func:`appearance_matrix`'s.

    Returns
    -------
    float in [0, 1]
        0.5 is chance.
    """
    n = len(first)
    if n != len(second) or n < 2:
        raise ValueError(f"pair_ranking_auc: first and second must hold the same number (>= 2) "
                         f"of tracklets, got {len(first)} and {len(second)}")
    a = appearance_matrix(list(first) + list(second), feature=feature)[:n, n:]
    true = np.diag(a)
    off = ~np.eye(n, dtype=bool)
    by_row = (true[:, None] > a) + 0.5 * (true[:, None] == a)  # first[i] against second[j]
    by_col = (true[None, :] > a) + 0.5 * (true[None, :] == a)  # second[j] against first[i]
    return float(0.5 * (by_row[off].mean() + by_col[off].mean()))


def transit_matrix(tracklets: Sequence[Tracklet], network: CameraNetwork,
                   edges: str = "all") -> np.ndarray:
    """Eq. 8-9 for every ordered pair of tracklets.

    Tracklets on cameras that are not in ``network`` (dropped ones) get 0 in their rows and
    columns.

    Parameters
    ----------
    tracklets : sequence of Tracklet
    network : CameraNetwork
    edges : {"all", "original", "joined"}
        Which edges count: all (eq. 8-9), only those Camera Dropout did not add, or only those
        it added (:meth:`~pftrack_network.network.CameraNetwork.joined_edges`).

    Returns
    -------
    ndarray (n, n) float, 1/s
        ``T[i, j]`` = max over edges e joining camera(i) and camera(j) of
        ``gamma.pdf(t_start(j) - t_end(i), k_e, scale=theta_e)``; 0 when no edge joins them or
        the time is not positive.
    """
    if edges == "all":
        return _transit(tracklets, network, split=False)[0]
    if edges not in ("original", "joined"):
        raise ValueError(f"transit_matrix: edges must be 'all', 'original' or 'joined', "
                         f"got {edges!r}")
    return _transit(tracklets, network, split=True)[int(edges == "joined")]


def transit_matrices(tracklets: Sequence[Tracklet], network: CameraNetwork
                     ) -> tuple[np.ndarray, np.ndarray]:
    """:func:`transit_matrix` over the network's own edges and over the edges Camera Dropout
    joined, from one pdf evaluation (the elementwise maximum of the two is
    ``transit_matrix(tracklets, network)``).

    Returns
    -------
    original, joined : ndarray (n, n) float, 1/s
    """
    original, joined = _transit(tracklets, network, split=True)
    return original, joined


def _transit(tracklets: Sequence[Tracklet], network: CameraNetwork, split: bool
             ) -> list[np.ndarray]:
    from scipy.stats import gamma

    n = len(tracklets)
    outs = [np.zeros((n, n)) for _ in range(2 if split else 1)]
    u, v, k, theta = network.edge_arrays()
    if n == 0 or len(u) == 0:
        return outs
    group = network.joined_edges().astype(int) if split else np.zeros(len(u), int)
    index = {c: i for i, c in enumerate(network.cameras)}
    cam = np.array([index.get(t.camera, -1) for t in tracklets])
    start = np.array([t.t_start_s for t in tracklets])
    end = np.array([t.t_end_s for t in tracklets])
    n_cam = len(index)
    # tracklets grouped by camera: the pairs of an edge are the product of its two groups
    order = np.argsort(cam, kind="stable")
    order = order[cam[order] >= 0]
    bounds = np.searchsorted(cam[order], np.arange(n_cam + 1))
    sizes = np.diff(bounds)
    # both directions of every edge
    eu, ev = np.concatenate([u, v]), np.concatenate([v, u])
    ek, et = np.concatenate([k, k]), np.concatenate([theta, theta])
    eg = np.concatenate([group, group])
    n_pairs = sizes[eu] * sizes[ev]
    keep = n_pairs > 0
    eu, ev, ek, et, eg, n_pairs = eu[keep], ev[keep], ek[keep], et[keep], eg[keep], n_pairs[keep]
    if not len(eu):
        return outs
    total = int(n_pairs.sum())
    edge_of = np.repeat(np.arange(len(eu)), n_pairs)
    local = np.arange(total) - np.repeat(np.cumsum(n_pairs) - n_pairs, n_pairs)
    width = sizes[ev][edge_of]
    i = order[bounds[eu][edge_of] + local // width]
    j = order[bounds[ev][edge_of] + local % width]
    dt = start[j] - end[i]
    pdf = np.where(dt > 0, gamma.pdf(np.maximum(dt, 1e-12), ek[edge_of], scale=et[edge_of]), 0.0)
    # the maximum over parallel edges (of one group): sorted by group, pair, then pdf, the
    # last of each (group, pair) wins
    flat = eg[edge_of] * (n * n) + i * n + j
    order = np.lexsort((pdf, flat))
    flat, pdf = flat[order], pdf[order]
    last = np.append(flat[1:] != flat[:-1], True)
    flat, pdf = flat[last], pdf[last]
    for g, out in enumerate(outs):
        sel = flat // (n * n) == g
        out.ravel()[flat[sel] % (n * n)] = pdf[sel]
    return outs


def similarity_matrix(tracklets: Sequence[Tracklet], network: CameraNetwork,
                      appearance: np.ndarray | None = None,
                      feature: str = "paper") -> np.ndarray:
    """Eq. 6: ``S[i, j] = appearance[i, j] * transit[i, j]`` (j following i), 1/s.

    Parameters
    ----------
    appearance : ndarray (n, n), optional
        :func:`appearance_matrix`'s result, reused across sub-networks (it does not depend on
        the network).
    feature : {"paper", "stripes"}
        The appearance computed when ``appearance`` is None (:func:`appearance_matrix`).
    """
    if appearance is None:
        appearance = appearance_matrix(tracklets, feature=feature)
    n = len(tracklets)
    if appearance.shape != (n, n):
        raise ValueError(f"appearance has shape {appearance.shape}, expected ({n}, {n})")
    return appearance * transit_matrix(tracklets, network)
