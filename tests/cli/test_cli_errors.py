"""The ``redres`` command never prints a traceback: every bad input and every file-system
failure is one line ``redres: error: ...`` naming the value or path and the fix, exit 2
(issue 18, item 4)."""

from __future__ import annotations

import errno
import re
import tempfile
from pathlib import Path

import pytest

from redres.cli import main
from redres.control.analysis import MAX_STEPS

GOOD = """
name = "tiny"

[robot]
model = "panda"

[trajectory]
type = "circle"
radius = 0.05
period = 1.0

[run]
dt = 0.002
duration = 0.02

[[schemes]]
type = "pinv"
"""


def one_error(capsys: pytest.CaptureFixture[str], argv: list[str]) -> str:
    """Run ``redres argv``; expect exit 2 and one ``redres: error:`` line; return it."""
    assert main(argv) == 2
    err = capsys.readouterr().err
    lines = [line for line in err.splitlines() if not line.startswith("redres: compiling")]
    assert len(lines) == 1, err
    assert lines[0].startswith("redres: error: ")
    assert "Traceback" not in err
    return lines[0]


def scenario(tmp_path: Path, text: str, name: str = "scenario.toml") -> str:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return str(path)


@pytest.mark.parametrize(
    ("old", "new", "message"),
    [
        ("duration = 0.02", "duration = 0.0005", r"\[run\]: duration = 0.0005 s is under half"),
        ("duration = 0.02", "duration = 1e9", rf"at most {MAX_STEPS:,} steps"),
        ("dt = 0.002", "dt = 1e-300", r"\[run\]: duration / dt = .*raise dt or shorten"),
        ("dt = 0.002", "dt = 5e-324", r"= inf steps"),
        ("duration = 0.02", "duration = " + "9" * 400, r"\(400 characters\) is too large"),
        ("period = 1.0", "period = 1.0\nnormal = [0, 0, " + "7" * 400 + "]", r"too large"),
        (
            'type = "pinv"',
            'type = "pinv"\n\n[[obstacles]]\ntype = "sphere"\ncenter = [0.4, 0, 0.5]\n'
            "radius = 1e300",
            r"\[obstacles\]\[0\]\.radius: must lie within ±1e\+09; got 1e\+300",
        ),
        ('model = "panda"', 'urdf = "' + "a" * 5000 + '"', r"\[robot\]\.urdf: .*too long"),
        ("[run]", "x = " + "[" * 3000 + "]" * 3000 + "\n[run]", r"nested too deeply"),
    ],
)
def test_bad_values_are_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], old: str, new: str, message: str
) -> None:
    assert old in GOOD
    path = scenario(tmp_path, GOOD.replace(old, new, 1))
    line = one_error(capsys, ["run", path, "--out", str(tmp_path / "report")])
    assert re.search(message, line), line
    assert not (tmp_path / "report").exists()


def test_a_byte_order_mark_is_read(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "bom.toml"
    path.write_bytes(b"\xef\xbb\xbf" + GOOD.encode())
    assert main(["run", str(path), "--quiet", "--out", str(tmp_path / "o")]) == 0


@pytest.mark.parametrize(
    ("make_out", "message"),
    [
        (lambda d: (d / "file").write_text("x") and d / "file" / "sub", r"'.*file' is a file"),
        (lambda d: Path("/proc/redres-report"), r"'/proc/redres-report': "),
        (lambda d: d / ("b" * 5000), r"\(50\d\d characters\).*too long"),
        (lambda d: (d / "o" / "report.html").mkdir(parents=True) or d / "o", r"is a folder"),
    ],
    ids=["under-a-file", "proc", "long-name", "report.html-folder"],
)
def test_bad_report_folders_are_refused_before_running(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], make_out, message: str
) -> None:
    out = make_out(tmp_path)
    for extra in ([], ["--force"]):
        line = one_error(capsys, ["run", scenario(tmp_path, GOOD), "--out", str(out), *extra])
        assert re.search(message, line), line


def test_a_report_html_folder_in_an_earlier_report(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "o"
    (out / "report.html").mkdir(parents=True)
    (out / ".redres-report").write_text("")
    assert "report.html' is a folder" in one_error(
        capsys, ["run", scenario(tmp_path, GOOD), "--out", str(out)]
    )


def test_a_read_only_folder(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """As root a chmod 555 folder stays writable, so the refusal is simulated."""

    def refuse(*args: object, dir: str = "", **kwargs: object) -> str:
        raise PermissionError(errno.EACCES, "Permission denied", dir)

    monkeypatch.setattr(tempfile, "mkdtemp", refuse)
    line = one_error(capsys, ["run", scenario(tmp_path, GOOD), "--out", str(tmp_path / "ro")])
    assert "Permission denied; you may not write there" in line and "'" + str(tmp_path) in line


def test_a_full_disk(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    def full(self: Path, data: object) -> int:
        raise OSError(errno.ENOSPC, "No space left on device", str(self))

    monkeypatch.setattr(Path, "write_bytes", full)
    out = tmp_path / "report"
    line = one_error(capsys, ["run", scenario(tmp_path, GOOD), "--quiet", "--out", str(out)])
    assert "No space left on device; the disk is full" in line and ".png" in line
    assert not out.exists()  # the first report failed: no folder left


def test_an_unreadable_scenario(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    line = one_error(capsys, ["run", str(tmp_path)])  # a folder, not a file
    assert "cannot read the scenario file" in line and str(tmp_path) in line
