"""The ``pftrack`` command keeps large arrays in the heap (glibc): a freed 48 MB array stays
with the process for the next frame instead of going back to the kernel; off with
``PFTRACK_MALLOC=default``."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="glibc only")

_PROBE = """
import os, sys
import numpy as np
from pftrack.cli import _alloc
kept = _alloc.keep_large_arrays() if sys.argv[1] == "keep" else False
page = os.sysconf("SC_PAGE_SIZE")
def rss():
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * page
a = np.ones(6_000_000)  # 48 MB, touched
before = rss()
del a
print(kept, _alloc.kept(), (before - rss()) / 2**20)
"""


def _probe(mode: str, **env: str) -> tuple[bool, bool, float]:
    out = subprocess.run([sys.executable, "-c", _PROBE, mode], capture_output=True, text=True,
                         check=True, env=dict(os.environ, **env)).stdout.split()
    return out[0] == "True", out[1] == "True", float(out[2])


def _is_glibc() -> bool:
    import ctypes

    try:
        ctypes.CDLL(None).gnu_get_libc_version  # noqa: B018
    except AttributeError:
        return False
    return True


@pytest.mark.skipif(not _is_glibc(), reason="glibc only")
def test_a_freed_large_array_stays_in_the_heap_only_when_kept():
    kept, flag, returned_mb = _probe("keep")
    assert kept and flag
    assert returned_mb < 8  # the 48 MB stay with the process, for the next frame's arrays
    kept, flag, returned_mb = _probe("default")
    assert not kept and not flag
    assert returned_mb > 40  # glibc's default: an mmap'd array goes back to the kernel
    kept, flag, returned_mb = _probe("keep", PFTRACK_MALLOC="default")
    assert not kept and not flag and returned_mb > 40


@pytest.mark.skipif(not _is_glibc(), reason="glibc only")
@pytest.mark.parametrize("setting, expected", [("", True), ("default", False)])
def test_the_command_keeps_large_arrays_and_bench_core_says_so(setting, expected):
    env = dict(os.environ, PFTRACK_MALLOC=setting)
    out = subprocess.run([sys.executable, "-m", "pftrack", "bench", "core", "--json",
                          "--no-stonesoup", "--particles", "1000", "--repeats", "1"],
                         capture_output=True, text=True, check=True, env=env).stdout
    assert json.loads(out)["environment"]["heap_keeps_large_arrays"] is expected
