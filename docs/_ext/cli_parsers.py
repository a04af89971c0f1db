"""The argparse parsers of the project's command lines, for sphinx-argparse (docs/api/cli.md).

``clumpprops`` and ``clumpprops export`` expose ``build_parser()``.  The study's commands
(``python -m studies``, ``python -m studies.report``) build their parser inside ``main``: the
parser is taken from a call of ``main`` whose ``parse_args`` stops before anything runs, so the
page always shows the options the command really has.
"""
import argparse
import importlib
import textwrap

from docutils import nodes
from docutils.parsers.rst import Directive


class _Captured(Exception):
    """Carries the parser whose ``parse_args`` was called."""

    def __init__(self, parser):
        super().__init__(parser.prog)
        self.parser = parser


def parser_of(module_name):
    """The ``argparse.ArgumentParser`` of command module ``module_name``.

    Its ``build_parser()`` where it has one; otherwise the parser ``main`` builds, captured at its
    ``parse_args`` call (``main`` is stopped there: nothing is read, written or started).
    """
    module = importlib.import_module(module_name)
    if hasattr(module, "build_parser"):
        return module.build_parser()
    original = argparse.ArgumentParser.parse_args

    def capture(self, *args, **kwargs):
        raise _Captured(self)

    argparse.ArgumentParser.parse_args = capture
    try:
        module.main([])
    except _Captured as captured:
        return captured.parser
    finally:
        argparse.ArgumentParser.parse_args = original
    raise RuntimeError(f"{module_name}.main returned without parsing its arguments")


def clumpprops_parser():
    """``clumpprops FILE``."""
    return parser_of("clumpprops.cli")


def export_parser():
    """``clumpprops export FILE --to ENGINE``."""
    return parser_of("clumpprops.io.cli")


def studies_parser():
    """``python -m studies COMMAND SPEC``."""
    return parser_of("studies.__main__")


def report_parser():
    """``python -m studies.report``."""
    return parser_of("studies.report")


class ParserDescription(Directive):
    """``.. parser-description:: FUNC``: the description of parser ``FUNC()`` of this module, as the
    command's ``--help`` shows it (a literal block: the study's description is laid out in columns)."""

    required_arguments = 1

    def run(self):
        parser = globals()[self.arguments[0]]()
        text = textwrap.dedent(parser.description or "").strip("\n").replace("``", "")
        return [nodes.literal_block(text, text)]


def setup(app):
    app.add_directive("parser-description", ParserDescription)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
