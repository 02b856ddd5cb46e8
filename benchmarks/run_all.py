"""Run every benchmark and rewrite docs/benchmarks.md (the entry point of ``make bench``).

Each benchmark runs in its own process, one after the other, so that none inherits
another's imports, threads or caches; their progress bars go to the terminal, their
Markdown to the page. The page is assembled from their output only — every figure on it
comes from this run — and written atomically (temporary file, then rename). If a
benchmark fails, the page is left as it was and the exit status is 1; a peer library
that is not installed is skipped with a note, never a failure.

Run from the repository root::

    python benchmarks/run_all.py            # full run, rewrites docs/benchmarks.md
    python benchmarks/run_all.py --quick    # smoke run with small counts, to build/
"""

from __future__ import annotations

import argparse
import datetime as dt
import importlib.metadata
import json
import os
import platform
import re
import subprocess
import sys
import tempfile
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

import numpy as np
from tqdm import tqdm

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
ROOT = HERE.parent
PAGE = ROOT / "docs" / "benchmarks.md"
COMMAND = "make bench  # = .venv/bin/python benchmarks/run_all.py"
PACKAGES = ("redres", "numpy", "scipy", "pin", "numba", "qpsolvers", "daqp", "pin-pink",
            "mink", "mujoco", "roboticstoolbox-python", "ikpy", "pytracik", "torch",
            "pytorch-kinematics")  # fmt: skip


@dataclass
class Bench:
    """One benchmark script and how its output goes on the page."""

    key: str
    script: str
    title: str
    intro: str
    args: list[str] = field(default_factory=list)
    quick: list[str] = field(default_factory=list)
    markdown: bool = True  # stdout is Markdown (else shown as a code block)
    json: bool = False  # the script takes --json PATH
    output: str = ""
    notes: list[str] = field(default_factory=list)
    seconds: float = 0.0


