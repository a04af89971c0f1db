"""``public-names`` directive: a module's public names, read from its ``__all__``, documented.

Used on the API pages below ``automodule`` (which gives the module's docstring) so that the pages
follow the modules as they change (names added, moved into subpackages): a summary table
(autosummary), the constants (``METHODS``, ``ENGINES``, ...) with their value and their ``#:``
comment, then every class and function in full (autodoc, numpydoc).  Dunder names
(``__version__``) are left out.
"""
import importlib
import inspect
import sys

from docutils import nodes
from docutils.parsers.rst import Directive
from docutils.statemachine import StringList
from sphinx.pycode import ModuleAnalyzer
from sphinx.util.nodes import nested_parse_with_titles


def public_names(module_name):
    """The names of ``module_name.__all__`` without dunders, in their ``__all__`` order."""
    module = importlib.import_module(module_name)
    names = getattr(module, "__all__", None)
    if names is None:
        raise ValueError(f"{module_name} has no __all__: its public names are not declared")
    return [n for n in names if not (n.startswith("__") and n.endswith("__"))]


def is_constant(value):
    """True for module-level data (not a class, function or module)."""
    return not (inspect.isclass(value) or inspect.isroutine(value) or inspect.ismodule(value))


def constant_comment(module_name, name):
    """The ``#:`` comment of constant ``name`` in ``module_name`` or the submodule that defines it."""
    value = getattr(sys.modules[module_name], name)
    candidates = [module_name] + sorted(m for m in list(sys.modules) if m.startswith(module_name + "."))
    for candidate in candidates:
        if getattr(sys.modules.get(candidate), name, None) is not value:
            continue
        try:
            docs = ModuleAnalyzer.for_module(candidate).find_attr_docs()
        except Exception:  # a compiled module or one without source: no comment to read
            continue
        if ("", name) in docs:
            return [line for line in docs[("", name)] if line.strip()]
    return []


def _directive(value):
    if inspect.isclass(value):
        return "autoexception" if issubclass(value, BaseException) else "autoclass"
    return "autofunction"


def _rst(module_name):
    """reST of the summary table, the constants and the full entries of ``module_name.__all__``."""
    module = sys.modules[module_name]
    names = public_names(module_name)
    routines = [n for n in names if not is_constant(getattr(module, n))]
    constants = [n for n in names if is_constant(getattr(module, n))]
    lines = [".. autosummary::", ""] + [f"   ~{module_name}.{n}" for n in routines] + [""]
    if constants:
        lines += [".. rubric:: Constants", ""]
    for n in constants:
        lines += [f".. py:data:: {n}", f"   :module: {module_name}", f"   :value: {getattr(module, n)!r}", ""]
        lines += [f"   {line}" for line in constant_comment(module_name, n)] + [""]
    if routines:
        lines += [".. rubric:: Classes and functions", ""]
    for n in routines:
        value = getattr(module, n)
        lines += [f".. {_directive(value)}:: {module_name}.{n}"]
        if inspect.isclass(value):
            lines += ["   :members:", "   :undoc-members:", "   :show-inheritance:"]
        lines += [""]
    return lines


class PublicNames(Directive):
    """``.. public-names:: MODULE``: ``MODULE.__all__`` as a summary table, then in full."""

    required_arguments = 1

    def run(self):
        module_name = self.arguments[0]
        importlib.import_module(module_name)
        content = StringList(_rst(module_name), source=f"<public-names {module_name}>")
        container = nodes.container()
        nested_parse_with_titles(self.state, content, container)
        return container.children


def check_every_name_documented(app, env):
    """Warn (an error under -W) for each public name of ``public_api_modules`` that no page documents."""
    from sphinx.util import logging

    documented = set(env.get_domain("py").objects)
    for module_name in app.config.public_api_modules:
        for name in public_names(module_name):
            if f"{module_name}.{name}" not in documented:
                logging.getLogger(__name__).warning(f"{module_name}.{name} is public (__all__) but no page "
                                                    "documents it: add a public-names directive for its module")


def setup(app):
    app.add_directive("public-names", PublicNames)
    app.add_config_value("public_api_modules", [], "env")
    app.connect("env-check-consistency", check_every_name_documented)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
