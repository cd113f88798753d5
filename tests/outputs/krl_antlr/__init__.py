"""grammars-v4's KRL grammar (``krl.g4``, LGPL 3.0 or later: README.md here) and its ANTLR 4.13.2 Python parser,
generated once and committed, as an independent check of the KRL writer's files (tests only).

``syntax_errors(text)`` is every syntax error the lexer and the parser report for one ``.src`` or ``.dat``.
"""

from __future__ import annotations

from antlr4 import CommonTokenStream, InputStream
from antlr4.error.ErrorListener import ErrorListener

from .krlLexer import krlLexer
from .krlParser import krlParser


class _Collected(ErrorListener):
    """Every error reported, as (line, column, message): line from 1, column from 0 (ANTLR's)."""

    def __init__(self):
        super().__init__()
        self.errors: list[tuple[int, int, str]] = []

    def syntaxError(self, recognizer, offendingSymbol, line, column, msg, e):
        self.errors.append((line, column, msg))


def syntax_errors(text: str) -> list[tuple[int, int, str]]:
    """The (line, column, message) of every lexer and parser error in ``text`` parsed as one KRL ``module``
    (krl.g4's start rule: a ``.src``'s routines or a ``.dat``'s DEFDAT); empty when it parses. ANTLR recovers
    from an error and goes on, so one run reports them all."""
    collected = _Collected()
    lexer = krlLexer(InputStream(text))
    lexer.removeErrorListeners()
    lexer.addErrorListener(collected)
    parser = krlParser(CommonTokenStream(lexer))
    parser.removeErrorListeners()
    parser.addErrorListener(collected)
    parser.module()
    return collected.errors
