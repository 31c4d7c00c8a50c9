"""`exhibit bench mesh`: the implicit polygonizer on the collision surface (Figure 17's case) at
growing resolution, against a dense baseline that visits all n⁴ cells, in the same run."""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import time

from exhibit.errors import ExhibitError
from exhibit.scenes import collision
from exhibit.surfaces.expressions import compile_field
from exhibit.surfaces.implicit import polygonize

HELP = "time the implicit polygonizer (collision surface) against a dense n^4 baseline"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--sizes", default="16,32,64,128", help="resolutions (default: %(default)s)"
    )
    parser.add_argument(
        "--dense-sizes",
        default="8,16",
        help="resolutions for the dense baseline (default: %(default)s)",
    )
    parser.add_argument("--repeat", type=int, default=3, help="runs per size; the median counts")
    parser.add_argument("--json", action="store_true", help="print JSON")


def _sizes(text: str, option: str) -> list[int]:
    try:
        sizes = [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise ExhibitError(
            f"{option}: expected comma-separated whole numbers, got {text!r}"
        ) from None
    if not sizes or any(not 2 <= n <= 512 for n in sizes):
        raise ExhibitError(f"{option}: sizes must lie between 2 and 512")
    return sizes


def run(args: argparse.Namespace) -> int:
    sizes = _sizes(args.sizes, "--sizes")
    dense_sizes = _sizes(args.dense_sizes, "--dense-sizes")
    if args.repeat < 1:
        raise ExhibitError("--repeat must be at least 1")
    params = collision.FIGURE_PARAMS[17]
    f = compile_field(collision.CYLINDER, collision.AXES, params)
    g = compile_field(collision.SPHERE, collision.AXES, params)
    lo, hi = collision.box(params)

    def measure(n, prune):
        times, result = [], None
        for _ in range(args.repeat):
            start = time.perf_counter()
            result = polygonize("bench", f, g, lo, hi, n, seed=1, prune=prune)
            times.append(time.perf_counter() - start)
        return statistics.median(times), result

    measure(8, True)  # warm up numpy and the lambdified functions
    results, dense = [], []
    for n in sizes:
        seconds, result = measure(n, True)
        results.append(
            {
                "n": n,
                "seconds": round(seconds, 4),
                "triangles": len(result.surface.triangles),
                "max_residual": result.stats.max_residual,
                "cells": result.stats.cells,
            }
        )
    for n in dense_sizes:
        seconds, result = measure(n, False)
        dense.append(
            {"n": n, "seconds": round(seconds, 4), "triangles": len(result.surface.triangles)}
        )
    report = {
        "machine": f"{platform.machine()}, {os.cpu_count()} cores, "
        f"Python {platform.python_version()}",
        "surface": "collision, rc=1, rs=1.2, vc=0, vs=1 (Figure 17)",
        "results": results,
        "dense_baseline": dense,
    }
    if args.json:
        print(json.dumps(report, indent=2))
        return 0
    print(f"{report['surface']} on {report['machine']}; median of {args.repeat}")
    print(f"{'n':>5} {'seconds':>9} {'ratio':>6} {'triangles':>10} {'cells':>9} {'residual':>9}")
    previous = None
    for row in results:
        ratio = f"{row['seconds'] / previous:6.2f}" if previous else "     -"
        previous = row["seconds"]
        print(
            f"{row['n']:>5} {row['seconds']:>9.3f} {ratio} {row['triangles']:>10} "
            f"{row['cells']:>9} {row['max_residual']:>9.1e}"
        )
    print("dense baseline (every cell of the n^4 grid):")
    by_n = {row["n"]: row for row in results}
    for row in dense:
        pruned = by_n.get(row["n"])
        speedup = f", pruned is {row['seconds'] / pruned['seconds']:.1f}x faster" if pruned else ""
        print(f"{row['n']:>5} {row['seconds']:>9.3f} s, {row['triangles']} triangles{speedup}")
    return 0
