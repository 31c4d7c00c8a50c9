"""`exhibit bench NAME`: benchmarks (speed is measured here, never in timed tests).

Each benchmark lives beside the code it measures, in a module with HELP, add_arguments(parser)
and run(args); this command only dispatches. Every benchmark compares against a baseline in the
same run, so ratios hold on a noisy machine.
"""

from __future__ import annotations

import importlib

HELP = "benchmarks: " + ", ".join(["mesh", "render", "startup", "input"])

#: benchmark name -> module providing HELP, add_arguments, run
BENCHMARKS = {
    "mesh": "exhibit.surfaces.bench",
    "render": "exhibit.render.bench",
    "startup": "exhibit.kiosk.bench",
    "input": "exhibit.devices.bench",
}


def add_arguments(parser) -> None:
    sub = parser.add_subparsers(dest="benchmark", metavar="BENCHMARK", required=True)
    for name, module_name in BENCHMARKS.items():
        try:
            module = importlib.import_module(module_name)
        except ModuleNotFoundError as exc:
            if exc.name is None or not module_name.startswith(exc.name):
                raise
            continue  # that part of the exhibit is not built yet
        bench = sub.add_parser(name, help=module.HELP, description=module.HELP)
        module.add_arguments(bench)
        bench.set_defaults(_bench=module.run)


def run(args) -> int:
    return args._bench(args)
