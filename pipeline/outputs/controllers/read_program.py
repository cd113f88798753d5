"""One entry to the readers: a controller program's text in any of the five languages -> a job document, with the
timing settings its header marks (``settings_mark``)."""

from __future__ import annotations

from ...errors import ConfigurationError
from .settings_mark import with_part_names, with_signal_names, with_written_settings

#: The program file's suffix (KRL: the .src; its targets are in the .dat beside it) -> its language.
READ_SUFFIXES = {".mod": "rapid", ".ls": "ls", ".jbi": "jbi", ".src": "krl", ".script": "urscript"}


#: What each language selects by a number whose data the file may not hold (a tool, a user frame): the readers'
#: keywords that take it.
SELECTED_BY_NUMBER = {"rapid": ("tool",), "ls": ("tool", "frame"), "jbi": ("tool", "frame"), "krl": ("tool", "frame"),
                      "urscript": ()}


def read_program_text(language: str, text: str, robot, source: str, dat: str | None = None,
                      dat_source: str = "<dat>", tool=None, frame=None) -> dict:
    """The job document (SI lengths, angles in degrees) of the program ``text`` in ``language`` (rapid, ls, jbi,
    krl with its ``dat``, urscript) for ``robot`` (a preset name, robot file or Robot); ``source`` names it in
    errors (FileFormatError from the readers); ``tool``: X_FT (4, 4) [m] of the tool the program selects by number
    without its data, ``frame``: the user frame (base) it selects so, in the robot's base frame (4, 4) [m] (None: not
    given; ConfigurationError for a language that selects none so)."""
    from .read_jbi import read_jbi
    from .read_krl import read_krl
    from .read_ls import read_ls
    from .read_rapid import read_rapid
    from .read_urscript import read_urscript

    extra = {key: value for key, value in (("tool", tool), ("frame", frame)) if value is not None}
    for key in extra:
        if key not in SELECTED_BY_NUMBER[language]:
            raise ConfigurationError(f"--{key}: a {language} program does not select a {key} by number (its data are "
                                     f"in the program itself); leave --{key} out")
    readers = {"rapid": lambda: read_rapid(text, robot, source=source, **extra),
               "ls": lambda: read_ls(text, robot, source=source, **extra),
               "jbi": lambda: read_jbi(text, robot, source=source, **extra),
               "krl": lambda: read_krl(text, dat, robot, source, dat_source, **extra),
               "urscript": lambda: read_urscript(text, robot, source)}
    return with_part_names(with_signal_names(with_written_settings(readers[language](), text), text), text)
