"""``public-names`` directive: a module's public names, read from its ``__all__``.

Used on the API pages above ``automodule`` so that the pages follow the modules as they change
(names added, moved into subpackages).  Classes and functions get a summary table (autosummary;
``automodule`` documents them in full below it); constants (``METHODS``, ``ENGINES``, ...), which
``automodule`` leaves out when they are imported from a submodule, are documented here with their
value and their ``#:`` comment.  Dunder names (``__version__``) are left out.
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


def _rst(module_name):
    module = sys.modules[module_name]
    names = public_names(module_name)
    routines = [n for n in names if not is_constant(getattr(module, n))]
    constants = [n for n in names if is_constant(getattr(module, n))]
    lines = [".. autosummary::", ""] + [f"   {module_name}.{n}" for n in routines] + [""]
    if constants:
        lines += [".. rubric:: Constants", ""]
    for n in constants:
        lines += [f".. py:data:: {module_name}.{n}", f"   :value: {getattr(module, n)!r}", ""]
        lines += [f"   {line}" for line in constant_comment(module_name, n)] + [""]
    return lines


class PublicNames(Directive):
    """``.. public-names:: MODULE``: a summary table of ``MODULE.__all__`` and its constants."""

    required_arguments = 1

    def run(self):
        module_name = self.arguments[0]
        importlib.import_module(module_name)
        content = StringList(_rst(module_name), source=f"<public-names {module_name}>")
        container = nodes.container()
        nested_parse_with_titles(self.state, content, container)
        return container.children


def setup(app):
    app.add_directive("public-names", PublicNames)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
