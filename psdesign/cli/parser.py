"""The argument parser class of every ``psdesign`` command: a bad argument is one line naming
the option and what it takes (exit status 2), as a bad spec key is."""

from __future__ import annotations

import argparse
import difflib
import re
from collections.abc import Sequence

#: argparse's own line for a value its ``type=int`` / ``type=float`` could not convert.
_BAD_NUMBER = re.compile(r"^argument (?P<opt>\S+): invalid (?P<kind>int|float) value: (?P<got>.*)$")
_KIND = {"int": "an integer", "float": "a number"}


class Parser(argparse.ArgumentParser):
    """``argparse.ArgumentParser`` whose errors are one line, exit status 2: a value that is
    not a number names the option's allowed range (its help), and an unknown option names the
    closest one the command has."""

    def error(self, message: str) -> None:  # one line, exit 2
        self.exit(2, f"psdesign: error: {self._explained(message)}\n")

    def parse_args(self, args: Sequence[str] | None = None, namespace=None):  # noqa: ANN201
        ns, extras = self.parse_known_args(args, namespace)
        if extras:
            self.error(unrecognized(self, ns, extras))
        return ns

    def _explained(self, message: str) -> str:
        """argparse's "argument --n-radii: invalid int value: 'abc'" as "--n-radii: must be an
        integer, got 'abc' (allowed: <its help>)"; any other message as it is."""
        match = _BAD_NUMBER.match(message)
        if match is None:
            return message
        opt = match["opt"].split("/")[-1]  # "-o/--output" -> "--output"
        action = self._option_string_actions.get(opt)
        allowed = f" (allowed: {_first_clause(action.help)})" if action and action.help else ""
        return f"{opt}: must be {_KIND[match['kind']]}, got {match['got']}{allowed}"


def _first_clause(text: str) -> str:
    """An option's help up to its first "; " where that leaves no bracket open (the range
    comes first; --workers goes on about schedulers), else all of it.

    >>> _first_clause("processes, 0 to 64; 0 runs here")
    'processes, 0 to 64'
    >>> _first_clause("in (0, 0.2] (default 0.1; above 0.2 untrustworthy)")
    'in (0, 0.2] (default 0.1; above 0.2 untrustworthy)'
    """
    text = text.replace("%%", "%")
    head = text.split("; ")[0]
    opened = sum(head.count(c) for c in "([") - sum(head.count(c) for c in ")]")
    return head if opened == 0 else text


def _leaf(parser: argparse.ArgumentParser, ns: argparse.Namespace) -> argparse.ArgumentParser:
    """The sub-command parser the namespace's choices lead to (``psdesign study run`` ->
    the ``run`` parser), else ``parser``."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            chosen = action.choices.get(getattr(ns, action.dest, None))
            return parser if chosen is None else _leaf(chosen, ns)
    return parser


def unrecognized(parser: argparse.ArgumentParser, ns: argparse.Namespace, extras: list) -> str:
    """The line for arguments no option took: with the closest option of the command for a
    mistyped one ("--sovler": did you mean --solver?) and where the options are listed.

    >>> p = Parser(prog="psdesign")
    >>> _ = p.add_argument("--solver")
    >>> unrecognized(p, argparse.Namespace(), ["--sovler", "voxel"])[:63]
    'unrecognized arguments: --sovler voxel; did you mean --solver? '
    """
    leaf = _leaf(parser, ns)
    options = [o for o in leaf._option_string_actions if o.startswith("--")]
    hints = []
    for arg in extras:
        if arg.startswith("-"):
            close = difflib.get_close_matches(arg.split("=")[0], options, n=1, cutoff=0.6)
            hints += [h for h in close if h not in hints]
    line = f"unrecognized arguments: {' '.join(extras)}"
    if hints:
        line += f"; did you mean {' or '.join(hints)}?"
    return f"{line} ({leaf.prog} --help lists the options)"
