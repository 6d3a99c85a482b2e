"""The jobs of a batch (``pftrack batch``): :class:`Job`, and reading them from a JOBS file or a
parsed document, defaults and ``matrix`` expanded, relative paths made absolute. The file's
format, and how :func:`pftrack.workflows.batch.run_batch` runs the jobs, are described in
:mod:`pftrack.workflows.batch`.
"""

from __future__ import annotations

import hashlib
import itertools
import json
import os
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

KINDS = ("config", "demo", "bench")  # the field that names a job's kind (config: a run job)
RUN_FIELDS = {"config", "video", "camera", "gt", "frames", "seed", "detector_model", "set",
              "report"}
TOOL_FIELDS = {"args", "seed"}
COMMON_FIELDS = {"name", "group", "matrix"}
PATH_FIELDS = ("video", "camera", "gt", "detector_model")
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9._=-]*$")


@dataclass(frozen=True)
class Job:
    """One job of a batch.

    Attributes
    ----------
    name : str
        Its folder under the batch's output folder (letters, digits, ``. _ - =``).
    kind : {"run", "demo", "bench"}
        ``run``: ``pftrack run``; ``demo``, ``bench``: a registered demo or benchmark.
    spec : dict
        Its fields: for ``run`` the :func:`pftrack.workflows.pipeline.run_pipeline` arguments
        (``config``, ``video``, ``camera``, ``gt``, ``frames``, ``seed``, ``detector_model``,
        ``set``, ``report``), paths absolute; for ``demo``/``bench`` its name (``demo`` or
        ``bench``), ``args`` (a list of strings) and ``seed``.
    group : str
        Jobs that differ only by seed share a group (the table's aggregates).
    """

    name: str
    kind: str
    spec: dict[str, Any]
    group: str = ""

    @property
    def seed(self) -> int | None:
        s = self.spec.get("seed")
        return None if s is None else int(s)

    def token(self) -> str:
        """A digest of the job (kind and fields): a folder is this job's only if it matches."""
        text = json.dumps({"name": self.name, "kind": self.kind, "spec": self.spec},
                          sort_keys=True, default=str)
        return hashlib.sha256(text.encode()).hexdigest()[:16]


def load_jobs(path: str | os.PathLike[str]) -> list[Job]:
    """The jobs of a JOBS YAML file (format in the module docstring), matrices expanded.

    Raises
    ------
    FileNotFoundError
        No such file.
    ValueError
        Bad YAML, an unknown key, a missing field, a duplicate name: the message names the file,
        the job and the field.
    """
    import yaml

    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"jobs file {path} not found")
    try:
        doc = yaml.safe_load(path.read_text())
    except yaml.YAMLError as exc:
        raise ValueError(f"jobs file {path}: not valid YAML: {exc}") from None
    return parse_jobs(doc, base=path.parent, where=str(path))


def parse_jobs(doc: Any, *, base: str | os.PathLike[str] = ".", where: str = "jobs"
               ) -> list[Job]:
    """Jobs from a parsed JOBS document ``{defaults: {...}, jobs: [...]}`` (or a bare list).

    ``base`` is the folder relative paths are read from; ``where`` names the source in errors.
    """
    if isinstance(doc, list):
        doc = {"jobs": doc}
    if not isinstance(doc, dict):
        raise ValueError(  # noqa: TRY004 - a user's input error, reported as one line
            f"{where}: expected a mapping with 'jobs' (and optional 'defaults')")
    unknown = set(doc) - {"jobs", "defaults"}
    if unknown:
        raise ValueError(f"{where}: unknown top-level keys {sorted(unknown)}; known: "
                         "['defaults', 'jobs']")
    defaults = doc.get("defaults") or {}
    if not isinstance(defaults, dict):
        raise ValueError(f"{where}: 'defaults' must be a mapping")  # noqa: TRY004
    bad = set(defaults) - RUN_FIELDS - TOOL_FIELDS
    if bad:
        raise ValueError(f"{where}: unknown field(s) {sorted(bad)} in 'defaults'; known: "
                         f"{sorted(RUN_FIELDS | TOOL_FIELDS)}")
    entries = doc.get("jobs")
    if not isinstance(entries, list) or not entries:
        raise ValueError(f"{where}: 'jobs' must be a non-empty list")
    jobs: list[Job] = []
    for i, entry in enumerate(entries):
        if not isinstance(entry, dict):
            raise ValueError(  # noqa: TRY004
                f"{where}: job {i + 1} must be a mapping, got {entry!r}")
        label = f"{where}: job {entry.get('name', i + 1)!r}"
        kind = next((k for k in KINDS if entry.get(k) is not None), None)
        fits = RUN_FIELDS if kind == "config" else TOOL_FIELDS  # defaults a job's kind takes
        merged = {**{k: v for k, v in defaults.items() if k in fits}, **entry}
        jobs.extend(expand_matrix(merged, base=Path(base), label=label))
    seen: set[str] = set()
    for job in jobs:
        if job.name in seen:
            raise ValueError(f"{where}: two jobs are named {job.name!r}; names are folders and "
                             "must be unique")
        seen.add(job.name)
    return jobs


