"""Lines of ``src/`` by kind: code, docstrings, comments, blank (for the redesign's
"the net change removes code"; ``wc -l`` counts all four).

Run from the repository root: ``python benchmarks/source_lines.py [DIR]`` (default
``src``); for another commit, ``git archive <commit> src | tar -x -C /tmp/x`` first.
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path


def count(root: Path) -> dict[str, int]:
    totals = {"files": 0, "lines": 0, "docstrings": 0, "comments": 0, "blank": 0}
    for path in sorted(root.rglob("*.py")):
        text = path.read_text(encoding="utf-8")
        lines = text.splitlines()
        docs = 0
        for node in ast.walk(ast.parse(text)):
            body = getattr(node, "body", None)
            if not isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef,
                                     ast.AsyncFunctionDef)) or not body:  # fmt: skip
                continue
            first = body[0]
            if isinstance(first, ast.Expr) and isinstance(first.value, ast.Constant):
                if isinstance(first.value.value, str) and first.end_lineno is not None:
                    docs += first.end_lineno - first.lineno + 1
        totals["files"] += 1
        totals["lines"] += len(lines)
        totals["docstrings"] += docs
        totals["comments"] += sum(1 for line in lines if line.strip().startswith("#"))
        totals["blank"] += sum(1 for line in lines if not line.strip())
    totals["code"] = totals["lines"] - totals["docstrings"] - totals["comments"] - totals["blank"]
    return totals


if __name__ == "__main__":
    found = count(Path(sys.argv[1] if len(sys.argv) > 1 else "src"))
    print("  ".join(f"{key} {value}" for key, value in found.items()))
