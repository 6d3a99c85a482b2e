"""The camera-network paper's pictures (matplotlib, Agg): a network beside its dropout sub-networks,
one person's tracklet images across cameras, and one person's trajectory as two linkers built it
(the paper's figure 5). Each function returns a figure; :func:`save_figure` writes it
atomically and closes it."""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from pftrack_network.network import CameraNetwork, Tracklet, camera_dropout

__all__ = ["draw_dropout", "draw_person_images", "draw_trajectories", "person_gained",
           "save_figure"]


def _plt():
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig: Any, path: str | os.PathLike[str], dpi: int = 110) -> Path:
    """Write ``fig`` to ``path`` atomically and close it."""
    from pftrack.io.atomic import atomic_write_with

    try:
        return atomic_write_with(path, lambda p: fig.savefig(p, dpi=dpi))
    finally:
        _plt().close(fig)


def draw_dropout(network: CameraNetwork, n_dropped: int, rng: np.random.Generator,
                 n_examples: int = 2, **dropout_options: Any) -> Any:
    """The network and ``n_examples`` Camera Dropout sub-networks side by side (dropped
    cameras dashed, added edges orange)."""
    plt = _plt()
    fig, axes = plt.subplots(1, 1 + n_examples, figsize=(5.2 * (1 + n_examples), 5.4))
    network.draw(axes[0], title=f"network: {len(network.cameras)} cameras, "
                                f"{network.number_of_edges()} edges")
    for ax in axes[1:]:
        sub, dropped = camera_dropout(network, n_dropped, rng, **dropout_options)
        sub.draw(ax, dropped=dropped, reference=network,
                 title=f"dropout C_d={n_dropped}: {sub.number_of_edges()} edges")
    fig.tight_layout()
    return fig


def draw_person_images(tracklets: Sequence[Tracklet], person: int,
                       real_camera: dict[str, int] | None = None, max_tracklets: int = 10
                       ) -> Any:
    """One person's tracklets in time order, a column per tracklet (camera, time, and the
    real camera when given), its images stacked."""
    plt = _plt()
    mine = [t for t in tracklets if t.person == person][:max_tracklets]
    if not mine:
        raise ValueError(f"no tracklet of person {person}")
    rows = max(len(t.images) for t in mine)
    fig, axes = plt.subplots(rows, len(mine), figsize=(1.25 * len(mine), 2.3 * rows),
                             squeeze=False)
    for c, t in enumerate(mine):
        for r in range(rows):
            ax = axes[r, c]
            ax.axis("off")
            if r < len(t.images):
                ax.imshow(t.images[r][:, :, ::-1])
        head = f"{t.camera}\n{t.t_start_s / 60:.1f} min"
        if real_camera is not None:
            head += f"\nreal cam {'AB'[real_camera[t.camera]]}"
        axes[0, c].set_title(head, fontsize=8)
    fig.suptitle(f"person {person}: tracklets in time order", fontsize=10)
    fig.tight_layout()
    return fig


def draw_trajectories(network: CameraNetwork, tracklets: Sequence[Tracklet], person: int,
                      labelings: dict[str, np.ndarray]) -> Any:
    """Figure 5: for each labeling, the trajectory that holds ``person``'s first tracklet,
    drawn over the network as arrows in time order; a tracklet of the right person green,
    of another person red (with that person's number)."""
    plt = _plt()
    fig, axes = plt.subplots(1, len(labelings), figsize=(5.4 * len(labelings), 5.6),
                             squeeze=False)
    first = min((i for i, t in enumerate(tracklets) if t.person == person),
                key=lambda i: tracklets[i].t_start_s)
    truth_n = sum(t.person == person for t in tracklets)
    for ax, (name, labels) in zip(axes[0], labelings.items()):
        network.draw(ax, title="")
        for p in ax.patches:
            p.set_alpha(0.25)
        members = sorted(np.flatnonzero(labels == labels[first]),
                         key=lambda i: tracklets[i].t_start_s)
        xy = np.array([network.position_m(tracklets[i].camera) for i in members])
        jitter = np.linspace(-6, 6, len(members))[:, None]
        xy = xy + jitter
        ok = [tracklets[i].person == person for i in members]
        for a in range(len(members) - 1):
            ax.annotate("", xy=xy[a + 1], xytext=xy[a],
                        arrowprops={"arrowstyle": "->", "lw": 1.8,
                                    "color": "tab:green" if ok[a + 1] else "tab:red"})
        for (x, y), good, i in zip(xy, ok, members):
            ax.scatter([x], [y], s=50, c="tab:green" if good else "tab:red", zorder=5)
            if not good:
                ax.annotate(f"p{tracklets[i].person}", (x, y), xytext=(4, 4),
                            textcoords="offset points", fontsize=7, color="tab:red")
        right = sum(ok)
        ax.set_title(f"{name}: {len(members)} tracklets linked, {right} of person {person} "
                     f"(who has {truth_n})", fontsize=9)
    fig.tight_layout()
    return fig


def person_gained(tracklets: Sequence[Tracklet], before: np.ndarray, after: np.ndarray) -> int:
    """The person whose first tracklet's trajectory holds the most more of their own tracklets
    under ``after`` than under ``before`` (ties: the lowest number): the case to show."""
    people = sorted({t.person for t in tracklets if t.person is not None})
    person = np.array([t.person for t in tracklets])
    start = np.array([t.t_start_s for t in tracklets])
    gains = []
    for p in people:
        mine = np.flatnonzero(person == p)
        first = mine[np.argmin(start[mine])]
        gains.append(int((after[mine] == after[first]).sum() - (before[mine] == before[first])
                         .sum()))
    return int(people[int(np.argmax(gains))])
