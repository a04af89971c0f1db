"""The argparse parsers of the project's command lines, for sphinx-argparse (docs/api/cli.md).

``clumpprops`` and ``clumpprops export`` expose ``build_parser()``.  The study's commands
(``python -m studies``, ``python -m studies.report``) build their parser inside ``main``: the
parser is taken from a call of ``main`` whose ``parse_args`` stops before anything runs, so the
page always shows the options the command really has.
"""
import argparse
import importlib
import re
import textwrap

from docutils import nodes
from docutils.parsers.rst import Directive
from docutils.statemachine import StringList


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


def literal_epilog(parser):
    """``parser`` with its epilog as a reST literal block: the ``clumpprops`` epilogs are laid out
    for a terminal (lists of subcommands and of files, indented), which reST would misread."""
    if parser.epilog:
        parser.epilog = "::\n\n" + textwrap.indent(parser.epilog, "   ")
    return parser


def clumpprops_parser():
    """``clumpprops FILE``."""
    return literal_epilog(parser_of("clumpprops.cli"))


def export_parser():
    """``clumpprops export FILE --to ENGINE``."""
    return literal_epilog(parser_of("clumpprops.io.cli"))


def show_parser():
    """``clumpprops show FILE -o OUT.png``."""
    return literal_epilog(parser_of("clumpprops.show"))


def fit_parser():
    """``clumpprops fit MESH --spheres N``."""
    return literal_epilog(parser_of("clumpprops.fit"))


def studies_parser():
    """``python -m studies COMMAND SPEC``."""
    return parser_of("studies.__main__")


def report_parser():
    """``python -m studies.report``."""
    return parser_of("studies.report")


COMMAND_ROW = re.compile(r"^(?P<indent>\s+)(?P<name>[\w-]+)\s{2,}(?P<text>\S.*)$")


def description_rst(description):
    """reST of an argparse description: its paragraphs as they are, and a block of indented
    ``NAME  text`` lines (with deeper-indented continuation lines) as a two-column table."""
    out, rows = [], []

    def flush_rows():
        if rows:
            out.extend([".. list-table::", "   :widths: 1 5", ""])
            for name, text in rows:
                out.extend([f"   * - ``{name}``", f"     - {text}"])
            out.append("")
            rows.clear()

    indent = None
    for line in textwrap.dedent(description or "").strip("\n").split("\n"):
        m = COMMAND_ROW.match(line)
        if m and (indent is None or len(m.group("indent")) == indent):
            indent = len(m.group("indent"))
            rows.append((m.group("name"), m.group("text").strip()))
        elif rows and line.strip() and len(line) - len(line.lstrip()) > indent:
            rows[-1] = (rows[-1][0], rows[-1][1] + " " + line.strip())
        else:
            flush_rows()
            indent = None
            out.append(line)
    flush_rows()
    return out


class ParserDescription(Directive):
    """``.. parser-description:: FUNC``: the description of parser ``FUNC()`` of this module; a
    list of sub-commands in it (indented ``NAME  text`` lines) becomes a table."""

    required_arguments = 1

    def run(self):
        parser = globals()[self.arguments[0]]()
        content = StringList(description_rst(parser.description), source=f"<{self.arguments[0]} description>")
        container = nodes.container()
        self.state.nested_parse(content, 0, container)
        return container.children


def setup(app):
    app.add_directive("parser-description", ParserDescription)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
