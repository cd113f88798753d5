"""One entry to the readers: a controller program's text in any of the five languages -> a job document, with the
timing settings its header marks (``settings_mark``)."""

from __future__ import annotations

from .settings_mark import with_signal_names, with_written_settings

#: The program file's suffix (KRL: the .src; its targets are in the .dat beside it) -> its language.
READ_SUFFIXES = {".mod": "rapid", ".ls": "ls", ".jbi": "jbi", ".src": "krl", ".script": "urscript"}


def read_program_text(language: str, text: str, robot, source: str, dat: str | None = None,
                      dat_source: str = "<dat>") -> dict:
    """The job document (SI lengths, angles in degrees) of the program ``text`` in ``language`` (rapid, ls, jbi,
    krl with its ``dat``, urscript) for ``robot`` (a preset name, robot file or Robot); ``source`` names it in
    errors (FileFormatError from the readers)."""
    from .read_jbi import read_jbi
    from .read_krl import read_krl
    from .read_ls import read_ls
    from .read_rapid import read_rapid
    from .read_urscript import read_urscript

    readers = {"rapid": lambda: read_rapid(text, robot), "ls": lambda: read_ls(text, robot, source=source),
               "jbi": lambda: read_jbi(text, robot, source=source),
               "krl": lambda: read_krl(text, dat, robot, source, dat_source),
               "urscript": lambda: read_urscript(text, robot, source)}
    return with_signal_names(with_written_settings(readers[language](), text), text)