BENCHES = [
    Bench("differential", "differential.py", "Differential step: Panda and iiwa 14",
          "One whole control step (kinematics, pose error, joint velocity, integration) per "
          "call, same arm, configuration and target for every library; each operation's "
          "contenders interleaved (60 rounds of 100-call blocks, shuffled). Ratio = redres "
          "median ÷ peer median (< 1: redres is faster), with the faster of redres' two loop "
          "steps: `Controller.step` (compiled paths) and `Scheme.step` composed by hand. "
          "Each library's call: `benchmarks/differential.py`. PlaCo pins its own Pinocchio "
          "(pin 3.8): its rows come from its own interpreter (`PLACO_PYTHON`), timed the "
          "same way but not interleaved, and its frame task takes the whole error per step "
          "(no gain).",
          quick=["--rounds", "2", "--calls", "50"], json=True),
    Bench("step", "step.py", "One CLIK step with a joint-limit null space (Panda)",
          "`benchmarks/step.py`: one closed-loop inverse-kinematics step (pose error, damped "
          "inverse, Liégeois' joint-limit gradient in its null space, integration) through "
          "the public API next to pink, mink, KDL and PlaCo (ratio here = peer ÷ redres, "
          "> 1: redres is faster). PlaCo's row comes from its own interpreter "
          "(`PLACO_PYTHON`: it pins pin 3.8), timed in the same blocks, not interleaved."),
    Bench("shaping", "shaping.py", "Command shaping to the Panda's limits",
          "`benchmarks/shaping.py`: redres' `CommandShaper` next to Ruckig on one stream of "
          "random wanted velocities (time per cycle, commands a robot would refuse), then "
          "the random Panda runs of the shaping test with and without shaping: refused "
          "runs and the tracking error shaping costs.", quick=["--quick"]),
    Bench("mujoco_plant", "mujoco_plant.py", "The same circle on MuJoCo's Panda: redres and mink",
          "`benchmarks/mujoco_plant.py`: the Menagerie Panda simulated by MuJoCo follows a "
          "5 cm circle through its position servos, commanded by redres' `Controller` and by "
          "mink's `solve_ik` on the same plant (and with mink's own habit, `ctrl = q` on the "
          "bare servos): time per control step and the tracking error MuJoCo measures."),
    Bench("collision_mink", "collision_mink.py",
          "Collision avoidance as a hard constraint: redres and mink",
          "`benchmarks/collision_mink.py`: redres' `QPScheme` with `Collisions` (the velocity "
          "damper of Faverjon & Tournassoud 1987, Kanoun et al. 2011) next to mink's "
          "`solve_ik` with `CollisionAvoidanceLimit` (DAQP) on the same Panda, capsules, "
          "obstacles and pairs, the damper's parameters mapped onto mink's: the time of one "
          "control step with about 20 pairs within the influence distance, then both closed "
          "loops on the same random scenes driving into obstacles, every pair's distance "
          "measured at every step.", quick=["--scenes", "3", "--steps", "100"]),
    Bench("scaling", "scaling.py", "Scaling with the number of joints",
          "Planar chains of 3 to 50 joints (3 task rows) and a 14-joint chain (two S-R-S "
          "arms in series, 6 rows). The algebra predicts, for m fixed task rows: O(n) for "
          "the kinematics and O(m²n + m³) for the damped inverse — linear in n, plus a "
          "constant for the Python and Pinocchio call overhead; the least-squares line "
          "below is that prediction fitted to the measurements."),
    Bench("ik_compare", "ik_compare.py", "Position inverse kinematics",
          "Same 10,000 random reachable pose targets per arm, same starting configurations "
          "(neutral, then the same seeded random restarts), same tolerance checked by us "
          "with Pinocchio forward kinematics (robot.fk), same time limit; solutions outside "
          "the joint limits are failures. Times per target, all attempts and failures included.",
          args=["--targets", "10000"], quick=["--targets", "20"], json=True),
    Bench("quality", "quality.py", "Quality on a joint-limit problem: the Panda joint-limit circle",
          "Each library's best equivalent configuration tracks the circle that drives plain "
          "pseudo-inverse control past joint 2's limit; errors and margins computed here "
          "from each run's configurations with Pinocchio forward kinematics. PlaCo runs in "
          "its own interpreter (`PLACO_PYTHON`) and times its steps there.", json=True),
    Bench("ik", "ik.py", "redres IK alone: pose and position-only targets",
          "`benchmarks/ik.py`: redres' `ik` with its default options (its own restarts).",
          quick=["--targets", "50"], markdown=False),
    Bench("linalg", "linalg.py", "Inner kernels: one damped rate step on a 6 x 7 Jacobian",
          "`benchmarks/linalg.py` (redres against NumPy).", quick=["--rounds", "3"],
          markdown=False),
    Bench("dense_qp", "dense_qp.py", "The hard-limit step's QPs: compiled solvers, DAQP, ProxQP",
          "`benchmarks/dense_qp.py`: the exact and least-violating QPs `QPScheme` solves on "
          "step.py's saturating Panda loop, and random ones (n = 7, m = 6), by redres' "
          "compiled solvers (from a compiled loop and from Python), DAQP and ProxQP from "
          "Python; µs per solve, medians."),
    Bench("first_use", "first_use.py", "First use: cold and warm start",
          "`benchmarks/first_use.py`: seconds from the first import to the first answer in a "
          "fresh process, with an empty compiled-code cache (cold) and with the cache the cold "
          "run filled (warm), for redres' entry points and the peers' first solves.",
          json=True),
    Bench("batch", "batch.py", "Batches: Jacobian + damped step per item (Panda)",
          "`benchmarks/batch.py`: `rr.batch.rate_step` on one thread and on all cores "
          "against a NumPy-vectorised batch (Pinocchio loop + batched solve) and a Python "
          "loop of single calls, as items per second; then the first batch call of a fresh "
          "process with an empty and a warm cache.", quick=["--quick"]),
    Bench("batch_ik", "batch_ik.py", "Batch position IK (Panda, iiwa14)",
          "`benchmarks/batch_ik.py`: `rr.batch.ik` on one thread and on all cores against "
          "pytorch_kinematics' CPU batch IK (`pip install pytorch-kinematics`, a 4 GB "
          "install with torch: not in the bench extra), pose targets per second, every "
          "solution checked with Pinocchio's forward kinematics.", quick=["--quick"]),
    Bench("analytic_ik", "analytic_ik.py", "Every IK solution at a given q7 (Panda, iiwa14)",
          "`benchmarks/analytic_ik.py`: `rr.ik_all(robot, T, q7=...)` (the closed form of "
          "`redres.ik.analytic`) next to GeoFIK (geofikpy) and frankik (He & Liu 2021) on the "
          "same 1,000 random in-limit Panda poses at their own q7: time per call and per "
          "solution, solutions found, how often the original configuration is among them, "
          "the worst forward-kinematics error (Pinocchio), solutions holding NaN.",
          quick=["--poses", "50", "--rounds", "1"], markdown=False),
    Bench("plan", "plan.py", "Global planning by dynamic programming: time against grid size",
          "`benchmarks/plan.py`: `rr.plan_path` on the Panda joint-limit circle (q7, from the "
          "scenario's q0) and the iiwa14 figure eight (arm angle), K samples x P parameter "
          "values x 8 branches, max-min joint-limit margin: the grid (closed-form IK), the "
          "DP and the whole call on one thread, the grid and the whole call on all cores; "
          "pairs tested after the pruning against every feasible pair; then with "
          "acceleration limits (qdd_max), the DP over transitions.",
          quick=["--quick", "--rounds", "1"]),
    Bench("dynamics", "dynamics.py", "Operational-space control step (Panda)",
          "`benchmarks/dynamics.py`: the compiled operational-space step next to the same "
          "step on Pinocchio, and the pieces of a step (redres alone).",
          quick=["--rounds", "3"], markdown=False),
    Bench("reliability", "reliability_surfaces.py",
          "Reliability: generated bad inputs on the new surfaces",
          "`benchmarks/reliability_surfaces.py`: value generators (not numbers, NaN, inf, "
          "10**400, ragged, complex, bool, text, counts of 0 and 2**63, broadcasts of 10**9 "
          "rows, wrong shapes) crossed with every parameter of batches, rr.ik, with_limits, "
          "the viewer; every numeric attribute of the URDF fixture, the Panda URDF, the MJCF "
          "fixture and Menagerie's four arms replaced by bad tokens; every key of the "
          "built-in sweep specs replaced by bad values, and their sizes set to 10**7 and "
          "10**9 and planned in a child process; valid inputs checked (batch FK and "
          "Jacobians against the single calls, IK answers against FK and the limits).",
          quick=["--quick"]),
]  # fmt: skip


