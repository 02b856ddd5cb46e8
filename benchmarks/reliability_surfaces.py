"""Generated bad inputs on the surfaces added since the first reliability campaign:
batches, IK options, ``Robot.with_limits``, URDF strings, MJCF files, sweep specs and the
live viewer. Every input is classified:

* **clear error** — a ``RedresError`` (which is also the builtin error a user expects);
* **valid** — a valid input that gave a checked answer (batch FK against ``Robot.fk``,
  IK answers against forward kinematics and the limits, limits as asked);
* **wrong** — a valid input whose answer failed its check;
* **raw** — any other exception (a traceback a user would see);
* **silent accept** — an invalid input that returned without an error;
* **non-finite** — a finite-looking answer with NaN or infinity in it;
* **hang** — no answer within the time limit (an alarm; a compiled call cannot be
  interrupted, so the batch cases are sized to finish in milliseconds).

    PYTHONPATH=src python benchmarks/reliability_surfaces.py [--json FILE] [--seed N]

The inputs come from value generators crossed with every parameter of each surface
(deterministic for a seed). Markdown goes to standard output (``make bench``'s page).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
from collections import Counter
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
from reliability_files import mjcf_cases, plan_cases, sweep_spec_cases, urdf_cases
from reliability_inputs import (
    BAD_COUNTS,
    BAD_POSITIVE,
    BAD_SEEDS,
    NOT_NUMBERS,
    NOT_NUMBERS_OR_NONE,
    THREAD_COUNTS,
    Case,
    bad_arrays,
    classify,
    random_q,
)

import redres as rr


def batch_cases(rng: np.random.Generator) -> Iterator[Case]:
    panda = rr.models.panda()
    n = panda.n
    q = random_q(panda, rng, 6)
    T = rr.batch.fk(panda, q)

    def fk_ok(out: Any) -> bool:
        return bool(np.allclose(out, [panda.fk(x) for x in q], atol=1e-12))

    yield "batch", "fk valid", lambda: rr.batch.fk(panda, q), True, fk_ok
    for i in range(200):  # valid inputs of every size from one row up: checked answers
        rows = random_q(panda, rng, 1 + i % 17)

        def matches(out: Any, rows: np.ndarray = rows) -> bool:
            return bool(np.allclose(out, [panda.fk(x) for x in rows], atol=1e-12))

        def jac(out: Any, rows: np.ndarray = rows) -> bool:
            return bool(np.allclose(out, [panda.jacobian(x) for x in rows], atol=1e-12))

        yield (
            "batch",
            f"fk of {len(rows)} rows (valid)",
            lambda r=rows: rr.batch.fk(panda, r),
            True,
            matches,
        )
        yield (
            "batch",
            f"jacobian of {len(rows)} rows (valid)",
            lambda r=rows: rr.batch.jacobian(panda, r),
            True,
            jac,
        )
    for name, value in bad_arrays(n, n).items():
        yield "batch", f"fk q = {name}", lambda v=value: rr.batch.fk(panda, v), False, None
        yield (
            "batch",
            f"jacobian q = {name}",
            lambda v=value: rr.batch.jacobian(panda, v),
            False,
            None,
        )
        yield (
            "batch",
            f"rate_step q = {name}",
            lambda v=value: rr.batch.rate_step(panda, v, np.zeros((len(q), 6))),
            False,
            None,
        )
    for name, value in bad_arrays(n, 6).items():
        yield (
            "batch",
            f"rate_step xd = {name}",
            lambda v=value: rr.batch.rate_step(panda, q, v),
            False,
            None,
        )
    for name, value in THREAD_COUNTS.items():
        yield (
            "batch",
            f"fk threads = {name}",
            lambda v=value: rr.batch.fk(panda, q, threads=v),
            False,
            None,
        )
    for name, value in {**NOT_NUMBERS, "no robot": None, "a string robot": "panda"}.items():
        yield "batch", f"fk robot = {name}", lambda v=value: rr.batch.fk(v, q), False, None
    for name, value in {**NOT_NUMBERS, "True": True, "array": np.ones(3)}.items():  # any real
        yield (
            "batch",
            f"rate_step k_null = {name}",
            lambda v=value: rr.batch.rate_step(panda, q, np.zeros((6, 6)), k_null=v),
            False,
            None,
        )

    def ik_ok(out: Any) -> bool:
        reached = rr.batch.fk(panda, out.q[out.converged])
        inside = all(panda.within_limits(x) for x in out.q[out.converged])
        close = np.abs(reached[:, :3, 3] - T[out.converged, :3, 3]).max(initial=0.0) <= 1e-6
        return bool(inside and close and out.converged.mean() > 0.5)

    yield "batch ik", "ik valid", lambda: rr.batch.ik(panda, T, seed=1), True, ik_ok
    options = {
        "max_iterations": BAD_COUNTS,
        "max_restarts": {**BAD_COUNTS, "-1": -1},
        "patience": BAD_COUNTS,
        "solutions": {**BAD_COUNTS, "10**6": 10**6},
        "threads": THREAD_COUNTS,
        "tol_position": BAD_POSITIVE,
        "tol_orientation": BAD_POSITIVE,
        "max_step": BAD_POSITIVE,
        "k_limits": {**NOT_NUMBERS, "-1": -1.0},
        "damping": {**NOT_NUMBERS_OR_NONE, "float": 0.1},
        "seed": BAD_SEEDS,
    }
    for key, values in options.items():
        for name, value in values.items():
            if key == "max_restarts" and name == "0":
                continue  # 0 restarts is valid
            yield (
                "batch ik",
                f"ik {key} = {name}",
                lambda k=key, v=value: rr.batch.ik(panda, T[:2], **{k: v}),
                False,
                None,
            )
    for name, value in bad_arrays(n, 16).items():
        yield "batch ik", f"ik targets = {name}", lambda v=value: rr.batch.ik(panda, v), False, None
    for name, value in bad_arrays(n, n).items():
        if value is None:
            continue  # the default
        yield (
            "batch ik",
            f"ik q0 = {name}",
            lambda v=value: rr.batch.ik(panda, T[:2], q0=v),
            False,
            None,
        )
    for name, value in {
        **NOT_NUMBERS_OR_NONE,
        "wrong length": np.zeros(5, np.int64),
        "negative": -np.ones(6, np.int64),
        "2**62": np.full(6, 2**62),
    }.items():
        yield (
            "batch ik",
            f"ik keys = {name}",
            lambda v=value: rr.batch.ik(panda, T, keys=v),
            False,
            None,
        )


def ik_cases(rng: np.random.Generator) -> Iterator[Case]:
    panda = rr.models.panda()
    T = panda.fk(panda.random_configuration(rng))

    def ok(out: Any) -> bool:
        return bool(
            out.converged
            and panda.within_limits(out.q)
            and np.abs(panda.fk(out.q) - T).max() < 1e-5
        )

    yield "rr.ik options", "valid", lambda: rr.ik(panda, T, seed=0), True, ok
    for i in range(150):  # random reachable targets with random valid options
        target = panda.fk(panda.random_configuration(rng))
        options = {
            "seed": int(rng.integers(0, 2**40)),
            "tol_position": 10 ** rng.uniform(-9, -5),
            "max_step": rng.uniform(0.1, 1.0),
            "timeout_s": None,
        }

        def reached(
            out: Any, target: np.ndarray = target, tol: float = options["tol_position"]
        ) -> bool:
            p = panda.fk(out.q)[:3, 3]
            return bool(
                out.converged
                and panda.within_limits(out.q)
                and np.linalg.norm(p - target[:3, 3]) <= tol * 1.0001
            )

        yield (
            "rr.ik options",
            f"random target {i} (valid)",
            lambda t=target, o=options: rr.ik(panda, t, **o),
            True,
            reached,
        )
    options = {
        "max_iterations": BAD_COUNTS,
        "max_restarts": BAD_COUNTS,
        "patience": BAD_COUNTS,
        "tol_position": BAD_POSITIVE,
        "tol_orientation": BAD_POSITIVE,
        "max_step": BAD_POSITIVE,
        "timeout_s": BAD_POSITIVE,
        "preference_tol": BAD_POSITIVE,
        "seed": BAD_SEEDS,
        "q0": bad_arrays(7, 7),
        "q_preferred": bad_arrays(7, 7),
        "arm_angle": NOT_NUMBERS_OR_NONE,
        "frame": {**NOT_NUMBERS_OR_NONE, "unknown": "nope", "int": 5},
    }
    for key, values in options.items():
        for name, value in values.items():
            if key == "max_restarts" and name == "0":
                continue
            if value is None or (key == "timeout_s" and name == "inf"):
                continue  # the default: valid (no time budget for timeout_s=inf too)
            yield (
                "rr.ik options",
                f"{key} = {name}",
                lambda k=key, v=value: rr.ik(panda, T, **{k: v}),
                False,
                None,
            )


def limit_cases() -> Iterator[Case]:
    panda = rr.models.panda()

    def halved(out: Any) -> bool:
        return bool(np.allclose(out.qd_max, panda.qd_max / 2))

    yield (
        "with_limits",
        "qd_max halved",
        lambda: panda.with_limits(qd_max=panda.qd_max / 2),
        True,
        halved,
    )
    rng = np.random.default_rng(7)
    for i in range(100):  # random valid fractions of each limit
        key = ("qd_max", "qdd_max", "qddd_max", "tau_max")[i % 4]
        value = getattr(panda, key) * rng.uniform(0.05, 1.0, panda.n)

        def applied(out: Any, key: str = key, value: np.ndarray = value) -> bool:
            return bool(np.array_equal(getattr(out, key), value))

        yield (
            "with_limits",
            f"{key} random fraction {i} (valid)",
            lambda k=key, v=value: panda.with_limits(**{k: v}),
            True,
            applied,
        )
    values = {
        **NOT_NUMBERS_OR_NONE,
        "0": 0.0,
        "-1": -1.0,
        "True": True,
        "wrong length": np.ones(3),
        "one negative": np.r_[np.ones(6), -1.0],
        "one nan": np.r_[np.ones(6), np.nan],
        "2-D": np.ones((7, 1)),
    }
    for key in ("qd_max", "qdd_max", "qddd_max", "tau_max"):
        above = 2.0 * getattr(panda, key)  # this tightens limits, it cannot raise them
        for name, value in {**values, "twice the robot's": above}.items():
            if name == "inf" or (name == "twice the robot's" and np.isinf(value).all()):
                continue  # inf: "unknown", valid; above an infinite limit: there is none
            yield (
                "with_limits",
                f"{key} = {name}",
                lambda k=key, v=value: panda.with_limits(**{k: v}),
                False,
                None,
            )
    for name in ("qd_mx", "velocity", "limits"):
        yield (
            "with_limits",
            f"keyword {name}",
            lambda k=name: panda.with_limits(**{k: 1.0}),
            False,
            None,
        )


def viewer_cases() -> Iterator[Case]:
    try:
        from redres.viewer import Viewer
    except ImportError:  # pragma: no cover
        return
    panda = rr.models.panda()
    for name, value in {**NOT_NUMBERS, "70000": 70000, "-1": -1, "True": True}.items():
        yield "viewer", f"port = {name}", lambda v=value: Viewer(panda, port=v).close(), False, None
    for name, value in {**BAD_POSITIVE, "1e-300": 1e-300, "1e9": 1e9}.items():
        yield (
            "viewer",
            f"rate = {name}",
            lambda v=value: Viewer(panda, rate=v, port=0).close(),
            False,
            None,
        )
    for name, value in {"no such host": "no.such.host.invalid", "int": 5, "empty": ""}.items():
        yield (
            "viewer",
            f"host = {name}",
            lambda v=value: Viewer(panda, host=v, port=0).close(),
            False,
            None,
        )


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", type=Path, help="also write every case here")
    parser.add_argument("--seed", type=int, default=41)
    parser.add_argument("--quick", action="store_true", help="every tenth case")
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    rows: list[tuple[str, str, str]] = []
    with tempfile.TemporaryDirectory() as folder:
        tmp = Path(folder)
        groups = (
            batch_cases(rng),
            ik_cases(rng),
            limit_cases(),
            urdf_cases(),
            mjcf_cases(tmp),
            sweep_spec_cases(tmp),
            plan_cases(tmp),
            viewer_cases(),
        )
        index = 0
        for group in groups:
            for surface, name, call, valid, check in group:
                index += 1
                if args.quick and index % 10:
                    continue
                rows.append((surface, name, classify(call, valid, check)))
    counts = Counter(result for _, _, result in rows)
    if args.json:
        args.json.write_text(json.dumps({"counts": counts, "cases": rows}, indent=1))
    load = os.getloadavg()[0]
    print(
        f"{len(rows):,} generated inputs on the new surfaces (seed {args.seed}; load average "
        f"{load:.2f}); `PYTHONPATH=src python benchmarks/reliability_surfaces.py`.\n"
    )
    kinds = ["valid", "clear error", "wrong", "raw", "silent accept", "non-finite", "hang"]
    print("| surface | inputs | " + " | ".join(kinds) + " |")
    print("|---|---:|" + "---:|" * len(kinds))
    for surface in dict.fromkeys(s for s, _, _ in rows):
        sub = Counter(_kind(r) for s, _, r in rows if s == surface)
        print(
            f"| {surface} | {sum(sub.values()):,} | "
            + " | ".join(f"{sub[k]:,}" for k in kinds)
            + " |"
        )
    total = Counter(_kind(r) for _, _, r in rows)
    print(
        f"| **all** | **{len(rows):,}** | " + " | ".join(f"**{total[k]:,}**" for k in kinds) + " |"
    )
    bad = [(s, n, r) for s, n, r in rows if _kind(r) not in ("valid", "clear error")]
    if bad:
        print("\nNot clear errors or valid answers:\n")
        for surface, name, result in bad[:60]:
            print(f"- {surface}: `{name}`: {result}")
    return 0


def _kind(result: str) -> str:
    return "raw" if result.startswith("raw") else "wrong" if result.startswith("wrong") else result


if __name__ == "__main__":
    sys.exit(main())
