"""Benchmark results as data: record them into ``results/``, render them into the docs.

Recording runs a registered benchmark (``pftrack bench NAME --json``) in a new process and
writes its JSON result, wrapped with what is needed to read it later, to
``results/NAME-DATE.json``::

    python docs/_ext/pftrack_results.py record pets09-ground -- --no-ablation

Each file holds ``benchmark``, ``args`` (the bench's own arguments), ``commit`` (``git
rev-parse HEAD`` and whether the working tree had changes), ``date`` (UTC, ISO 8601),
``machine`` (host name, processor, logical cores, Python, the 1-minute load before and after),
``wall_s``, ``protocol`` (which frames or seeds chose the settings and which are reported, as
the benchmark declares it and its JSON carries it: :func:`protocol_of`) and ``result`` (the
benchmark's JSON as printed), and ``ran_as`` when the benchmark has been renamed since (the
name it ran under). No figure is typed by hand: every number comes from the run.

Rendering (the Sphinx side, called by ``pftrack_docs``): :func:`results_page` reads every file
of ``results/`` and writes one section per benchmark from its latest file, the headline figures
(:data:`HEADLINE`) in a table with the file's commit, date, machine and protocol.
"""

from __future__ import annotations

import datetime as _dt
import json
import os
import platform
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[2]
RESULTS = ROOT / "results"

#: The keys of the protocol a benchmark declares (``PROTOCOL`` in its module of
#: ``pftrack_bench``) and its JSON result carries under ``"protocol"``.
PROTOCOL_KEYS = ("data", "chosen_on", "reported_on")


def protocol_of(name: str, result: dict[str, Any]) -> dict[str, str]:
    """The protocol a benchmark's JSON result carries (the words of :data:`PROTOCOL_KEYS`).

    Raises
    ------
    ValueError
        The result carries no protocol (a benchmark that declares none, or a result file
        written before benchmarks carried theirs).
    """
    proto = result.get("protocol")
    if not isinstance(proto, dict) or any(k not in proto for k in PROTOCOL_KEYS):
        raise ValueError(f"results: the result of benchmark {name!r} carries no protocol "
                         f"({', '.join(PROTOCOL_KEYS)} under 'protocol'); every benchmark of "
                         "pftrack_bench declares one")
    return {k: str(proto[k]) for k in PROTOCOL_KEYS}