def _slug(value: Any) -> str:
    if isinstance(value, (str, os.PathLike)) and ("/" in str(value) or "\\" in str(value)):
        value = Path(value).stem
    text = re.sub(r"[^A-Za-z0-9.=-]+", "_", str(value)).strip("_")
    return text or "x"


def expand_matrix(entry: dict[str, Any], *, base: Path = Path("."), label: str = "job"
                  ) -> list[Job]:
    """One job entry (a mapping) to its jobs: one, or the product of its ``matrix`` lists.

    A matrix key is one of the job's fields (``seed``, ``frames``, ``video``, ``set``, ``args``,
    ...); each expanded job is named ``NAME-KEYVALUE-...`` (``set`` and ``args`` by their
    index: ``set0``) and grouped with the jobs that differ from it only by seed.
    """
    entry = dict(entry)
    name = entry.get("name")
    if not isinstance(name, str) or not _NAME.match(name):
        raise ValueError(f"{label}: 'name' must be a folder name (letters, digits, . _ - =), "
                         f"got {name!r}")
    kinds = [k for k in KINDS if entry.get(k) is not None]
    if len(kinds) != 1:
        raise ValueError(f"{label}: give exactly one of 'config' (a pftrack run), 'demo' or "
                         f"'bench', got {kinds or 'none'}")
    kind = {"config": "run", "demo": "demo", "bench": "bench"}[kinds[0]]
    allowed = COMMON_FIELDS | (RUN_FIELDS if kind == "run" else TOOL_FIELDS | {kind})
    unknown = set(entry) - allowed
    if unknown:
        raise ValueError(f"{label}: unknown field(s) {sorted(unknown)} for a {kind} job; "
                         f"known: {sorted(allowed)}")
    matrix = entry.pop("matrix", None) or {}
    if not isinstance(matrix, dict):
        raise ValueError(f"{label}: 'matrix' must map fields to lists of values")  # noqa: TRY004
    for key, values in matrix.items():
        if key not in allowed - COMMON_FIELDS:
            raise ValueError(f"{label}: matrix field {key!r} is not a field of a {kind} job; "
                             f"known: {sorted(allowed - COMMON_FIELDS)}")
        if not isinstance(values, list) or not values:
            raise ValueError(f"{label}: matrix field {key!r} must be a non-empty list")
    group_base = entry.pop("group", None)
    keys = list(matrix)
    out = []
    for combo in itertools.product(*(matrix[k] for k in keys)):
        fields = {**entry, **dict(zip(keys, combo, strict=True))}
        parts, group_parts = [name], [group_base or name]
        for k, v in zip(keys, combo, strict=True):
            piece = f"{k}{matrix[k].index(v)}" if k in ("set", "args") else f"{k}{_slug(v)}"
            parts.append(piece)
            if k != "seed":
                group_parts.append(piece)
        fields["name"] = "-".join(parts)
        out.append(_make_job(fields, kind, base, f"{label.rsplit(':', 1)[0]}: job "
                                                  f"{fields['name']!r}",
                             group="-".join(group_parts)))
    return out


def _make_job(fields: dict[str, Any], kind: str, base: Path, label: str, group: str) -> Job:
    name = fields.pop("name")
    if not _NAME.match(name):
        raise ValueError(f"{label}: the expanded name {name!r} is not a folder name")
    spec: dict[str, Any] = {}
    if fields.get("seed") is not None:
        try:
            spec["seed"] = int(fields["seed"])
        except (TypeError, ValueError):
            raise ValueError(f"{label}: 'seed' must be an integer, got "
                             f"{fields['seed']!r}") from None
    if kind == "run":
        if not fields.get("video"):
            raise ValueError(f"{label}: missing field 'video' (the video file to track)")
        config = fields["config"]
        if isinstance(config, str) and (base / config).is_file():
            config = str((base / config).resolve())
        elif not isinstance(config, (str, dict)):
            raise ValueError(f"{label}: 'config' must be a preset name, a YAML path or a "
                             f"mapping, got {config!r}")
        spec["config"] = config
        for key in PATH_FIELDS:
            if fields.get(key) is not None:
                spec[key] = str((base / str(fields[key])).absolute())
        if fields.get("frames") is not None:
            from pftrack.io.frames import parse_frames

            try:
                first, last = parse_frames(str(fields["frames"]))
            except ValueError as exc:
                raise ValueError(f"{label}: field 'frames': {exc}") from None
            spec["frames"] = f"{first}:{'' if last is None else last}"
        overrides = fields.get("set") or {}
        if not isinstance(overrides, dict):
            raise ValueError(f"{label}: 'set' must map dotted parameter paths to values, got "
                             f"{overrides!r}")
        spec["set"] = dict(overrides)
        spec["report"] = bool(fields.get("report", False))
        spec.setdefault("seed", 0)
    else:
        target = fields[kind]
        args = fields.get("args") or []
        if isinstance(args, str):
            import shlex

            args = shlex.split(args)
        if not isinstance(args, list):
            raise ValueError(f"{label}: 'args' must be a list of strings, got {args!r}")
        spec[kind] = str(target)
        spec["args"] = [str(a) for a in args]
    return Job(name=name, kind=kind, spec=spec, group=group)
