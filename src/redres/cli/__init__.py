"""The ``redres`` command: ``redres robots``, ``demo``, ``run``, ``plan``, ``warmup``, ``bench``,
``sweep``.

Exit codes: 0 success, 2 bad usage, bad input or a file that cannot be read or written
(one line on stderr: ``redres: error: ...`` naming the value or path and the fix).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from .._version import __version__
from ..errors import InvalidParameterError, RedresError, describe_os_error, install_hint

if TYPE_CHECKING:
    from .demo import Output


def robots_table() -> tuple[str, list[dict[str, object]]]:
    """Text table and records describing every built-in robot."""
    from .. import models
    from ..scenarios.runner import aligned_table

    records: list[dict[str, object]] = []
    rows = []
    for name in models.names():
        robot = models.load(name)
        span = np.degrees(robot.q_max - robot.q_min)
        records.append(
            {
                "name": name,
                "dof": robot.n,
                "tip": robot.tip,
                "q_min": robot.q_min.tolist(),
                "q_max": robot.q_max.tolist(),
                "qd_max": [float(x) for x in robot.qd_max],
                "tau_max": [float(x) for x in robot.tau_max],
                "frames": robot.frames(),
            }
        )
        qd = robot.qd_max
        rows.append(
            [
                name,
                str(robot.n),
                robot.tip,
                f"{span.min():.0f}-{span.max():.0f}",
                "-" if np.isinf(qd).all() else f"{qd.min():.2f}-{qd.max():.2f}",
                ", ".join(
                    f for f in robot.frames(include_joint_frames=False) if not f.startswith("link")
                ),
            ]
        )
    headers = ["robot", "dof", "tip", "range deg", "qd_max rad/s", "named frames"]
    return aligned_table(headers, rows), records


def example_robots() -> list[str]:
    """Names of the example-robot-data URDFs (``[]`` without the ``robots`` extra)."""
    from ..errors import MissingDependencyError
    from ..models import example_robot_names

    try:
        return example_robot_names()
    except MissingDependencyError:
        return []


def _cmd_robots(args: argparse.Namespace) -> int:
    text, records = robots_table()
    examples = example_robots()
    if args.json:
        print(json.dumps({"builtin": records, "example_robots": examples} if args.all
                         else records))  # fmt: skip
        return 0
    print(text)
    if examples:
        print(f"\nexample-robot-data ({len(examples)}; rr.models.example_robot(name, tip=...)):")
        print("  " + ", ".join(examples))
    else:
        print(f"\nexample-robot-data URDFs: install the robots extra: {install_hint('robots')}")
    return 0


def _cmd_demo(args: argparse.Namespace) -> int:
    from .demo import run_demo

    return run_demo(_output(args))


def _cmd_run(args: argparse.Namespace) -> int:
    from ..scenarios.spec import builtin_scenarios, load_scenario
    from .demo import run_scenarios

    builtin = builtin_scenarios()
    if args.list:
        listing = {name: _description(path) for name, path in sorted(builtin.items())}
        if args.json:
            print(json.dumps([{"name": k, "description": v} for k, v in listing.items()]))
            return 0
        for name, description in listing.items():
            print(f"{name:28s} {description}")
        return 0
    if not args.scenario:
        print("redres run: error: give a scenario file (or --list)", file=sys.stderr)
        return 2
    spec = load_scenario(_scenario_path(args.scenario, builtin))
    franka = _franka_target(args, spec.robot.name)
    if franka is not None:
        return run_scenarios([spec], _output(args), title=spec.name, franka=franka)
    if not args.view:
        return run_scenarios([spec], _output(args), title=spec.name)
    from ..viewer import Viewer, serve_runs

    viewer = Viewer(
        spec.robot, obstacles=spec.obstacles, collisions=_collisions_of(spec), port=args.port
    )  # live while it runs; the pairs of its collision constraint
    print(f"redres: {spec.name}: playing the runs at {viewer.url}", file=sys.stderr, flush=True)

    def after(runs: list) -> None:  # type: ignore[type-arg]
        serve_runs(spec, [log for _, log in runs], viewer=viewer, seconds=args.seconds)

    try:
        return run_scenarios([spec], _output(args), title=spec.name, after=after, viewer=viewer)
    finally:
        viewer.close()


def _collisions_of(spec: Any) -> Any:
    """The collision constraint of the first scheme of ``spec`` that has one (the pairs a
    live view draws), or None; a scheme that cannot be built here (a missing extra) has
    none to show."""
    for scheme in spec.schemes:
        if scheme.kind == "qp":
            try:
                found = getattr(scheme.build(), "collisions", None)
            except RedresError:
                continue
            if found is not None:
                return found
    return None


def _description(path: Path) -> str:
    """A built-in scenario's description; one this machine cannot run says why (a MuJoCo
    scenario without the extra) instead of failing the whole list."""
    from ..scenarios.spec import load_scenario

    try:
        return load_scenario(path).description
    except RedresError as exc:
        return f"(cannot run here: {str(exc).split(': ', 1)[-1]})"


def _franka_target(args: argparse.Namespace, robot: str) -> Any:
    """Where ``--robot`` / ``--dry-run`` send the scenario (None: simulate it as usual)."""
    if args.robot is None and not args.dry_run:
        return None
    from ..scenarios.runner import FrankaTarget

    address = None
    if args.robot is not None:
        scheme, _, host = args.robot.partition("://")
        if scheme != "franka" or not host:
            raise InvalidParameterError(f"--robot takes franka://HOST; got {args.robot!r}")
        address = None if args.dry_run else host
    arm = args.arm or ("panda" if robot.startswith("panda") else "fr3")
    return FrankaTarget(address, arm, args.mode, args.hand)


def _scenario_path(target: str, builtin: dict[str, Path]) -> Path:
    """A scenario file, or the built-in scenario of that name when no such file exists."""
    return builtin[target] if target in builtin and not Path(target).exists() else Path(target)


def _cmd_view(args: argparse.Namespace) -> int:
    from ..scenarios.spec import builtin_scenarios, load_scenario
    from ..viewer import serve_scenario

    spec = load_scenario(_scenario_path(args.scenario, builtin_scenarios()))
    return serve_scenario(spec, port=args.port, seconds=args.seconds)


def _cmd_plan(args: argparse.Namespace) -> int:
    from dataclasses import replace

    from ..scenarios.spec import PlanSettings, builtin_scenarios, load_scenario
    from .demo import run_scenarios

    spec = load_scenario(_scenario_path(args.scenario, builtin_scenarios()))
    if args.duration is not None:
        spec.duration = min(spec.duration, args.duration)
    settings = spec.plan or PlanSettings()
    objective = args.objective or settings.objective
    if objective == "obstacle_clearance" and not spec.obstacles:
        raise InvalidParameterError(
            f"scenario {spec.name!r} has no obstacles: 'obstacle_clearance' needs [[obstacles]]"
        )
    spec.plan = replace(
        settings, objective=objective, resolution=args.resolution or settings.resolution,
        qdd_max=settings.qdd_max if args.qdd_max is None else args.qdd_max,
    )  # fmt: skip
    return run_scenarios([spec], _output(args), title=f"{spec.name}: against the global optimum")


def _cmd_warmup(args: argparse.Namespace) -> int:
    from .._compile import cache_dir
    from .._warmup import groups, warmup

    if args.list:
        for name, group in groups().items():
            state = "cached" if group.cached() else "not cached"
            modules = ", ".join(m.removeprefix("redres.") for m in group.modules)
            print(f"{name:12s} {state:10s} {modules}")
        return 0
    seconds = warmup(args.groups or None, quiet=args.quiet, jobs=args.jobs)
    if not args.quiet:
        print(f"redres: warm-up done in {seconds:.1f} s; cached in {cache_dir()}",
              file=sys.stderr)  # fmt: skip
    return 0


def _cmd_bench(args: argparse.Namespace) -> int:
    import runpy

    script = Path(__file__).resolve().parents[2] / "benchmarks" / "step.py"
    if not script.is_file():
        print(
            "redres bench: error: benchmarks/step.py is part of the source checkout; "
            "run it from a clone of the repository",
            file=sys.stderr,
        )
        return 2
    runpy.run_path(str(script), run_name="__main__")
    return 0


def _output(args: argparse.Namespace) -> Output:
    """The :class:`~redres.cli.demo.Output` of the options :func:`_output_options` adds."""
    from .demo import Output

    return Output(Path(args.out), args.json, args.quiet, args.force, args.quick)


def _output_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--out", default="redres-report", help="report folder")
    parser.add_argument(
        "--force", action="store_true",
        help="write the report into a folder that holds other files (they are kept)",
    )  # fmt: skip
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--quiet", action="store_true", help="print only the results")
    parser.add_argument(
        "--quick", action="store_true", help="run 5%% of each scenario's duration (smoke test)"
    )


def _port(text: str) -> int:
    """A ``--port``: an integer from 0 to 65535 (refused before any run starts)."""
    try:
        port = int(text)
    except ValueError:
        port = -1
    if not 0 <= port <= 65535:
        raise argparse.ArgumentTypeError(f"must be an integer from 0 to 65535; got {text!r}")
    return port


def _viewer_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--port", type=_port, default=8080, help="port of the viewer's page")
    parser.add_argument("--seconds", type=float, default=None, help="stop the viewer after this")


def _command(
    sub: argparse._SubParsersAction[argparse.ArgumentParser],
    name: str,
    func: Callable[[argparse.Namespace], int],
    help: str,
) -> argparse.ArgumentParser:
    """The subcommand ``name``, run by ``func(args)``."""
    parser = sub.add_parser(name, help=help)
    parser.set_defaults(func=func)
    return parser


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="redres", description="Redundancy resolution for robot manipulators."
    )
    parser.add_argument("--version", action="version", version=f"redres {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)
    robots = _command(sub, "robots", _cmd_robots, "list the built-in robot models")
    robots.add_argument("--json", action="store_true", help="print JSON instead of a table")
    robots.add_argument(
        "--all", action="store_true",
        help="with --json: an object with the built-in and the example-robot-data robots",
    )  # fmt: skip
    _output_options(
        _command(sub, "demo", _cmd_demo, "compare every scheme on the built-in scenarios")
    )
    run = _command(sub, "run", _cmd_run, "run a scenario file (TOML)")
    run.add_argument("scenario", nargs="?", help="scenario file or built-in scenario name")
    run.add_argument("--list", action="store_true", help="list the built-in scenarios")
    run.add_argument("--view", action="store_true", help="then show the runs in the browser")
    run.add_argument(
        "--robot", metavar="franka://HOST", help="run on the Franka arm at HOST (docs/franka.md)"
    )
    run.add_argument(
        "--dry-run",
        action="store_true",
        help="with --robot: the same 1 kHz loop on the model, no robot",
    )
    run.add_argument(
        "--arm",
        choices=("fr3", "panda"),
        default=None,
        help="the Franka arm (default: the scenario's robot if a Panda, else fr3)",
    )
    run.add_argument("--hand", action="store_true", help="the Franka Hand is on the arm")
    run.add_argument("--mode", choices=("velocity", "position"), default="velocity",
                     help="the Franka command of the rate-control schemes")  # fmt: skip
    _viewer_options(run)
    _output_options(run)
    view = _command(
        sub, "view", _cmd_view, "run a scenario and show its runs in the browser (viser)"
    )
    view.add_argument("scenario", help="scenario file or built-in scenario name")
    _viewer_options(view)
    plan = _command(sub, "plan", _cmd_plan,
                    "the global optimum of a scenario's path against its schemes")  # fmt: skip
    plan.add_argument("scenario", help="scenario file or built-in scenario name")
    plan.add_argument(
        "--objective",
        default=None,
        choices=("joint_limit_margin", "obstacle_clearance", "path_length"),
        help="what to compare (default: the scenario's [plan] objective, else the margin)",
    )
    plan.add_argument("--resolution", type=int, default=None,
                      help="parameter values per sample (default: [plan], else 360)")  # fmt: skip
    plan.add_argument("--duration", type=float, default=None, help="s of the path (default all)")
    plan.add_argument("--qdd-max", type=float, default=None,
                      help="the plan's acceleration limit, rad/s² (default: none)")  # fmt: skip
    _output_options(plan)
    warm = _command(
        sub, "warmup", _cmd_warmup, "compile the kernels now (a first call is then fast)"
    )
    warm.add_argument("groups", nargs="*", help="what to compile (default all; see --list)")
    warm.add_argument("--list", action="store_true", help="list the groups and what is cached")
    warm.add_argument("--quiet", action="store_true", help="print nothing")
    warm.add_argument("--jobs", type=int, default=2, help="processes to compile in (default 2)")
    _command(sub, "bench", _cmd_bench, "run the control-step benchmark against peers")
    from .sweep import register as register_sweep

    register_sweep(sub)
    return parser


__all__ = ["main"]


def main(argv: Sequence[str] | None = None) -> int:
    """Entry point of the ``redres`` command."""
    args = build_parser().parse_args(argv)
    try:
        return int(args.func(args))
    except RedresError as exc:
        print(f"redres: error: {exc}", file=sys.stderr)
        return 2
    except BrokenPipeError:  # e.g. `redres robots | head`
        sys.stderr.close()
        return 0
    except OSError as exc:  # a report folder or file that cannot be written or read
        print(f"redres: error: {describe_os_error(exc)}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    raise SystemExit(main())
