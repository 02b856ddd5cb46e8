"""Sphinx configuration of the redres documentation site (``make docs``).

The build runs with warnings as errors and nitpicky cross-references
(``sphinx-build -W --keep-going -n``). It executes every example of ``examples/``
(sphinx-gallery) and every theory page of ``theory/`` (MyST-NB), so a broken example or a
failing check in a theory page fails the build.

External links (intersphinx) are added only when the inventories can be reached: CI and
most build machines have no network beyond the package registries, so the build first
asks each inventory with a short timeout and uses those that answer. References to
external types (NumPy, SciPy, Pinocchio, Matplotlib, the standard library) are then
links where an inventory was reached and plain text otherwise; ``nitpick_ignore_regex``
below lists exactly those external namespaces so that their absence is never a warning.
Everything of redres itself must resolve: a public name to its page (``_ext/redres_api.py``
redirects every other path of it there), an existing internal name (a private helper, a
module constant, a type alias) to plain code text; a name that exists nowhere is an error.
"""

from __future__ import annotations

import atexit
import builtins
import collections.abc
import os
import shutil
import sys
import tempfile
import typing
import urllib.request
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE / "_ext"))

# Examples and notebooks run in this process and in Jupyter kernels: compile numba kernels
# in the foreground (the cache of `make test` is then warm). sphinx-gallery draws with
# Agg by itself; the notebooks need the kernel's inline backend, which MPLBACKEND would
# override (their figures would silently vanish).
os.environ.setdefault("REDRES_COMPILE", "foreground")
os.environ.pop("MPLBACKEND", None)
# The gallery runs each example at its own length (the closed-loop ones: the whole
# scenario, 10 s at 1 kHz, a few seconds of build time each); REDRES_DOCS_STEPS=N
# shortens them all to N control steps.
if os.environ.get("REDRES_DOCS_STEPS"):
    os.environ["REDRES_EXAMPLE_STEPS"] = os.environ["REDRES_DOCS_STEPS"]
# The notebooks' kernels talk to the build over local TCP, and each kernel used to print
# a warning about it ("Kernel is running over TCP without encryption"): nine lines of
# noise per build. Their IPython profile, in a folder of this build, keeps the kernels'
# log to errors and writes no history.
_PROFILE = Path(tempfile.mkdtemp(prefix="redres-docs-ipython-"))
(_PROFILE / "profile_default").mkdir()
(_PROFILE / "profile_default" / "ipython_kernel_config.py").write_text(
    'c.IPKernelApp.log_level = "ERROR"\nc.HistoryManager.enabled = False\n'
)
os.environ["IPYTHONDIR"] = str(_PROFILE)
atexit.register(shutil.rmtree, _PROFILE, ignore_errors=True)

from sphinx.ext.napoleon.docstring import GoogleDocstring  # noqa: E402
from sphinx.util.inspect import TypeAliasForwardRef  # noqa: E402

import redres  # noqa: E402

project = "redres"
author = "The redres developers"
copyright = "The redres developers, BSD-3-Clause"
release = redres.__version__
version = release

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.napoleon",
    "sphinx.ext.mathjax",
    "sphinx.ext.intersphinx",
    "sphinx_copybutton",
    "offline_mathjax",
    "myst_nb",
    "sphinx_gallery.gen_gallery",
    "redres_api",
]

source_suffix = {".rst": "restructuredtext", ".md": "myst-nb"}
root_doc = "index"
exclude_patterns = ["_build", "**.ipynb_checkpoints", "auto_examples/*.ipynb"]
templates_path = ["_templates"]

# --- HTML -----------------------------------------------------------------------------
html_theme = "pydata_sphinx_theme"
html_title = f"redres {release}"
html_theme_options = {
    "navigation_with_keys": False,
    "show_toc_level": 2,
    "header_links_before_dropdown": 4,
    "secondary_sidebar_items": ["page-toc"],
    "footer_start": ["copyright"],
    "footer_end": ["sphinx-version"],
}
html_static_path: list[str] = []
html_show_sourcelink = False

# --- autodoc, autosummary, napoleon ---------------------------------------------------
autosummary_generate = True
autosummary_imported_members = True
autodoc_default_options = {"member-order": "bysource"}
autodoc_typehints = "description"
autodoc_typehints_description_target = "documented_params"
autodoc_preserve_defaults = True
# Keep NumPy's ArrayLike by name in signatures (expanded, it is a ten-line union).
autodoc_type_aliases = {"ArrayLike": "ArrayLike"}
# Sphinx 9.0 prints such an alias inside a union as "TypeAliasForwardRef('ArrayLike')":
# make its repr the alias name.
TypeAliasForwardRef.__repr__ = lambda self: str(self.name)  # type: ignore[method-assign]
# The class docstring says what the constructor takes (Google style "Args:"); __init__
# docstrings only point back to it, so they are not appended.
autoclass_content = "class"
autodoc_class_signature = "mixed"
napoleon_google_docstring = True
napoleon_numpy_docstring = False
napoleon_include_init_with_doc = False
napoleon_use_rtype = False
napoleon_preprocess_types = False
napoleon_attr_annotations = True


