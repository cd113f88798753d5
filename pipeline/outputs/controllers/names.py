"""Program names a controller takes: one table of reserved words per language, with its source, and the one
rule that makes a legal name of any job name (``legal_name``), which every writer, ``lint`` and the readers share.

The rule: characters other than letters, digits and ``_`` become ``_``; FANUC and Yaskawa names upper case;
``P_`` before a name that does not start with a letter, is a reserved word of the language (compared as the
language compares names: RAPID, KRL, INFORM and LS ignore case, URScript does not) or is a name the writer
itself declares in the same file (``WRITER_NAMES``); cut to the language's length (``NAME_MAX``). The prefixed
name is an ordinary identifier, which every reader takes back.

Reserved words, per language:

* RAPID: the reserved words of ABB's "Technical reference manual - RAPID kernel", section "Reserved words".
* KRL: the keywords of the ANTLR grammar ``kuka/krl.g4`` (antlr/grammars-v4, LGPL-3.0; its lexer's keyword
  tokens, KSS 5/8 syntax), e.g. ``DEF END( )`` is not KRL.
* INFORM (JBI): the job file's section and instruction words the writer uses or a job may call (``NOP``, ``END``,
  ``MOVJ`` ...; NX100 operator's manual, "INFORM instructions"). Whether a controller refuses them as job names
  is unconfirmed: they are avoided so that a ``CALL JOB:`` line is never ambiguous.
* LS (FANUC TP): the ASCII program's section words and the TP instruction words the writer uses (``/PROG``,
  ``/MN``, ``/POS``, ``/END``, ``J``, ``L``, ``C``, ``UFRAME_NUM`` ...; FANUC R-30iB operator's manual, "program
  instructions"). No published list of names a controller refuses was found: avoided, unconfirmed.
* URScript: the keywords of "The URScript Programming Language" (e-Series SW 5.x, "The language"), and the
  functions a written program defines (``native_moves``, ``certified_replay``, ``use_certified_replay``).
"""

from __future__ import annotations

import re

#: The controller languages (``lint`` checks each, ``runner`` writes each).
RAPID, FANUC_LS, JBI, KRL, URSCRIPT = "rapid", "ls", "jbi", "krl", "urscript"
LANGUAGES = (RAPID, FANUC_LS, JBI, KRL, URSCRIPT)
#: The longest program name of each language [characters; None: any length] (sources: ``lint.LIMITS``).
NAME_MAX = {RAPID: 32, FANUC_LS: 8, JBI: 8, KRL: 24, URSCRIPT: None}

RESERVED_WORDS = {
    RAPID: frozenset((
        "ALIAS", "AND", "BACKWARD", "CASE", "CONNECT", "CONST", "DEFAULT", "DIV", "DO", "ELSE", "ELSEIF", "ENDFOR",
        "ENDFUNC", "ENDIF", "ENDMODULE", "ENDPROC", "ENDRECORD", "ENDTEST", "ENDTRAP", "ENDWHILE", "ERROR", "EXIT",
        "FALSE", "FOR", "FROM", "FUNC", "GOTO", "IF", "INOUT", "LOCAL", "MOD", "MODULE", "NOSTEPIN", "NOT", "NOVIEW",
        "OR", "PERS", "PROC", "RAISE", "READONLY", "RECORD", "RETRY", "RETURN", "STEP", "SYSMODULE", "TASK", "TEST",
        "THEN", "TO", "TRAP", "TRUE", "TRYNEXT", "UNDO", "VAR", "VIEWONLY", "WHILE", "WITH", "XOR")),
    KRL: frozenset((
        "AND", "ANIN", "ANOUT", "B_AND", "B_NOT", "B_OR", "B_EXOR", "BOOL", "BRAKE", "C_DIS", "C_ORI", "C_PTP",
        "C_VEL", "CASE", "CAST_FROM", "CAST_TO", "CHAR", "CIRC_REL", "CIRC", "CONST", "CONTINUE", "DELAY", "DECL",
        "DEF", "DEFAULT", "DEFDAT", "DEFFCT", "DO", "ELSE", "END", "ENDDAT", "ENDFCT", "ENDFOR", "ENDIF", "ENDLOOP",
        "ENDSWITCH", "ENDWHILE", "ENUM", "EXIT", "EXT", "EXTFCT", "FALSE", "FOR", "GLOBAL", "GOTO", "HALT", "IF",
        "IMPORT", "INTERRUPT", "INT", "IS", "LIN_REL", "LIN", "LOOP", "MAXIMUM", "MINIMUM", "NOT", "OR", "PRIO",
        "PTP_REL", "PTP", "PUBLIC", "REAL", "REPEAT", "RETURN", "SEC", "SIGNAL", "STRUC", "SWITCH", "THEN", "TO",
        "TRIGGER", "TRUE", "UNTIL", "WAIT", "WHEN", "WHILE", "EXOR")),
    JBI: frozenset((
        "JOB", "NAME", "POS", "INST", "NOP", "END", "MOVJ", "MOVL", "MOVC", "MOVS", "IMOV", "CALL", "JUMP", "RET",
        "TIMER", "WAIT", "PAUSE", "DOUT", "DIN", "SET", "TOOL", "ATTR", "COMM", "DATE")),
    FANUC_LS: frozenset((
        "PROG", "ATTR", "MN", "POS", "END", "J", "L", "C", "A", "CALL", "JMP", "LBL", "WAIT", "PAUSE", "ABORT",
        "IF", "SELECT", "ELSE", "FOR", "ENDFOR", "RUN", "UFRAME_NUM", "UTOOL_NUM", "UFRAME", "UTOOL", "PAYLOAD",
        "FINE", "CNT", "OFFSET", "MAIN")),
    URSCRIPT: frozenset((
        "def", "end", "if", "elif", "else", "while", "for", "return", "thread", "run", "kill", "global", "local",
        "and", "or", "not", "xor", "True", "False", "halt", "sec", "native_moves", "certified_replay",
        "use_certified_replay")),
}
#: Languages whose names ignore case (RAPID kernel manual "Identifiers"; KSS "Names"; INFORM and TP names are
#: upper case).
CASE_INSENSITIVE = frozenset((RAPID, KRL, JBI, FANUC_LS))
#: Names a writer declares itself in the program's file, which the program (module, DEF) name must not repeat:
#: RAPID's data and routine names (``rapid``), KRL's .dat points (``krl``).
WRITER_NAMES = {
    RAPID: re.compile(r"(tool_job|wobj_base|main|[jpc]\d+(_\d+)?|speed_[\d_]+|zone_[\d_]+)", re.IGNORECASE),
    KRL: re.compile(r"X[PA]\d+(_\d+)?", re.IGNORECASE),
}
PREFIX = "P_"


def is_reserved(language: str, name: str) -> bool:
    """Whether ``name`` is a reserved word of ``language`` or a name its writer declares (module docstring)."""
    key = name.upper() if language in CASE_INSENSITIVE else name
    taken = WRITER_NAMES.get(language)
    return key in RESERVED_WORDS[language] or bool(taken is not None and taken.fullmatch(name))


def legal_name(language: str, job_name: str) -> str:
    """A legal program name in ``language`` made from ``job_name`` (the rule of the module docstring)."""
    name = re.sub(r"[^A-Za-z0-9_]+", "_", job_name).strip("_")
    if language in (FANUC_LS, JBI):
        name = name.upper()
    if not name[:1].isalpha() or is_reserved(language, name):
        name = f"{PREFIX}{name}"
    return name[:NAME_MAX[language]].rstrip("_")
