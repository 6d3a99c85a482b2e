"""pftrack's benchmarks and paper experiments: ``pftrack bench NAME``.

Not part of the product: ``pip install pftrack`` does not install this package. It is a
distribution of its own in the repository (``benchmarks/``), installed editable by ``./dev``,
and registered through the ``pftrack`` entry-point group exactly as a third-party plugin is
(entry point ``bench``). The product (``toolkit/``, ``plugins/``) never imports it.

Each benchmark is a module of this package with ``run``, ``add_arguments``, optionally
``format_table``, and a ``PROTOCOL`` (:class:`pftrack_bench.protocol.Protocol`) declaring what
chose its settings and what it reports; the JSON it prints carries that protocol.
"""

from __future__ import annotations

from pftrack import hookimpl

__version__ = "0.1.0"

#: Benchmark name -> its module in this package.
BENCHMARKS: dict[str, str] = {
    "core": "core",
    "colour": "colour",
    "pets09-colour": "pets09_colour",
    "people-colour": "people_colour",
    "background": "background",
    "coast": "coast",
    "camera-network": "camera_network",
    "batch": "batch",
    "detectors": "detectors",
    "fresh-video": "fresh_video",
    "mog2-people": "mog2_people",
    "own-detections": "own_detections",
    "pets09-ground": "pets09_ground",
    "soccer": "soccer",
}


def protocols() -> dict[str, dict[str, str]]:
    """Every benchmark's protocol in words, by benchmark name (what its JSON carries)."""
    from importlib import import_module

    return {name: import_module(f"pftrack_bench.{module}").PROTOCOL.as_dict()
            for name, module in BENCHMARKS.items()}


@hookimpl
def pftrack_register_benchmarks(register):
    from importlib import import_module

    from pftrack_bench.protocol import benchmark

    for name, module in BENCHMARKS.items():
        register(name, benchmark(import_module(f"pftrack_bench.{module}")))