def _pump(stream: IO[bytes], sink: list[bytes], echo: bool) -> None:
    """Copy a child's stream into ``sink`` (and to our stderr: its progress bars)."""
    for chunk in iter(lambda: stream.read1(4096), b""):  # type: ignore[attr-defined]
        sink.append(chunk)
        if echo:
            sys.stderr.buffer.write(chunk)
            sys.stderr.flush()


def run(bench: Bench, quick: bool, workdir: Path, timeout: float) -> dict[str, Any] | None:
    """Run one benchmark; fill its output and notes; return its JSON figures if any."""
    cmd = [sys.executable, str(HERE / bench.script), *(bench.quick if quick else bench.args)]
    json_path = workdir / f"{bench.key}.json"
    if bench.json:
        cmd += ["--json", str(json_path)]
    t0 = time.perf_counter()
    # Kernels compile on the caller's path: a timed loop must not switch from the reference
    # path to compiled code midway (first_use.py sets its own policy per case).
    env = dict(os.environ, REDRES_COMPILE="foreground")
    proc = subprocess.Popen(cmd, cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    out: list[bytes] = []
    err: list[bytes] = []
    pumps = [threading.Thread(target=_pump, args=(proc.stdout, out, False)),
             threading.Thread(target=_pump, args=(proc.stderr, err, True))]  # fmt: skip
    for p in pumps:
        p.start()
    try:
        status = proc.wait(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.wait()
        raise RuntimeError(f"{bench.script} did not finish within {timeout:.0f} s") from None
    for p in pumps:
        p.join()
    bench.seconds = time.perf_counter() - t0
    stderr = b"".join(err).decode(errors="replace")
    if status != 0:
        raise RuntimeError(f"{bench.script} failed (exit {status}):\n{stderr[-3000:]}")
    bench.output = b"".join(out).decode().strip()
    bench.notes = sorted(set(re.findall(r"note: (.+)", stderr)))
    return json.loads(json_path.read_text()) if bench.json else None


def machine() -> list[str]:
    """Lines describing the machine and the software."""
    cpu = platform.processor() or platform.machine()
    memory = ""
    try:
        info = Path("/proc/cpuinfo").read_text()
        cpu = re.search(r"model name\s*:\s*(.+)", info).group(1)  # type: ignore[union-attr]
        kb = re.search(r"MemTotal:\s*(\d+)", Path("/proc/meminfo").read_text())
        memory = f", {int(kb.group(1)) / 2**20:.0f} GiB RAM" if kb else ""
    except (OSError, AttributeError):
        pass
    versions = []
    for name in PACKAGES:
        try:
            versions.append(f"{name} {importlib.metadata.version(name)}")
        except importlib.metadata.PackageNotFoundError:
            versions.append(f"{name} (not installed)")
    return [
        f"- Machine: {cpu}, {os.cpu_count()} cores{memory}; {platform.platform()}",
        f"- Python {platform.python_version()}; " + ", ".join(versions) + f"; {kdl_version()}",
        f"- redres source: {git_revision()}",
    ]


def kdl_version() -> str:
    try:
        out = subprocess.run(["dpkg-query", "-W", "-f", "${Version}", "python3-pykdl"],
                             capture_output=True, text=True, check=True).stdout  # fmt: skip
        return f"KDL (python3-pykdl) {out}"
    except (OSError, subprocess.CalledProcessError):
        return "KDL (python3-pykdl) not installed"


def git_revision() -> str:
    """The commit, and whether the working tree had changes (read-only git commands)."""
    try:
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, check=True,
                              capture_output=True, text=True).stdout.strip()  # fmt: skip
        dirty = subprocess.run(["git", "status", "--porcelain"], cwd=ROOT, check=True,
                               capture_output=True, text=True).stdout.strip()  # fmt: skip
    except (OSError, subprocess.CalledProcessError):
        return "not a git checkout"
    return f"commit {head}" + (" plus uncommitted changes" if dirty else "")


def load() -> str:
    return "/".join(f"{v:.2f}" for v in os.getloadavg())


def page(benches: list[Bench], figures: dict[str, Any], header: list[str], quick: bool) -> str:
    lines = ["# Benchmarks: redres next to the libraries users would pick instead", ""]
    lines += ["<!-- Generated by benchmarks/run_all.py (make bench): do not edit by hand. -->", ""]
    if quick:
        lines += ["**Quick smoke run (small counts): not representative.**", ""]
    lines += [*header, ""]
    lines += ["## Where redres is not ahead, and why", ""]
    lines += [*not_ahead(figures), ""]
    for bench in benches:
        lines += [f"## {bench.title}", "", bench.intro, ""]
        lines += [_spaced(bench.output)] if bench.markdown else ["```text", bench.output, "```"]
        lines += [""] + [f"> Note: {n}" for n in bench.notes] + ([""] if bench.notes else [])
        lines += [f"*{bench.script}: {bench.seconds:.0f} s.*", ""]
    lines += ["## What would close the gaps", "", *closing_note(figures), ""]
    return "\n".join(lines)


WHY = {
    "first_use": "*Why:* redres' kernels are compiled by numba and cached on disk. On a cold "
    "cache (a fresh install, an edited kernel) the first answers come from the reference path "
    "while a background process compiles; on a warm one the first call loads numba and the "
    "cached code (about 0.3 s), so warm is the slower of the two here. pink and mink call "
    "Pinocchio, MuJoCo and DAQP, which ship compiled.",
    "compiled": "*Why:* KDL runs the whole step (Jacobian, SVD, null-space term) in one C++ "
    "call; a redres step makes several calls from Python — Pinocchio for the kinematics, a "
    "compiled kernel for the inverse, the objective's gradient, input validation — each "
    "paying interpreter and binding overhead. The `linalg.rate_step on arrays` rows show "
    "how much of it is the `Scheme` layer.",
    "qp": "*Why:* redres' `QPScheme` builds position, velocity *and acceleration* bounds each "
    "step, solves the task as an equality-constrained QP and, when that is infeasible, a "
    "second least-violation QP, with Python between the pieces; pink and mink solve one QP "
    "without acceleration limits. PlaCo (C++ over Pinocchio, qpmad) builds and solves its "
    "QP in one call and has no acceleration limits: the compiled hard-limit step of issue "
    "40 is what would close that gap.",
    "ik": "*Why:* robotics-toolbox's `ik_LM` and KDL's `NR_JL` run their whole iteration "
    "loop in C++, one call per attempt; redres' `ik` runs its iterations in one compiled "
    "call per attempt too, but validates its arguments and reads the clock in Python "
    "between attempts (about 10 µs per call).",
    "circle": "*Why:* pink and mink track the pose one period ahead with gain 1 — a "
    "dead-beat loop, K = 1/dt — and their posture task pulls harder than the scenario's "
    "null-space gain 5, while the scenario runs CLIK at K = 50/s; KDL normalises its "
    "null-space step (ġ = −2αg), which at alpha 5 pulls harder toward mid-range than "
    "k = 5. Those are gains, not methods: the *tuned* redres row uses K = 1/dt and k = 50. "
    "What remains is the feed-forward: `rr.run` feeds the reference twist at t (first "
    "order), pink and mink the pose at t + dt, which includes the path's curvature "
    "(½·a·dt², a fraction of a micrometre on this circle).",
    "start": "*Why:* redres' QP and SNS schemes enforce the Panda's acceleration limits, and "
    "the circle starts at full speed from rest, so the first steps lag; pink and mink "
    "enforce no acceleration limits.",
}


def _differential(data: dict[str, Any]) -> dict[str, list[str]]:
    found: dict[str, list[str]] = {"compiled": [], "qp": []}
    for arm, ops in data.items():
        for op, libs in ops.items():
            base = min(libs[k]["median_us"] for k in ("redres-fused", "redres") if k in libs)
            for lib, t in libs.items():
                if not lib.startswith("redres") and t["median_us"] < base:
                    found["qp" if op == "qp" else "compiled"].append(
                        f"- {op} step, {arm}: **{lib}** {t['median_us']:.1f} µs, redres "
                        f"{base:.1f} µs (medians; redres ÷ peer {base / t['median_us']:.2f})."
                    )
    return found


def _ik(data: dict[str, Any]) -> dict[str, list[str]]:
    items, rows = [], data["rows"]
    for mine in (r for r in rows if r["library"] == "redres"):
        peers = (r for r in rows if r["arm"] == mine["arm"] and "redres" not in r["library"])
        for r in peers:
            better = [what for what, key, sign in (("success", "success_pct", 1),
                      ("median time", "median_ms", -1), ("mean time", "mean_ms", -1))
                      if sign * (r[key] - mine[key]) > 0]  # fmt: skip
            if better:
                items.append(
                    f"- IK, {r['arm']}: **{r['library']}** has the better {', '.join(better)}: "
                    f"{r['success_pct']:.1f} %, median {r['median_ms']:.2f} ms, mean "
                    f"{r['mean_ms']:.2f} ms; redres {mine['success_pct']:.1f} %, "
                    f"{mine['median_ms']:.2f} ms, {mine['mean_ms']:.2f} ms."
                )
    return {"ik": items}


def _first_use(data: dict[str, Any]) -> dict[str, list[str]]:
    readme, items = data.get("README example", {}), []
    for peer in ("pink first solve_ik", "mink first solve_ik", "robotics-toolbox first ik_LM"):
        theirs = data.get(peer, {})
        for kind in ("cold_s", "warm_s"):
            if None not in (readme.get(kind), theirs.get(kind)) and theirs[kind] < readme[kind]:
                items.append(
                    f"- First use ({kind[:-2]} cache): **{peer}** answers in "
                    f"{theirs[kind]:.2f} s, redres' README example in {readme[kind]:.2f} s."
                )
    return {"first_use": items}


def _quality(rows: list[dict[str, Any]]) -> dict[str, list[str]]:
    gp = next((r for r in rows if r["label"] == "redres gradient projection (joint limits)"), None)
    if gp is None:
        return {}
    found: dict[str, list[str]] = {"circle": [], "start": []}
    for r in rows:
        tracks = r["settled_mm"] < 0.9 * gp["settled_mm"]
        keeps = r["min_margin_rad"] > gp["min_margin_rad"] + 0.005
        if not r["label"].startswith("redres") and (tracks or keeps):
            found["circle"].append(
                f"- Circle: **{r['label']}** {r['settled_mm']:.4f} mm after the start, margin "
                f"{r['min_margin_rad']:.3f} rad; redres gradient projection (scenario gains) "
                f"{gp['settled_mm']:.4f} mm, {gp['min_margin_rad']:.3f} rad."
            )
        if r["label"].startswith("redres") and r["max_position_mm"] > 10 * r["settled_mm"] > 0:
            found["start"].append(
                f"- Circle: **{r['label']}** {r['max_position_mm']:.2f} mm at the start, "
                f"{r['settled_mm']:.4f} mm after 0.25 s."
            )
    tuned = next((r for r in rows if "tuned" in r["label"]), None)
    if found["circle"] and tuned is not None:
        found["circle"].append(
            f"- Circle, redres tuned (K = 1/dt, k = 50): {tuned['settled_mm']:.4f} mm, margin "
            f"{tuned['min_margin_rad']:.3f} rad."
        )
    return found


def step_kdl_broken() -> bool:
    """Whether step.py's KDL step returns q unchanged (its chain freed: KDL errors out)."""
    try:
        import step  # benchmarks/step.py, owned elsewhere: checked, never edited

        robot, q, target = step.problem()
        fn = step.kdl_step(robot, q, target)
        return fn is not None and bool(np.array_equal(np.asarray(fn()), q))
    except Exception:  # its API may change: then no claim is made
        return False


def not_ahead(figures: dict[str, Any]) -> list[str]:
    found: dict[str, list[str]] = {}
    for key, analyse in (("differential", _differential), ("ik_compare", _ik),
                         ("quality", _quality), ("first_use", _first_use)):  # fmt: skip
        if key in figures:
            found.update(analyse(figures[key]))
    lines = []
    for kind, items in found.items():
        if items:
            lines += [*items, "", WHY[kind], ""]
    if step_kdl_broken():
        lines += ["*Caveat on the step.py table:* its KDL row times solvers whose chain was "
                  "freed (KDL returns an error code and a zero velocity), so it does not "
                  "measure KDL; the KDL rows of the differential table do.", ""]  # fmt: skip
    return lines or ["Nowhere in this run: redres is ahead in every comparison below."]


def closing_note(figures: dict[str, Any]) -> list[str]:
    return [
        "- **Compiled inner loops.** Where a C++ library wins (KDL's velocity solvers, "
        "robotics-toolbox's `ik_LM`, KDL's `NR_JL`), the gap is call overhead, not "
        "arithmetic. A compiled serial-chain kernel (forward kinematics and the world-aligned "
        "Jacobian from the joint placements, in the same numba style as `redres.linalg`) "
        "would let a step, and a whole IK attempt, be one call from Python.",
        "- **QP step.** DAQP's update and solve are 4–5 µs of the controller's ~15 µs QP "
        "step; the rest is the box, the Gram factorisation and two kernel calls. Calling "
        "DAQP's C API from the kernel would remove the Python round trip, at the price of "
        "depending on its struct layout.",
        "- **Tracking quality** is mostly a choice of gains: with the dead-beat gain pink and "
        "mink use (the tuned row) redres keeps the same margin; a feed-forward of the next "
        "reference pose in `rr.run` (`trajectory.sample(t + dt)`, not the twist at t) would "
        "remove the sub-micrometre remainder.",
    ]


def _spaced(markdown: str) -> str:
    """A blank line before and after every table, so that text around it stays text."""
    out: list[str] = []
    for line in markdown.splitlines():
        is_row, was_row = line.startswith("|"), bool(out) and out[-1].startswith("|")
        if out and out[-1].strip() and line.strip() and is_row != was_row:
            out.append("")
        out.append(line)
    return "\n".join(out)


def write_atomically(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    with os.fdopen(fd, "w", encoding="utf-8") as f:
        f.write(text)
    os.replace(tmp, path)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="small counts (a smoke test)")
    parser.add_argument("--out", type=Path, help="page to write (default: docs/benchmarks.md, "
                        "or build/benchmarks-quick.md with --quick)")  # fmt: skip
    parser.add_argument(
        "--timeout",
        type=float,
        default=2400.0,
        help="per benchmark, s (first_use.py compiles every kernel group cold: about 20 min here)",
    )
    args = parser.parse_args()
    out = args.out or (ROOT / "build" / "benchmarks-quick.md" if args.quick else PAGE)
    started, load_start, t0 = dt.datetime.now(dt.timezone.utc), load(), time.perf_counter()
    loads = [os.getloadavg()[0]]
    figures: dict[str, Any] = {}
    with tempfile.TemporaryDirectory() as workdir:
        bar = tqdm(BENCHES, desc="make bench", unit="benchmark", position=0)
        for bench in bar:
            bar.set_postfix_str(bench.script)
            try:
                result = run(bench, args.quick, Path(workdir), args.timeout)
            except RuntimeError as exc:
                print(f"\n{exc}\n{out} left unchanged.", file=sys.stderr)
                return 1
            if result is not None:
                figures[bench.key] = result
            loads.append(os.getloadavg()[0])
    total = time.perf_counter() - t0
    header = [
        f"- Date: {started:%Y-%m-%d %H:%M} UTC; total run time {total / 60:.1f} min",
        f"- Command: `{COMMAND}`" + (" `--quick`" if args.quick else ""),
        *machine(),
        f"- Load average (1/5/15 min) {load_start} at the start, {load()} at the end; "
        f"1-min average between {min(loads):.2f} and {max(loads):.2f} during the run. "
        f"Above {os.cpu_count()} (the core count) the benchmarks shared the CPU with other "
        "work: absolute times are then pessimistic and p99s noisy, while the interleaved "
        "ratios stay comparable.",
    ]
    write_atomically(out, page(BENCHES, figures, header, args.quick))
    print(f"wrote {out} in {total / 60:.1f} min", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