#: The figures shown per benchmark on the results page (keys of its JSON result, dotted for a
#: nested one), with a label.
HEADLINE: dict[str, list[tuple[str, str]]] = {
    "pets09-ground": [("MOTA", "MOTA (IoU 0.5)"), ("IDF1", "IDF1"), ("HOTA", "HOTA"),
                      ("median_error_m", "median ground error (m)"),
                      ("accuracy_5px", "within 5 px (the paper's accuracy)"),
                      ("frames_per_second_cpu", "frames per second of CPU time")],
    "fresh-video": [("MOTA", "MOTA (IoU 0.5), seed 0"), ("IDF1", "IDF1, seed 0"),
                    ("HOTA", "HOTA, seed 0"), ("seeds.n", "tracking seeds in the means (from 0)"),
                    ("seeds.MOTA_mean", "MOTA, mean over the seeds"),
                    ("seeds.IDF1_mean", "IDF1, mean over the seeds"),
                    ("seeds.HOTA_mean", "HOTA, mean over the seeds"),
                    ("peer.MOTA", "norfair on the same detections: MOTA"),
                    ("peer.IDF1", "norfair: IDF1"), ("peer.HOTA", "norfair: HOTA"),
                    ("camera_median_error_m", "estimated camera: median ground error (m)"),
                    ("frames_per_second_cpu", "frames per second of CPU time")],
    "own-detections": [("speed.people-image.cpu_ms_per_frame",
                        "people-image: CPU ms per frame (detections given)"),
                       ("speed.people-image.ratio_to_bytetrack",
                        "people-image: CPU time per frame / ByteTrack's, same run"),
                       ("speed.norfair.ratio_to_bytetrack",
                        "norfair: CPU time per frame / ByteTrack's, same run")],
    "coast": [("pets09.MOTA_world", "PETS: MOTA on the ground (1 m)"),
                ("pets09.IDF1_world", "PETS: IDF1 on the ground"),
                ("pets09.HOTA_world", "PETS: HOTA on the ground"),
                ("pets09.median_error_m", "PETS: median ground error (m)"),
                ("pets09.entry_exit_within_10", "PETS: people with entry and exit within 10 "
                                                "frames"),
                ("pets09.mog2.MOTA_world", "PETS, MOG2 fraction instead: MOTA on the ground"),
                ("pets09.frames_per_second_3x5000",
                 "PETS: frames per second of CPU, 3 groups of 5000 particles"),
                ("coast.frames_per_second_3x5000",
                 "coast: frames per second of CPU, 3 groups of 5000 particles"),
                ("coast.multi.MOTA_world", "coast, two boats and a car: MOTA on the ground"),
                ("coast.multi.IDF1_world", "coast, two boats and a car: IDF1 on the ground")],
    "camera-network": [(f"table1[method={m}].ari_mean", f"mean ARI: {label}") for m, label in (
        ("greedy", "greedy"), ("min-cost-flow", "min-cost flow"),
        ("trajectory-ensemble", "Trajectory Ensemble (C_d = 9, S = 100)"),
        ("trajectory-ensemble (C_d=5, tuned)", "Trajectory Ensemble, tuned C_d = 5"),
        ("trajectory-ensemble-gated (C_d=5, tuned)", "appearance-gated ensemble, C_d = 5"))]
    + [("seconds.trajectory_ensemble_one_run_median",
        "Trajectory Ensemble: seconds per run (median)")],
    "detectors": [(f"test.{d}.{v}.{f}", f"{d}, {v}: {f}")
                  for v in ("pets09", "mot17-09") for d in ("hog-people", "ssdlite-people")
                  for f in ("recall", "precision")]
    + [(f"speed[size={size}].ms_per_frame.{d}", f"{d}: ms per frame at {size}")
       for size in ("640x480", "1920x1080") for d in ("hog-people", "ssdlite-people")],
    "background": [(f"thermal.runs[clip={c},method={m}].{f}", f"thermal, {c}, {m}: {label}")
                   for c in ("recorded", "simulated") for m in ("eigenspace", "mog2")
                   for f, label in (("recall", "recall"),
                                    ("block_precision", "block precision"),
                                    ("false_alarm_frames", "false-alarm frames"))],
    "soccer": [("MOTA", "MOTA (IoU 0.5)"), ("IDF1", "IDF1"), ("HOTA", "HOTA"),
               ("MOTA_world", "MOTA on the ground"), ("IDF1_world", "IDF1 on the ground"),
               ("accuracy_5px", "within 5 px (the paper's accuracy)"),
               ("frames_per_second",
                "frames per second (wall time of detection and tracking)")],
}


def value_at(result: dict[str, Any], key: str) -> Any:
    """``result[key]``, a dotted key walking into nested mappings; None when absent.

    A part ``NAME[k=v,...]`` picks, from the list ``NAME``, the one record whose fields ``k``
    equal ``v`` (compared as text): ``rows[likelihood=cross-entropy-bg,samples=500,targets=3]
    .frames_per_second``; no record or several is None. ``NAME[i]`` is the list's item ``i``."""
    value: Any = result
    for part in re.findall(r"[^.\[]+(?:\[[^\]]*\])?", key):
        sel = None
        if part.endswith("]") and "[" in part:
            part, _, cond = part[:-1].partition("[")
            # conditions split at commas that start a new ``field=``: a value may hold commas
            sel = dict(c.split("=", 1) for c in re.split(r",(?=\s*[\w-]+=)", cond) if "=" in c)
        if not isinstance(value, dict) or part not in value:
            return None
        value = value[part]
        if sel is not None and not sel and cond.strip().isdigit():
            i = int(cond)
            if not isinstance(value, list) or i >= len(value):
                return None
            value = value[i]
        elif sel is not None:
            if not isinstance(value, list):
                return None
            hits = [r for r in value if isinstance(r, dict)
                    and all(str(r.get(k.strip())) == v.strip() for k, v in sel.items())]
            if len(hits) != 1:
                return None
            value = hits[0]
    return value


def _git(*args: str) -> str:
    return subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True,
                          check=True).stdout.strip()


def machine() -> dict[str, Any]:
    """The machine a result was measured on."""
    return {"host": platform.node(), "processor": platform.processor() or platform.machine(),
            "logical_cores": os.cpu_count(), "python": platform.python_version(),
            "system": f"{platform.system()} {platform.release()}"}


