"""``redres sweep``: run or resume a sweep spec, list the built-in specs.

::

    redres sweep SPEC.toml --out DIR [--workers N | --scheduler ADDRESS] [--json]
    redres sweep --list
    redres sweep SPEC.toml --out DIR --reuleaux map.h5   # a capability map, then HDF5
    redres sweep SPEC.toml --out DIR --html page.html    # then the sweep's HTML page

``SPEC`` is a file or the name of a built-in spec. Running the same command again on
the same folder resumes (finished shards are skipped); a folder of other files, or of a
sweep of other settings, is refused with one line. Exit codes as :mod:`redres.cli`.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

__all__ = ["register"]


def register(sub: argparse._SubParsersAction) -> None:  # type: ignore[type-arg]
    """Add the ``sweep`` subcommand to the ``redres`` parser's subparsers."""
    p = sub.add_parser("sweep", help="run a sweep spec: capability maps, IK datasets, ...")
    p.add_argument("spec", nargs="?", help="sweep spec file (TOML) or built-in spec name")
    p.add_argument("--out", help="output folder (absent, empty, or this sweep: resumed)")
    p.add_argument("--list", action="store_true", help="list the built-in sweep specs")
    engine = p.add_mutually_exclusive_group()
    engine.add_argument("--workers", type=int, help="local worker processes (default: all cores)")
    engine.add_argument(
        "--scheduler", metavar="ADDRESS", help="a running Dask scheduler, e.g. tcp://host:8786"
    )
    p.add_argument("--storage", choices=("zarr", "npz"),
                   help="array store of a new sweep (default: zarr if installed)")  # fmt: skip
    p.add_argument("--reuleaux", metavar="FILE.h5",
                   help="then export the capability map in Reuleaux's HDF5 layout")  # fmt: skip
    p.add_argument("--rows", metavar="FILE.npz|FILE.csv",
                   help="then export an IK dataset as training rows (pose, solution)")  # fmt: skip
    p.add_argument("--html", metavar="FILE.html",
                   help="then write the sweep's page: a map's 3D view, the ranked bases, "
                   "the scheme statistics")  # fmt: skip
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    p.set_defaults(func=main)


def main(args: argparse.Namespace) -> int:
    from ..sweeps.spec import builtin_specs, load_spec

    builtin = builtin_specs()
    if args.list:
        rows = []
        for name, path in sorted(builtin.items()):
            spec = load_spec(path)
            rows.append({"name": name, "kind": spec.kind, "description": spec.description})
        if args.json:
            print(json.dumps(rows))
        else:
            for row in rows:
                print(f"{row['name']:26s} {row['kind']:16s} {row['description']}")
        return 0
    if not args.spec or not args.out:
        print("redres sweep: error: give a spec and --out DIR (or --list)", file=sys.stderr)
        return 2
    if args.workers is not None and args.workers < 1:
        print(f"redres sweep: error: --workers must be >= 1; got {args.workers}", file=sys.stderr)
        return 2
    if args.rows and Path(args.rows).suffix.lower() not in (".npz", ".csv"):
        print(f"redres sweep: error: --rows writes .npz or .csv; got {args.rows}", file=sys.stderr)
        return 2
    from ..sweeps.engine import run

    target = args.spec
    path = builtin[target] if target in builtin and not Path(target).exists() else Path(target)
    try:
        report = run(path, args.out, workers=args.workers, scheduler=args.scheduler,
                     storage=args.storage, progress=not (args.quiet or args.json))  # fmt: skip
    except KeyboardInterrupt:
        print(f"\nredres sweep: interrupted; the finished shards are stored in {args.out}: run "
              "the same command again to resume", file=sys.stderr)  # fmt: skip
        return 130
    result = report.as_dict()
    if args.reuleaux:
        from ..sweeps.kinds.reuleaux import export_reuleaux

        result["reuleaux"] = str(export_reuleaux(args.out, args.reuleaux))
    if args.rows:
        from ..sweeps.kinds.ikdata import export_rows

        result["rows"] = str(export_rows(args.out, args.rows))
    if args.html:
        from ..report.sweep_page import write_html

        result["html"] = str(write_html(args.out, args.html))
    if args.json:
        print(json.dumps(result))
    else:
        shards = ", ".join(map(str, report.redone[:8])) + (
            ", ..." if len(report.redone) > 8 else ""
        )
        redone = f", {len(report.redone)} redone (damaged: shard {shards})" if report.redone else ""
        if report.tables_rewritten:
            redone += ", the plan's tables written again (damaged)"
        print(f"{report.kind} sweep in {args.out}: {report.computed} shards computed, "
              f"{report.skipped} already done{redone}, {report.queries:,} queries in "
              f"{report.seconds:.1f} s ({report.queries_per_second:,.0f}/s, {report.engine}, "
              f"{report.workers} workers)")  # fmt: skip
        if report.kind == "path_plans" and not args.quiet:
            from ..sweeps.kinds.plans import table

            print(table(args.out))
        if args.reuleaux:
            print(f"Reuleaux map: {result['reuleaux']}")
        if args.rows:
            print(f"training rows: {result['rows']}")
        if args.html:
            print(f"page: {result['html']}")
    return 0
