"""`exhibit bench NAME`: benchmarks (speed is measured here, never in timed tests).

Each benchmark is a module of this package, above the libraries it measures (geometry, surfaces,
scenes, render, devices, kiosk), so measuring a layer never makes it import a higher one. A module
has HELP, add_arguments(parser) and run(args); this one only dispatches. Every benchmark
compares against a baseline in the
same run, so ratios hold on a noisy machine.
"""

from __future__ import annotations

import argparse
import contextlib
import importlib
import os
import sys

#: numpy's BLAS threads: OpenBLAS (and MKL, BLIS) start one thread per core and let them spin
#: for a while after every call, so a numpy baseline timed just before a GL variant steals a core
#: from llvmpipe's rasteriser threads and skews the next measurement (the render floor measured
#: after the CPU baseline was the victim). The benchmarks time with one BLAS thread: set in the
#: environment before numpy is first imported (this module is imported before any benchmark,
#: and `exhibit` imports numpy for no other command first), and, if threadpoolctl is installed,
#: also limited at run time in case numpy was already imported (tests calling main() in-process).
BLAS_THREAD_VARIABLES = (
    "OPENBLAS_NUM_THREADS",
    "OMP_NUM_THREADS",
    "MKL_NUM_THREADS",
    "BLIS_NUM_THREADS",
)
if "numpy" not in sys.modules:
    for _name in BLAS_THREAD_VARIABLES:
        os.environ.setdefault(_name, "1")

HELP = "benchmarks: " + ", ".join(
    ["mesh", "render", "kiosk", "startup", "input", "governor", "next-scene"]
)

#: benchmark name -> module providing HELP, add_arguments, run
BENCHMARKS = {
    "mesh": "exhibit.commands.bench.mesh",
    "render": "exhibit.commands.bench.render",
    "kiosk": "exhibit.commands.bench.kiosk",
    "startup": "exhibit.commands.bench.startup",
    "input": "exhibit.commands.bench.input",
    "governor": "exhibit.commands.bench.governor",
    "next-scene": "exhibit.commands.bench.next_scene",
}


def add_arguments(parser: argparse.ArgumentParser) -> None:
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


def one_blas_thread():
    """A context limiting numpy's BLAS to one thread while benchmarks time (threadpoolctl when
    installed; otherwise the environment set at import does it, or nothing can)."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:
        return contextlib.nullcontext()
    return threadpool_limits(limits=1, user_api="blas")


def run(args: argparse.Namespace) -> int:
    with one_blas_thread():
        return args._bench(args)