def _split_variant(name: str) -> tuple[str, str | None]:
    """``NAME@VARIANT`` -> (NAME, VARIANT); a plain NAME -> (NAME, None)."""
    bench, _, variant = name.partition("@")
    if variant and not re.fullmatch(r"[a-z0-9][a-z0-9-]*", variant):
        raise ValueError(f"results: variant {variant!r} of {bench}: use lower-case letters, "
                         "digits and '-'")
    return bench, variant or None


def _key(doc: dict[str, Any]) -> str:
    """A result's key on the results page: its benchmark, ``@variant`` when it has one."""
    return doc["benchmark"] + (f"@{doc['variant']}" if doc.get("variant") else "")


def record(name: str, args: list[str], out_dir: Path = RESULTS,
           python: str = sys.executable) -> Path:
    """Run ``pftrack bench NAME --json ARGS`` and write its result with its provenance.

    ``name`` may be ``NAME@VARIANT``: the same benchmark recorded in another configuration (its
    ARGS), kept beside the default one on the results page (``camera-network@stripes``).
    Returns the file written (``out_dir/NAME[@VARIANT]-YYYYmmddTHHMMSSZ.json``, atomically).

    Raises
    ------
    RuntimeError
        The benchmark failed (its exit code and the end of its stderr).
    """
    bench, variant = _split_variant(name)
    date = _dt.datetime.now(_dt.UTC).replace(microsecond=0)
    commit = {"sha": _git("rev-parse", "HEAD"),
              "dirty": bool(_git("status", "--porcelain", "--untracked-files=no"))}
    load_before = os.getloadavg()[0]
    with tempfile.TemporaryDirectory(prefix="pftrack-results-") as tmp:
        raw = Path(tmp) / "result.json"
        t0 = time.perf_counter()
        proc = subprocess.run([python, "-m", "pftrack", "bench", bench, "--json", "--out",
                               str(raw), *args], cwd=ROOT, capture_output=True, text=True)
        wall = time.perf_counter() - t0
        if proc.returncode != 0:
            raise RuntimeError(f"pftrack bench {bench} failed (exit {proc.returncode}): "
                               f"{proc.stderr[-2000:]}")
        result = json.loads(raw.read_text())
    doc = {"benchmark": bench, **({"variant": variant} if variant else {}), "args": args,
           "commit": commit, "date": date.isoformat().replace("+00:00", "Z"),
           "machine": {**machine(), "load_1min_before": load_before,
                       "load_1min_after": os.getloadavg()[0]},
           "wall_s": wall, "protocol": protocol_of(bench, result), "result": result}
    out_dir.mkdir(parents=True, exist_ok=True)
    dest = out_dir / f"{name}-{date.strftime('%Y%m%dT%H%M%SZ')}.json"
    tmp_dest = dest.with_suffix(".json.tmp")
    tmp_dest.write_text(json.dumps(doc, indent=2, default=float) + "\n")
    os.replace(tmp_dest, dest)
    return dest


def wrap(name: str, result_file: Path, args: list[str], out_dir: Path = RESULTS) -> Path:
    """Record a result a benchmark already wrote (``pftrack bench NAME --out FILE``, e.g. one
    process per video joined by the benchmark's own merge): the same file as :func:`record`,
    with the commit, date and machine the result states when it states them."""
    bench, variant = _split_variant(name)
    result = json.loads(Path(result_file).read_text())
    commit = ({"sha": result["commit"], "dirty": bool(result.get("dirty"))}
              if isinstance(result.get("commit"), str) else
              {"sha": _git("rev-parse", "HEAD"),
               "dirty": bool(_git("status", "--porcelain", "--untracked-files=no"))})
    date = result.get("date_utc") or _dt.datetime.now(_dt.UTC).replace(
        microsecond=0).isoformat().replace("+00:00", "Z")
    stated = result.get("machine") or {}
    mach = {**machine(), "load_1min_before": None, "load_1min_after": None}
    mach["logical_cores"] = stated.get("cpu_count", mach["logical_cores"])
    doc = {"benchmark": bench, **({"variant": variant} if variant else {}), "args": args,
           "commit": commit, "date": date, "machine": mach,
           "wall_s": None, "wrapped": Path(result_file).name,
           "protocol": protocol_of(bench, result), "result": result}
    out_dir.mkdir(parents=True, exist_ok=True)
    stamp = date.replace("-", "").replace(":", "")
    dest = out_dir / f"{name}-{stamp}.json"
    tmp_dest = dest.with_suffix(".json.tmp")
    tmp_dest.write_text(json.dumps(doc, indent=2, default=float) + "\n")
    os.replace(tmp_dest, dest)
    return dest


