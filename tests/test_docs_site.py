"""Every public name of redres has a page in the built documentation site.

The public names are walked here from ``__all__`` (redres, the modules it lists, every
public subpackage, recursively). The built site (``make docs``) is read through its
``objects.inv``, Sphinx's index of every documented object: each public name, or another
public path of the same object, must be there with an existing page. Without a built site
the check is skipped, except under ``make docs`` (``REDRES_DOCS_REQUIRED=1``), which runs
it right after building.
"""

from __future__ import annotations

import importlib
import inspect
import os
import pkgutil
import re
import zlib
from pathlib import Path

import pytest

import redres

SITE = Path(__file__).resolve().parents[1] / "docs" / "_build" / "html"


def _public(name: str) -> bool:
    return not any(part.startswith("_") for part in name.split("."))


def walk_public_names() -> dict[str, object]:
    """``{"redres.linalg.pinv": pinv, ...}`` for every public module's ``__all__``."""
    modules = ["redres"] + [
        info.name
        for info in pkgutil.walk_packages(redres.__path__, prefix="redres.")
        if info.ispkg and _public(info.name)
    ]
    names: dict[str, object] = {}
    seen: set[str] = set()
    while modules:
        module_name = modules.pop(0)
        if module_name in seen:
            continue
        seen.add(module_name)
        module = importlib.import_module(module_name)
        for name in module.__all__:
            obj = getattr(module, name)
            names[f"{module_name}.{name}"] = obj
            if inspect.ismodule(obj) and _public(obj.__name__):
                modules.append(obj.__name__)
    return names


def read_inventory(path: Path) -> dict[str, str]:
    """``{name: page}`` of the Python objects in a Sphinx ``objects.inv`` (version 2)."""
    raw = path.read_bytes()
    header_end = 0
    for _ in range(4):
        header_end = raw.index(b"\n", header_end) + 1
    assert raw.startswith(b"# Sphinx inventory version 2"), "not a Sphinx inventory"
    entries: dict[str, str] = {}
    line = re.compile(r"(?x)(.+?)\s+(py:\S+)\s+(-?\d+)\s+(\S*)\s+(.*)")
    for text in zlib.decompress(raw[header_end:]).decode("utf-8").splitlines():
        match = line.fullmatch(text)
        if match and match.group(2).startswith("py:"):
            name, page = match.group(1), match.group(4)
            entries[name] = page.replace("$", name).split("#")[0]
    return entries


def test_the_walk_finds_the_public_api() -> None:
    """The walk reaches the subpackages and their names (an empty walk would pass all)."""
    names = walk_public_names()
    for expected in ("redres.Robot", "redres.linalg.pinv", "redres.robot.SerialChain",
                     "redres.resolution.QPScheme", "redres.report.write_report"):  # fmt: skip
        assert expected in names
    assert len(names) > 150


def test_read_inventory_reads_what_sphinx_writes(tmp_path: Path) -> None:
    body = "redres.linalg.pinv py:function 1 api/generated/$.html#$ -\nx std:label -1 a.html -\n"
    inv = tmp_path / "objects.inv"
    inv.write_bytes(
        b"# Sphinx inventory version 2\n# Project: p\n# Version: 1\n# zlib\n"
        + zlib.compress(body.encode())
    )
    assert read_inventory(inv) == {"redres.linalg.pinv": "api/generated/redres.linalg.pinv.html"}


def test_every_public_name_has_an_api_page() -> None:
    inventory_file = SITE / "objects.inv"
    if not inventory_file.is_file():
        if os.environ.get("REDRES_DOCS_REQUIRED"):
            pytest.fail(f"no built site at {inventory_file}; `make docs` builds it")
        pytest.skip("the documentation site is not built (make docs)")
    inventory = read_inventory(inventory_file)
    names = walk_public_names()
    paths_of: dict[tuple[int, str], list[str]] = {}
    for path, obj in names.items():
        paths_of.setdefault((id(obj), path.rpartition(".")[2]), []).append(path)
    missing = []
    for path, obj in names.items():
        aliases = paths_of[(id(obj), path.rpartition(".")[2])]
        if inspect.ismodule(obj):
            aliases = [obj.__name__]
        pages = [inventory[a] for a in aliases if a in inventory]
        if not pages or not all((SITE / page).is_file() for page in pages):
            missing.append(path)
    assert not missing, f"public names without an API page: {missing}"


def test_the_site_loads_no_script_or_stylesheet_from_another_host() -> None:
    """The site works offline: no page pulls a script or a stylesheet from a CDN (the
    gallery's execution-times pages did: jQuery and DataTables)."""
    if not (SITE / "index.html").is_file():
        if os.environ.get("REDRES_DOCS_REQUIRED"):
            pytest.fail(f"no built site at {SITE}; `make docs` builds it")
        pytest.skip("the documentation site is not built (make docs)")
    remote = re.compile(r"""<(?:script[^>]*\ssrc|link[^>]*\shref)=["'](?:https?:)?//""")
    pages = sorted(SITE.rglob("*.html"))
    assert len(pages) > 100  # the whole site, not an empty folder
    found = [str(p.relative_to(SITE)) for p in pages if remote.search(p.read_text("utf-8"))]
    assert not found, f"pages loading from another host: {found}"


def test_user_guide_pages_show_the_guide_in_their_sidebar() -> None:
    """Every user-guide page lists the guide's pages in its left sidebar (it was empty
    when the pages hung off the root), the viewer among them."""
    guide = SITE / "user_guide.html"
    if not guide.is_file():
        if os.environ.get("REDRES_DOCS_REQUIRED"):
            pytest.fail(f"no built site at {SITE}; `make docs` builds it")
        pytest.skip("the documentation site is not built (make docs)")
    entry = r'<li class="toctree-l1"><a class="reference internal" href="([a-z_]+)\.html"'
    pages = re.findall(entry, guide.read_text("utf-8"))
    assert {"models", "sweeps", "viewer", "report"} <= set(pages), pages
    for name in pages:
        html = (SITE / f"{name}.html").read_text("utf-8")
        nav = html[html.index("bd-sidenav") :]
        nav = nav[: nav.index("</ul>")]
        links = set(re.findall(r'href="([a-z_]+)\.html"', nav))
        assert len(links) >= len(pages) - 1, (name, links)  # all but itself ("#")