def _inline_attribute_without_type(self: GoogleDocstring) -> tuple[str, list[str]]:
    """redres writes property and attribute docstrings as sentences ("The Pinocchio data
    this robot computes into: the calling thread's own."), never as napoleon's
    ``type: description``; its types come from the annotations. Read them that way."""
    lines = [self._lines.next(), *self._dedent(self._consume_to_end())]
    return "", self.__class__(lines, self._config).lines()


GoogleDocstring._consume_inline_attribute = _inline_attribute_without_type  # type: ignore[method-assign]

# --- cross-references -----------------------------------------------------------------
nitpicky = True
default_role = "code"
python_use_unqualified_type_names = True
python_display_short_literal_types = True
_STDLIB = sorted(n for n in sys.stdlib_module_names if not n.startswith("_"))
_TYPING = sorted(n for n in dir(typing) + dir(collections.abc) if n[:1].isupper())
_EXTERNAL = (
    r"(numpy|np|scipy|pinocchio|pin|matplotlib|plotly|qpsolvers|numba)(\..*)?",
    # the standard library: its modules, and typing names as annotations spell them
    r"(" + "|".join(_STDLIB) + r")(\..*)?",
    r"(" + "|".join(_TYPING) + r")(\[.*)?",
    # builtins (int, float, ValueError, ...)
    r"(" + "|".join(n for n in dir(builtins) if not n.startswith("_")) + r")",
    # NumPy's array-like alias, and redres' own names for NumPy arrays of one dtype
    r"(ArrayLike|NDArray|FloatArray|IntArray)(\[.*)?",
)
# Genuinely external names: links when an intersphinx inventory answered, text otherwise.
nitpick_ignore_regex = [(r"py:.*", pattern) for pattern in _EXTERNAL]
# redres.robot.meshes.LinkMesh is internal (Robot.visuals' element type, no page of its own)
nitpick_ignore = [("py:class", "LinkMesh")]
# the inherited collections.abc.Mapping methods of SweepData: their docstrings' return text
nitpick_ignore_regex += [
    ("py:class", r"D\[k\] if k in D.*"),
    ("py:class", r"a set-like object providing a view on D's (items|keys)"),
    ("py:class", r"an object providing a view on D's values"),
]

_INVENTORIES = {
    "python": "https://docs.python.org/3",
    "numpy": "https://numpy.org/doc/stable",
    "scipy": "https://docs.scipy.org/doc/scipy",
    "matplotlib": "https://matplotlib.org/stable",
}


def _reachable(url: str) -> bool:
    try:
        with urllib.request.urlopen(f"{url}/objects.inv", timeout=3) as answer:
            return bool(answer.status == 200)
    except OSError:
        return False


def _intersphinx() -> dict[str, tuple[str, None]]:
    if os.environ.get("REDRES_DOCS_OFFLINE"):
        return {}
    with ThreadPoolExecutor(len(_INVENTORIES)) as pool:
        answers = dict(zip(_INVENTORIES, pool.map(_reachable, _INVENTORIES.values())))
    return {name: (url, None) for name, url in _INVENTORIES.items() if answers[name]}


# Pinocchio documents its Python API with Doxygen: there is no inventory to link to.
intersphinx_mapping = _intersphinx()
intersphinx_timeout = 5

# --- MyST and MyST-NB (the Markdown pages and the theory notebooks) --------------------
myst_enable_extensions = ["dollarmath", "amsmath", "colon_fence", "deflist"]
myst_heading_anchors = 3
nb_execution_mode = "force"
nb_execution_raise_on_error = True
nb_execution_timeout = 300
nb_execution_show_tb = True
nb_merge_streams = True

# --- sphinx-gallery (examples/) ---------------------------------------------------------
# Every numbered example runs at build time. Examples whose file name contains "_slow"
# run only with REDRES_DOCS_ALL=1 (none is that slow today).
_RUN = r"/\d\d_.*\.py" if os.environ.get("REDRES_DOCS_ALL") else r"/\d\d_(?!.*_slow).*\.py"
for _stale in (HERE / "sg_execution_times.rst", HERE / "auto_examples" / "sg_execution_times.rst"):
    _stale.unlink(missing_ok=True)  # written by earlier builds, before the option below
sphinx_gallery_conf = {
    "examples_dirs": "../examples",
    "gallery_dirs": "auto_examples",
    "filename_pattern": _RUN,
    "within_subsection_order": "FileNameSortKey",
    "download_all_examples": False,
    "remove_config_comments": True,
    "image_scrapers": ("matplotlib",),
    "reset_modules": ("matplotlib",),
    "backreferences_dir": None,
    "show_memory": False,
    "capture_repr": (),
    "min_reported_time": 1,
    # Its execution-times pages load jQuery and DataTables from CDNs: the site must work
    # offline (each example's page still gives its running time).
    "write_computation_times": False,
}