def _summary_tables(res: dict[str, Any]) -> list[str]:
    """A result's ``summary`` rows (video, level, tracker and ``<figure>_mean`` columns, as
    ``own-detections`` writes them) as one table per video and level."""
    rows = res.get("summary")
    if not isinstance(rows, list) or not rows or not isinstance(rows[0], dict):
        return _rows_table(res.get("rows"))
    figures = [f for f in ("HOTA", "IDF1", "MOTA", "IDSW", "Frag") if f"{f}_mean" in rows[0]]
    out: list[str] = []
    groups: dict[tuple[str, str], list[dict[str, Any]]] = {}
    for r in rows:
        groups.setdefault((str(r.get("video")), str(r.get("level"))), []).append(r)
    for (video, level), rs in groups.items():
        out += [f"**{video}, {level} detections** (mean over the runs)", "",
                "| tracker | " + " | ".join(figures) + " | CPU ms per frame |",
                "|---" * (len(figures) + 2) + "|"]
        out += ["| " + " | ".join([str(r.get("tracker"))]
                                  + [_fmt(r.get(f"{f}_mean")) for f in figures]
                                  + [_fmt(r.get("cpu_ms_per_frame"))]) + " |" for r in rs]
        out.append("")
    return out


def _rows_table(rows: Any, most: int = 9) -> list[str]:
    """A result's ``rows`` (a list of flat records, as most benchmarks write them) as one table
    of their first ``most`` scalar columns."""
    if not isinstance(rows, list) or not rows or not all(isinstance(r, dict) for r in rows):
        return []
    cols = [k for k, v in rows[0].items()
            if isinstance(v, (int, float, str)) and not isinstance(v, bool)][:most]
    if not cols:
        return []
    out = ["| " + " | ".join(cols) + " |", "|---" * len(cols) + "|"]
    out += ["| " + " | ".join(_fmt(r.get(c, "")) for c in cols) + " |" for r in rows]
    return out + [""]


def load_results(folder: Path = RESULTS) -> dict[str, dict[str, Any]]:
    """The latest result file of each benchmark in ``folder``, by benchmark name.

    Raises
    ------
    ValueError
        A file is not a result file (it names the file and the missing key).
    """
    latest: dict[str, dict[str, Any]] = {}
    for path in sorted(folder.glob("*.json")):
        doc = json.loads(path.read_text())
        for key in ("benchmark", "commit", "date", "machine", "protocol", "result"):
            if key not in doc:
                raise ValueError(f"results: {path.name} has no '{key}'")
        doc["file"] = path.name
        name = _key(doc)
        if name not in latest or doc["date"] > latest[name]["date"]:
            latest[name] = doc
    return latest


def _fmt(value: Any) -> str:
    if isinstance(value, float):
        return f"{value:.4g}"
    return str(value)


def figure(spec: str, folder: Path = RESULTS,
           _cache: dict[Path, dict[str, dict[str, Any]]] | None = None) -> str:
    """The text of one measured figure for prose: ``spec`` is ``NAME:KEY`` or
    ``NAME:KEY:FORMAT`` -- the benchmark, the (dotted) key into its latest result, and a
    Python format spec (default 4 significant digits; ``%`` for a percentage).

    Raises
    ------
    ValueError
        No result of that benchmark is committed, or its latest result has no such number.
    """
    parts = spec.split(":")
    if len(parts) not in (2, 3):
        raise ValueError(f"result figure {spec!r}: expected NAME:KEY or NAME:KEY:FORMAT")
    name, key = parts[0].strip(), parts[1].strip()
    docs = load_results(folder) if _cache is None else _cache.setdefault(folder,
                                                                         load_results(folder))
    if name not in docs:
        raise ValueError(f"result figure {spec!r}: no result of benchmark {name!r} in "
                         f"{folder} (record one: python docs/_ext/pftrack_results.py record "
                         f"{name})")
    value = value_at(docs[name]["result"], key)
    is_number = isinstance(value, (int, float)) and not isinstance(value, bool)
    if not is_number:
        raise ValueError(f"result figure {spec!r}: results/{docs[name]['file']} has no number "
                         f"at {key!r} (found {value!r})")
    return format(value, parts[2]) if len(parts) == 3 else _fmt(value)


