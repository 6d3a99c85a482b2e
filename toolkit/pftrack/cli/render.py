"""``pftrack render``: pictures of tracks.

* ``pftrack render topview TRACKS.txt --out PNG [--gt GT.txt] [--volume NAME|FILE]
  [--size WxH] [--title T] [--label L]`` -- the ground plane from above; trajectories from the
  MOTChallenge world columns 8-9 (x, y metres), coloured by id; ground truth dashed; the volume's
  ground lines when ``--volume`` is given, otherwise just the data's bounds with a metre grid.
* ``pftrack render overlay --video PATH --frame N --tracks TRACKS.txt [--camera CAM]
  --out PNG`` -- boxes and ids of MOT frame N drawn on the video frame N-1 (MOT frames count
  from 1, video frames from 0); with ``--camera`` and world columns, the ground positions
  (x, y, 0) projected through the camera as magenta dots.

PNGs are written atomically.
"""

from __future__ import annotations

import argparse

from pftrack.cli import _args

MAX_SIDE_PX = 8192


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"--size must be WxH in pixels, got {text!r}") from None
    if w < 16 or h < 16:
        raise argparse.ArgumentTypeError(f"--size must be at least 16x16, got {text!r}")
    if w > MAX_SIDE_PX or h > MAX_SIDE_PX:
        # beyond what an off-screen OpenGL framebuffer takes: VTK would abort the process
        raise argparse.ArgumentTypeError(f"--size must be at most {MAX_SIDE_PX}x{MAX_SIDE_PX}, "
                                         f"got {text!r}")
    return w, h


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("render", help="render a top view or a video overlay of tracks (PNG)",
                       description="Render pictures of tracks: a top view of the ground plane "
                                   "or boxes/ground dots over a video frame.")
    rs = p.add_subparsers(dest="render_command", metavar="KIND")
    t = rs.add_parser("topview", help="ground plane from above (MOT world columns, metres)")
    t.add_argument("tracks", metavar="TRACKS", help="MOTChallenge CSV with world x, y columns")
    t.add_argument("--out", required=True, help="output PNG")
    t.add_argument("--gt", help="ground-truth MOTChallenge CSV, drawn dashed")
    t.add_argument("--volume", help="volume name (pitch, near, far, or a name in a plugin's "
                   "volume files: pitch_corner, walkway), YAML file or FILE:NAME")
    t.add_argument("--size", type=_size, default=(1024, 768), help="WxH pixels (1024x768)")
    t.add_argument("--title", help="title text")
    t.add_argument("--label", default="estimate",
                   help="legend name of TRACKS (default: estimate; e.g. 'ground truth')")
    t.set_defaults(func=topview_handler)
    o = rs.add_parser("overlay", help="boxes, ids and projected ground dots on a video frame")
    o.add_argument("--video", required=True, help="video file")
    o.add_argument("--frame", type=_args.positive_int, required=True,
                   help="MOT frame number (1-based)")
    o.add_argument("--tracks", required=True, help="MOTChallenge CSV")
    o.add_argument("--camera", help="camera file (pftrack YAML, Tsai XML, OpenCV, Open3D)")
    o.add_argument("--out", required=True, help="output PNG")
    o.set_defaults(func=overlay_handler)
    p.set_defaults(func=lambda args: (p.print_help(), 2)[1])


def topview_handler(args: argparse.Namespace) -> int:
    from pathlib import Path

    from pftrack.io.mot import read_mot
    from pftrack.render.topview import render_topview
    from pftrack.render.tracks import tracks_from_mot

    if Path(args.out).suffix.lower() != ".png":
        raise ValueError(f"{args.out}: --out must be a .png file")
    tracks = tracks_from_mot(read_mot(args.tracks), source=str(args.tracks))
    gt = tracks_from_mot(read_mot(args.gt), source=str(args.gt)) if args.gt else None
    volume = None
    if args.volume:
        from pftrack.geometry.volumes import resolve_volume

        volume = resolve_volume(args.volume)
    title = args.title if args.title is not None else Path(args.tracks).name
    render_topview(args.out, tracks=tracks, ground_truth=gt, volume=volume,
                   size_wh=args.size, title=title, track_label=args.label)
    print(f"wrote {args.out}")
    return 0


def overlay_handler(args: argparse.Namespace) -> int:
    import numpy as np

    from pftrack.io.images import write_png
    from pftrack.io.mot import has_world, read_mot
    from pftrack.render.overlay import read_video_frame, render_overlay

    if not str(args.out).lower().endswith(".png"):
        raise ValueError(f"{args.out}: --out must be a .png file")
    if args.frame < 1:
        raise ValueError(f"--frame is a MOT frame number (from 1), got {args.frame}")
    rows = read_mot(args.tracks)
    rows = rows[rows[:, 0] == args.frame]
    frame = read_video_frame(args.video, args.frame - 1)
    camera, ground = None, None
    if args.camera:
        from pftrack.geometry.formats import load_camera

        camera = load_camera(args.camera)
        w = rows[has_world(rows)]
        ground = np.column_stack([w[:, 7:9], np.zeros(len(w))])
    img = render_overlay(frame, camera=camera, boxes_xywh_px=rows[:, 2:6], ids=rows[:, 1],
                         ground_points_m=ground)
    write_png(args.out, img)
    print(f"wrote {args.out} ({len(rows)} boxes in frame {args.frame})")
    return 0
