"""Sphinx configuration of the clumpprops documentation site (``make docs``: build/docs).

The guides are the Markdown files of this folder, read by MyST; the API reference is generated
by autodoc + numpydoc from the docstrings of the public modules (docs/api/); the study's command
line is documented from its own argparse parser (sphinx-argparse, docs/_ext/cli_parsers.py).
Every package used here is a Debian 12 package (scripts/setup.sh installs them).
"""
import os
import sys

from sphinx.util import logging as sphinx_logging

DOCS = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(DOCS)
sys.path[:0] = [ROOT, os.path.join(DOCS, "_ext")]   # the worktree's code first, then the extensions
os.environ.setdefault("OMP_NUM_THREADS", "1")

import clumpprops  # noqa: E402

project = "clumpprops"
author = "the clumpprops developers"
copyright = "the clumpprops developers, BSD-3-Clause"
version = release = clumpprops.__version__

extensions = [
    "myst_parser",
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx.ext.viewcode",
    "numpydoc",
    "sphinxarg.ext",
    "cli_parsers",
    "public_api",
]

source_suffix = {".md": "markdown", ".rst": "restructuredtext"}
root_doc = "index"
exclude_patterns = ["_build", "Thumbs.db", ".DS_Store"]
templates_path = []

# Markdown: $...$ maths, ::: fences, heading anchors for links like [x](studies.md#your-own-grain)
myst_enable_extensions = ["dollarmath", "colon_fence", "deflist"]
myst_heading_anchors = 4

# code blocks without a language are shell commands, file listings and program output, not Python
highlight_language = "none"

# guides whose sections start at H2 or H3 (cli.md, granular_gas.md) render as they are
suppress_warnings = ["myst.header"]

# API reference
autodoc_default_options = {}           # docs/_ext/public_api.py documents each name of __all__
autodoc_member_order = "bysource"
autodoc_typehints = "none"            # numpydoc's Parameters sections carry the types
public_api_modules = ["clumpprops", "clumpprops.yade", "clumpprops.io"]   # each name of __all__ must be documented
autosummary_generate = False          # summaries are tables on the module pages, no stub files
numpydoc_show_class_members = False   # autodoc lists the members itself
numpydoc_class_members_toctree = False
numpydoc_xref_param_type = False
# every documented public callable has its numpydoc sections (-W turns a missing one into an error):
# GL08 a docstring, PR01 every parameter documented, PR02 no unknown one, RT01 Returns where it returns
numpydoc_validation_checks = {"GL08", "PR01", "PR02", "RT01"}
# Not validated: private and dunder members.
numpydoc_validation_exclude = {r"\._[^.]*$"}

html_theme = "furo"
html_title = f"clumpprops {release}"
html_static_path = ["_static"]
html_css_files = ["clumpprops.css"]
html_show_sourcelink = False
html_extra_path = [os.path.join(ROOT, "LICENSE"), os.path.join(ROOT, "CITATION.cff")]

# -- links from the Markdown pages to files of the repository ------------------------------------
# The guides link to repository files by relative path, so that they read well on a forge too.
# Files that are pages of this site are linked to their page; LICENSE and CITATION.cff are copied
# into the site; any other existing file is shown as its link text (a source file is not part of
# the site).  A link to a file that does not exist still warns.
SITE_PAGES = {"README.md": "getting_started", "results/README.md": "results", "CHANGELOG.md": "changelog"}


def _repository_file(env, node):
    """The repository path (relative to ROOT) a Markdown link points to, or None."""
    target = node["reftarget"].split("#", 1)[0]
    page_dir = os.path.dirname(env.doc2path(node.get("refdoc", env.docname)))
    for base in (page_dir, ROOT):     # the page's folder, then the root (README.md's links, included)
        path = os.path.normpath(os.path.join(base, target))
        if path.startswith(ROOT + os.sep) and os.path.exists(path):
            return os.path.relpath(path, ROOT)
    return None


def link_repository_files(app, env, node, contnode):
    """``missing-reference`` handler for MyST links to repository files (see above)."""
    from docutils import nodes
    from sphinx.util.nodes import make_refnode

    if node.get("reftype") not in ("myst", "any") or "reftarget" not in node:
        return None
    path = _repository_file(env, node)
    if path is None:
        return None
    refdoc = node.get("refdoc", env.docname)
    if path in SITE_PAGES:
        return make_refnode(app.builder, refdoc, SITE_PAGES[path], "", contnode)
    if path in ("LICENSE", "CITATION.cff"):
        depth = refdoc.count("/")
        return nodes.reference("", "", contnode, internal=False, refuri="../" * depth + path)
    return contnode


def _check_no_yade(app, env):
    """Documenting ``clumpprops.yade`` must not import YADE (no scene is made, nothing is patched)."""
    if "yade" in sys.modules:
        sphinx_logging.getLogger(__name__).warning(
            "the docs build imported YADE: clumpprops.yade must import it lazily, inside its functions")


def setup(app):
    app.connect("missing-reference", link_repository_files)
    app.connect("env-updated", _check_no_yade)