def result_role(name: str, rawtext: str, text: str, lineno: int, inliner: Any,
                options: Any = None, content: Any = None) -> tuple[list[Any], list[Any]]:
    """The Sphinx role ``{result}`NAME:KEY[:FORMAT]``: a figure read from the latest committed
    result of benchmark NAME (:func:`figure`), linked to its section of the results page; an
    unknown benchmark or key is a build error, so prose cannot quote a figure no run made."""
    from docutils import nodes

    try:
        value = figure(text, _cache=_ROLE_CACHE)
    except ValueError as exc:
        msg = inliner.reporter.error(str(exc), line=lineno)
        return [inliner.problematic(rawtext, rawtext, msg)], [msg]
    from sphinx import addnodes

    bench = text.split(":")[0].strip().replace("@", "-")
    ref = addnodes.pending_xref(rawtext, refdomain="std", reftype="ref",
                                reftarget=f"results-{bench}", refexplicit=True,
                                refwarn=True)
    ref += nodes.inline(value, value)
    return [ref], []


_ROLE_CACHE: dict[Path, dict[str, dict[str, Any]]] = {}


def results_page(folder: Path = RESULTS) -> str:
    """The results page's body (MyST Markdown): per benchmark, its latest file's headline
    figures (:data:`HEADLINE`, else every number at the top level of its result), the command
    that measured them and its provenance."""
    lines = ["<!-- generated by docs/_ext/pftrack_results.py from results/*.json: do not "
             "edit -->", ""]
    docs = load_results(folder)
    if not docs:
        return "\n".join(lines + ["No result file is committed yet.", ""])
    for name, doc in sorted(docs.items()):
        res = doc["result"]
        keys = HEADLINE.get(doc["benchmark"]) or [(k, k) for k, v in res.items()
                                      if isinstance(v, (int, float)) and not isinstance(v, bool)]
        # ``ran_as``: the name the benchmark had when this file was recorded
        cmd = " ".join(["pftrack bench", doc.get("ran_as") or doc["benchmark"], "--json",
                        *doc.get("args", [])])
        m = doc["machine"]
        lines += [f"(results-{name.replace('@', '-')})=", f"## `{name}`", ""]
        head = [f"| {label} | {_fmt(value_at(res, k))} |" for k, label in keys
                if value_at(res, k) is not None]
        if head:
            lines += ["| figure | value |", "|---|---|", *head]
        tables = _summary_tables(res)
        if tables:
            lines += [""] + tables
        lines += ["", f"Measured by `{cmd}` on {doc['date']} at commit "
                  f"`{doc['commit']['sha'][:10]}`"
                  + (" (with uncommitted changes)" if doc["commit"].get("dirty") else "")
                  + f"; {m.get('logical_cores')} logical cores ({m.get('processor')})"
                  + (f", 1-minute load {_fmt(m.get('load_1min_before'))} before and "
                     f"{_fmt(m.get('load_1min_after'))} after"
                     if m.get("load_1min_before") is not None else "")
                  + f"; file `results/{doc['file']}`.", ""]
        proto = doc["protocol"]
        if proto:
            lines += [f"- **{k.replace('_', ' ')}**: {v}" for k, v in proto.items()]
            lines.append("")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    """``record NAME [-- BENCH ARGS...]``: run and record one benchmark; ``wrap NAME FILE
    [-- BENCH ARGS...]``: record a result file the benchmark already wrote."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if len(argv) >= 3 and argv[0] == "wrap":
        rest = argv[3:]
        print(wrap(argv[1], Path(argv[2]), rest[1:] if rest[:1] == ["--"] else rest))
        return 0
    if len(argv) < 2 or argv[0] != "record":
        print("usage: python docs/_ext/pftrack_results.py record NAME [-- ARGS...]",
              file=sys.stderr)
        return 2
    name, rest = argv[1], argv[2:]
    if rest[:1] == ["--"]:
        rest = rest[1:]
    print(record(name, rest))
    return 0


if __name__ == "__main__":
    sys.exit(main())
