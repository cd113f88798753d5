"""Structural checks of FANUC ``.ls``, Yaskawa ``.jbi`` and URScript files, written from the vendors' manuals and
real pendant files, independently of the package's writers, readers and lark grammars (no open parser of these
languages exists). Each rule is one function returning the problems it finds (``"line N: ..."``, empty when the
file passes), with its source in its docstring; ``ls_problems``, ``jbi_problems`` and ``urscript_problems`` run
every rule of a language. Sources marked "unverified" are third-party pages or our reading, not a vendor's manual.

Sources cited below:

* [NX100] Yaskawa Motoman NX100 operator's manual (HW0481924), 4.1 "Job Data Format", pp. 4-3 to 4-5
  (easymanua.ls/motoman/nx100/manual/228196?p=41 and ?p=43).
* [DX100] Yaskawa Motoman DX100 operator's manual, 4.1 (easymanua.ls/yaskawa/motoman-dx100/manual?p=37): RCONF's
  fields after the NX100's six are "unused".
* [motoman#142] ros-industrial/motoman issue 142: "ERROR 3200: NOP or END instruction not found" on loading a job.
* [LS-files] real pendant ``.ls`` files on GitHub: gavanderhoorn/fanuc_driver_exp ``src/ros_movesm.ls`` and
  JuniorNatalin/VASC ``.../kjltvl411550r01/english/up222.ls`` (``/PROG  UP222``, ``/ATTR`` with ``LINE_COUNT``,
  ``DEFAULT_GROUP = 1,1,1,1,*;``, ``/MN`` opening with ``   1:  UFRAME_NUM=0 ;`` ``   2:  UTOOL_NUM=2 ;``, motion lines
  ``   5:J P[1] 100% CNT0 ...;``, circular moves as ``C P[i]`` with ``:  P[j] speed term ;`` on the next line).
* [INTP-250] a FANUC alarm of the INTP family, "user frame number mismatch", when a point's UF is not the active
  ``UFRAME_NUM`` (third-party knowledge-base page, unverified; for UT likewise, unverified).
* [UR] Universal Robots' URScript manual: a program is a script of ``def``/``thread``/``if``/``while`` blocks closed
  by ``end``; a script sent to the controller that is one ``def name(): ... end`` is run as a program (unverified
  for a file pasted into a Script node, which only defines the function unless the file calls it).
"""

from __future__ import annotations

import datetime as dt
import itertools
import re

# ----------------------------------------------------------------------------------------------------------------
# FANUC LS
# ----------------------------------------------------------------------------------------------------------------

#: The sections of an ``.ls`` in their order (/APPL optional) [LS-files].
LS_SECTIONS = ("/PROG", "/ATTR", "/APPL", "/MN", "/POS", "/END")
#: A program name: an upper-case letter, then upper-case letters, digits or _, at most 8 characters: the limit of
#: the controllers before the R-30iA (R-J3iB operator's manual; later ones take longer names, unverified), which our
#: writers keep so that a program loads on every generation.
LS_NAME = re.compile(r"[A-Z][A-Z0-9_]{0,7}")
#: A motion instruction's target: P[n] or P[n:comment] (a position register PR[...] is not a target of ours).
_P = r"P\[(\d+)(?::[^\]]*)?\]"
#: Speeds: J in % (1..100), L and C in mm/sec (and the other units the pendant offers) [LS-files].
_LS_TERM = r"(FINE|CNT(\d+))"
LS_JOINT = re.compile(rf"J\s+{_P}\s+(\d+)%\s+{_LS_TERM}(\s+[^;]*)?\s*;")
LS_LINEAR = re.compile(rf"L\s+{_P}\s+(\d+(?:\.\d+)?)(mm/sec|cm/min|inch/min|deg/sec|sec|msec)\s+{_LS_TERM}(\s+[^;]*)?\s*;")
LS_CIRC_START = re.compile(rf"C\s+{_P}\s*")
LS_CIRC_END = re.compile(rf"{_P}\s+(\d+(?:\.\d+)?)(mm/sec|cm/min|inch/min|deg/sec|sec|msec)\s+{_LS_TERM}(\s+[^;]*)?\s*;")
#: CONFIG of a Cartesian point: 'F/N U/D T/B, turn J1, turn J4, turn J6' [LS-files; R-30iA operator's manual,
#: "Configuration"].
LS_CONFIG = re.compile(r"'[NF] [UD] [TB], -?\d+, -?\d+, -?\d+'")
#: Comment lines (!...) of at most 32 characters (FANUC TP comment length; unverified against a manual here).
LS_COMMENT_MAX = 32


def _ls_sections(text: str) -> tuple[dict[str, list[tuple[int, str]]], list[str]]:
    """(section -> its (line number, line) pairs after the section's own line, problems of the section order)."""
    sections: dict[str, list[tuple[int, str]]] = {}
    problems, current, order = [], None, []
    for number, line in enumerate(text.splitlines(), start=1):
        head = line.split()[0] if line.strip() else ""
        if head in LS_SECTIONS:
            if head in sections:
                problems.append(f"line {number}: {head} a second time")
            sections[head] = [(number, line)]
            order.append(head)
            current = head
        elif current is not None:
            sections[current].append((number, line))
    expected = [s for s in LS_SECTIONS if s in order]
    if order != expected:
        problems.append(f"sections in the order {order}, expected {expected} ({' '.join(LS_SECTIONS)}; /APPL optional)")
    for required in ("/PROG", "/ATTR", "/MN", "/POS", "/END"):
        if required not in sections:
            problems.append(f"no {required} section")
    return sections, problems


def ls_prog_line(text: str) -> list[str]:
    """Rule: the first line is ``/PROG  NAME`` and NAME is a program name (``LS_NAME``) [LS-files]."""
    first = text.splitlines()[0] if text else ""
    match = re.fullmatch(r"/PROG\s+(\S+)(\s+Macro)?\s*", first)
    if match is None:
        return [f"line 1: {first!r} is not '/PROG  NAME'"]
    if not LS_NAME.fullmatch(match.group(1)):
        return [(f"line 1: program name {match.group(1)!r}: 1-8 characters, an upper-case letter, then upper-case "
                 "letters, digits or _")]
    return []


def ls_sections(text: str) -> list[str]:
    """Rule: /PROG, /ATTR, (/APPL), /MN, /POS, /END, each once, in that order, /END the last non-blank line
    [LS-files]."""
    _, problems = _ls_sections(text)
    lines = [line for line in text.splitlines() if line.strip()]
    if not lines or lines[-1].strip() != "/END":
        problems.append(f"the last line is {lines[-1] if lines else ''!r}, not /END")
    return problems


def _ls_instructions(text: str) -> tuple[list[tuple[int, int, str]], list[str]]:
    """/MN's instructions as (line number in the file, instruction number, text after the colon, continuation
    lines joined with a space), and the problems of the numbering: numbered 1, 2, ... consecutively, each
    instruction (with its continuation lines ``   :  ...``) ending in ``;`` [LS-files]."""
    sections, _ = _ls_sections(text)
    instructions, problems = [], []
    for number, line in sections.get("/MN", [])[1:]:
        if not line.strip():
            continue
        numbered = re.fullmatch(r"\s*(\d+):(.*)", line)
        continued = re.fullmatch(r"\s*:(.*)", line)
        if numbered:
            instructions.append((number, int(numbered.group(1)), numbered.group(2).strip()))
        elif continued and instructions:
            at, n, body = instructions[-1]
            instructions[-1] = (at, n, f"{body} {continued.group(1).strip()}")
        else:
            problems.append(f"line {number}: {line!r} is neither '   N:  instruction' nor a continuation '   :  ...'")
    for k, (number, n, body) in enumerate(instructions, start=1):
        if n != k:
            problems.append(f"line {number}: instruction numbered {n}, expected {k} (numbered 1, 2, ... in order)")
        if not body.endswith(";"):
            problems.append(f"line {number}: instruction {n} {body!r} does not end with ';'")
    return instructions, problems


def ls_numbering(text: str) -> list[str]:
    """Rule: /MN's lines are numbered 1, 2, ... consecutively, every instruction ends with ``;``, and /ATTR's
    ``LINE_COUNT`` is their number [LS-files: LINE_COUNT equals the /MN lines]."""
    instructions, problems = _ls_instructions(text)
    count = re.search(r"^\s*LINE_COUNT\s*=\s*(\d+)\s*;", text, re.MULTILINE)
    if count is None:
        problems.append("/ATTR has no LINE_COUNT")
    elif int(count.group(1)) != len(instructions):
        problems.append(f"LINE_COUNT = {count.group(1)}, /MN has {len(instructions)} instructions")
    return problems


def _ls_motion(body: str) -> tuple[str, list[int]] | None:
    """(kind J/L/C, its P numbers) of a motion instruction, or None for another instruction; ValueError with the
    reason for a motion instruction that is not one of the forms of LS_JOINT, LS_LINEAR, LS_CIRC_*."""
    if not re.match(r"[JLC]\s+P", body):
        return None
    kind = body[0]
    if kind == "J":
        match = LS_JOINT.fullmatch(body)
        if match is None:
            raise ValueError("not 'J P[n] v% FINE|CNTn ;'")
        speed, cnt = int(match.group(2)), match.group(4)
        if not 1 <= speed <= 100 or (cnt is not None and not 0 <= int(cnt) <= 100):
            raise ValueError("J speed 1-100 %, CNT 0-100")
        return kind, [int(match.group(1))]
    if kind == "L":
        match = LS_LINEAR.fullmatch(body)
        if match is None:
            raise ValueError("not 'L P[n] v mm/sec FINE|CNTn ;'")
        if match.group(5) is not None and not 0 <= int(match.group(5)) <= 100:
            raise ValueError("CNT 0-100")
        return kind, [int(match.group(1))]
    start = LS_CIRC_START.match(body)
    end = LS_CIRC_END.fullmatch(body[start.end():]) if start else None
    if end is None:
        raise ValueError("not 'C P[via]' with ':  P[end] v mm/sec FINE|CNTn ;' on the next line")
    return kind, [int(start.group(1)), int(end.group(1))]


def _ls_points(text: str) -> tuple[dict[int, list[tuple[int, str]]], list[str]]:
    """/POS's points: number -> its blocks as (line, text from ``P[n]{`` to ``};``); problems of the block form."""
    sections, _ = _ls_sections(text)
    lines = sections.get("/POS", [])[1:]
    points: dict[int, list[tuple[int, str]]] = {}
    problems, k = [], 0
    while k < len(lines):
        number, line = lines[k]
        head = re.fullmatch(rf"\s*{_P}\s*\{{\s*", line)
        if head is None:
            if line.strip():
                problems.append(f"line {number}: {line!r} outside a 'P[n]{{ ... }};' block")
            k += 1
            continue
        block = []
        while k < len(lines) and not lines[k][1].strip().startswith("};"):
            block.append(lines[k][1])
            k += 1
        if k == len(lines):
            problems.append(f"line {number}: P[{head.group(1)}] not closed by '}};'")
        points.setdefault(int(head.group(1)), []).append((number, "\n".join(block)))
        k += 1
    return points, problems


def ls_motions_and_points(text: str) -> list[str]:
    """Rules: every motion instruction is ``J P[n] v% FINE|CNTn ;``, ``L P[n] v mm/sec FINE|CNTn ;`` or
    ``C P[via]`` / ``:  P[end] v mm/sec FINE|CNTn ;`` [LS-files], every P[n] a motion uses is defined in /POS
    exactly once, and every point is ``GP1:`` with ``UF : u, UT : t`` and either ``CONFIG : '...'`` (``LS_CONFIG``)
    with X Y Z (mm) W P R (deg), or J1..J6 (deg) [LS-files; R-30iA operator's manual, "Position data"]."""
    instructions, _ = _ls_instructions(text)
    points, problems = _ls_points(text)
    used = set()
    for number, n, body in instructions:
        try:
            motion = _ls_motion(body)
        except ValueError as exc:
            problems.append(f"line {number}: motion {body!r}: {exc}")
            continue
        if motion is not None:
            used.update(motion[1])
    for p in sorted(used):
        if len(points.get(p, [])) != 1:
            problems.append(f"P[{p}] is used in /MN and defined {len(points.get(p, []))} times in /POS (once)")
    for p, blocks in sorted(points.items()):
        for number, block in blocks:
            if not re.search(r"^\s*GP1:", block, re.MULTILINE):
                problems.append(f"line {number}: P[{p}] has no GP1: group")
            if not re.search(r"UF\s*:\s*\d+\s*,\s*UT\s*:\s*\d+", block):
                problems.append(f"line {number}: P[{p}] has no 'UF : u, UT : t'")
            cartesian = all(re.search(rf"\b{axis}\s*=\s*-?\d+\.\d+\s+{unit}", block)
                            for axis, unit in zip("XYZWPR", ["mm"] * 3 + ["deg"] * 3))
            joints = all(re.search(rf"\bJ{i}\s*=\s*-?\d+\.\d+\s+deg", block) for i in range(1, 7))
            config = re.search(r"CONFIG\s*:\s*('[^']*')", block)
            if cartesian and (config is None or not LS_CONFIG.fullmatch(config.group(1))):
                problems.append(f"line {number}: Cartesian P[{p}] without a CONFIG : 'F/N U/D T/B, t1, t4, t6' "
                                f"({config.group(1) if config else 'none'})")
            if cartesian == joints:
                problems.append(f"line {number}: P[{p}] is neither X Y Z W P R (mm, deg) nor J1..J6 (deg)")
    return problems


#: The /MN instruction that selects each frame -> the point field that names it.
FIELD = {"UFRAME_NUM": "UF", "UTOOL_NUM": "UT"}


def ls_frames(text: str) -> list[str]:
    """Rule: each point a motion uses has ``UF : u, UT : t`` equal to the ``UFRAME_NUM=u`` and ``UTOOL_NUM=t``
    selected in /MN before that motion: a program selects its frames (real programs open /MN with them
    [LS-files]); otherwise the controller runs it in whatever frames are active, and a point whose UF/UT is not
    the active one stops with an INTP alarm [INTP-250, unverified]."""
    instructions, _ = _ls_instructions(text)
    points, _ = _ls_points(text)
    frames: dict[str, str | None] = {"UFRAME_NUM": None, "UTOOL_NUM": None}
    problems = []
    for number, n, body in instructions:
        selected = re.fullmatch(r"(UFRAME_NUM|UTOOL_NUM)\s*=\s*(\d+)\s*;", body)
        if selected:
            frames[selected.group(1)] = selected.group(2)
            continue
        try:
            motion = _ls_motion(body)
        except ValueError:
            continue
        if motion is None:
            continue
        for p in motion[1]:
            for _, block in points.get(p, [])[:1]:
                uf_ut = re.search(r"UF\s*:\s*(\d+)\s*,\s*UT\s*:\s*(\d+)", block)
                if uf_ut is None:
                    continue
                for key, value in zip(("UFRAME_NUM", "UTOOL_NUM"), uf_ut.groups()):
                    if frames[key] is None:
                        problems.append(f"no {key}= selected in /MN before the first motion that needs it (line "
                                        f"{number}: P[{p}] has {FIELD[key]} : {value})")
                        frames[key] = "unselected"      # reported once
                    elif frames[key] not in (value, "unselected"):
                        problems.append(f"line {number}: P[{p}] is in {key}={value}, the active {key} is "
                                        f"{frames[key]}")
    return sorted(set(problems), key=problems.index)


def ls_header(text: str) -> list[str]:
    """Rule: /ATTR's ``DEFAULT_GROUP`` enables motion group 1 (``1,*,*,*,*``) when /MN moves the robot
    [LS-files], and every comment line ``!...`` is at most ``LS_COMMENT_MAX`` characters (unverified)."""
    problems = []
    instructions, _ = _ls_instructions(text)
    moves = any(re.match(r"[JLC]\s+P", body) for _, _, body in instructions)
    group = re.search(r"^\s*DEFAULT_GROUP\s*=\s*([^;]*);", text, re.MULTILINE)
    if moves and (group is None or group.group(1).split(",")[0].strip() != "1"):
        problems.append(f"DEFAULT_GROUP {group.group(1) if group else 'missing'}: group 1 must be on to move the robot")
    for number, n, body in instructions:
        if body.startswith("!"):
            comment = body[1:].rstrip(";").rstrip()
            if len(comment) > LS_COMMENT_MAX:
                problems.append(f"line {number}: comment of {len(comment)} characters (at most {LS_COMMENT_MAX})")
    return problems


LS_RULES = (ls_prog_line, ls_sections, ls_numbering, ls_motions_and_points, ls_frames, ls_header)


def ls_problems(text: str) -> list[str]:
    """Every LS rule's problems, each prefixed with its rule."""
    return [f"{rule.__name__}: {problem}" for rule in LS_RULES for problem in rule(text)]


# ----------------------------------------------------------------------------------------------------------------
# Yaskawa JBI (INFORM)
# ----------------------------------------------------------------------------------------------------------------

#: A job name: at most 8 characters [NX100 4.1.2]; upper-case letters, digits and _ (the characters every
#: controller's keyboard offers; our subset).
JBI_NAME = re.compile(r"[A-Z0-9_]{1,8}")
#: ///COMM and every comment instruction (') at most 32 characters [NX100 4.1.4 COMM; comments: NX100 4.1 as cited
#: by the project's vendor notes, unverified for ' lines].
JBI_COMMENT_MAX = 32
JBI_POSTYPES = {"PULSE", "BASE", "ROBOT", "TOOL", "USER", "MTOOL"}             # [NX100 4.1.3 POSTYPE]
JBI_ATTRIBUTES = {"JD", "DD", "SC", "RO", "WO", "RW", "RJ"}                     # [NX100 4.1.4 ATTR]
_NUMBER = r"-?\d+(?:\.\d+)?"
JBI_MOVE = re.compile(r"(MOVJ|MOVL|MOVC|MOVS)\s+(C\d{5}|P\d{3,4})(.*)")


def _jbi_parts(text: str) -> tuple[list[tuple[int, str]], list[tuple[int, str]]]:
    """(the //POS part, the //INST part) as (line number, line) pairs, each after its own line."""
    pos, inst, current = [], [], None
    for number, line in enumerate(text.splitlines(), start=1):
        if line.strip() == "//POS":
            current = pos
        elif line.strip() == "//INST":
            current = inst
        elif current is not None:
            current.append((number, line))
    return pos, inst


def jbi_header(text: str) -> list[str]:
    """Rules: ``/JOB`` first, ``//NAME name`` second (``JBI_NAME``), then ``//POS`` and ``//INST`` in that order
    [NX100 4.1.1-4.1.4]."""
    lines = text.splitlines()
    problems = []
    if not lines or lines[0].strip() != "/JOB":
        problems.append(f"line 1: {lines[0] if lines else ''!r}, not /JOB")
    name = re.fullmatch(r"//NAME (\S+)\s*", lines[1]) if len(lines) > 1 else None
    if name is None:
        problems.append("line 2: not '//NAME name'")
    elif not JBI_NAME.fullmatch(name.group(1)):
        problems.append(f"line 2: job name {name.group(1)!r}: at most 8 characters, A-Z 0-9 _")
    heads = [line.strip() for line in lines if line.strip() in ("//POS", "//INST")]
    if heads != ["//POS", "//INST"]:
        problems.append(f"sections {heads}, expected ['//POS', '//INST'] once each")
    return problems


def jbi_positions(text: str) -> list[str]:
    """Rules of //POS [NX100 4.1.3]: ``///NPOS C,BC,EC,P,BP,EX`` first, its counts those of the robot teaching
    positions ``Cnnnnn=`` and position variables ``Pnnnn=`` defined (no base or station axes here: BC = EC = BP =
    EX = 0); ``///TOOL n`` (and ``///USER n``) with n 0..23; ``///POSTYPE`` one of PULSE BASE ROBOT TOOL USER MTOOL
    before the first position, USER only with ``///USER``; Cartesian positions after ``///RECTAN`` and a
    ``///RCONF`` whose first six fields (flip, upper/lower arm, front/rear, R, T, S >= 180) are 0 or 1 and the
    rest 0 ("unused" [DX100]), each of six numbers (mm, deg); pulse positions of integers; each C defined once."""
    pos, _ = _jbi_parts(text)
    problems, defined_c, defined_p = [], {}, {}
    npos = postype = rconf = user = None
    rectan = False
    for number, line in pos:
        key = line.split()[0] if line.strip() else ""
        if key == "///NPOS":
            npos = (number, line.split(None, 1)[1] if len(line.split()) > 1 else "")
        elif key in ("///TOOL", "///USER"):
            value = line.split()[1] if len(line.split()) > 1 else ""
            if not (value.isdigit() and 0 <= int(value) <= 23):
                problems.append(f"line {number}: {key} {value!r}: 0 to 23")
            if key == "///USER":
                user = value
        elif key == "///POSTYPE":
            postype = line.split()[1] if len(line.split()) > 1 else ""
            if postype not in JBI_POSTYPES:
                problems.append(f"line {number}: ///POSTYPE {postype!r}: one of {sorted(JBI_POSTYPES)}")
            if postype == "USER" and user is None:
                problems.append(f"line {number}: ///POSTYPE USER without ///USER")
        elif key == "///RECTAN":
            rectan = True
        elif key == "///RCONF":
            fields = line.split()[1].split(",") if len(line.split()) > 1 else []
            if len(fields) < 6 or not all(f in ("0", "1") for f in fields[:6]) or any(f != "0" for f in fields[6:]):
                problems.append(f"line {number}: ///RCONF {','.join(fields)}: six fields of 0 or 1, then 0s")
            rconf = fields
        elif re.match(r"[CP]\d+=", line):
            name, values = line.split("=", 1)
            target = defined_c if name.startswith("C") else defined_p
            if not re.fullmatch(r"C\d{5}|P\d{3,4}", name):
                problems.append(f"line {number}: position name {name!r}: C and 5 digits, or P and 3-4 digits")
            if name in target:
                problems.append(f"line {number}: {name} defined a second time")
            target[name] = number
            numbers = values.split(",")
            if postype is None:
                problems.append(f"line {number}: {name} before any ///POSTYPE")
            elif postype == "PULSE":
                if not all(re.fullmatch(r"-?\d+", v) for v in numbers):
                    problems.append(f"line {number}: pulse data of integers expected, {values!r}")
            else:
                if not rectan or rconf is None:
                    problems.append(f"line {number}: Cartesian {name} without ///RECTAN and ///RCONF before it")
                if len(numbers) != 6 or not all(re.fullmatch(_NUMBER, v) for v in numbers):
                    problems.append(f"line {number}: {name} needs six numbers X,Y,Z,Rx,Ry,Rz, has {values!r}")
        elif line.strip():
            problems.append(f"line {number}: {line!r} is no //POS line")
    if npos is None:
        problems.append("//POS has no ///NPOS")
    else:
        counts = npos[1].split(",")
        expected = [len(defined_c), 0, 0, len(defined_p), 0, 0]
        if [c.strip() for c in counts] != [str(c) for c in expected]:
            problems.append(f"line {npos[0]}: ///NPOS {npos[1]}, the positions defined give "
                            f"{','.join(map(str, expected))}")
    if "///TOOL" not in {line.split()[0] for _, line in pos if line.strip()}:
        problems.append("//POS has no ///TOOL")
    return problems


def _jbi_instructions(text: str) -> tuple[list[tuple[int, str]], list[str]]:
    """(//INST's instructions after its /// header lines as (line number, line), problems of that header:
    ``///DATE YYYY/MM/DD HH:MM``, ``///COMM`` of at most 32 characters, ``///ATTR`` of JD DD SC RO WO RW RJ,
    ``///GROUP1`` naming the robot) [NX100 4.1.4]."""
    _, inst = _jbi_parts(text)
    problems, instructions, seen = [], [], set()
    for number, line in inst:
        if line.startswith("///") and not instructions:
            key, _, value = line.partition(" ")
            seen.add(key)
            if key == "///DATE":
                try:
                    dt.datetime.strptime(value.strip(), "%Y/%m/%d %H:%M")
                except ValueError:
                    problems.append(f"line {number}: ///DATE {value!r} is not YYYY/MM/DD HH:MM")
            elif key == "///COMM" and len(value) > JBI_COMMENT_MAX:
                problems.append(f"line {number}: ///COMM of {len(value)} characters (at most {JBI_COMMENT_MAX})")
            elif key == "///ATTR" and not set(value.strip().split(",")) <= JBI_ATTRIBUTES:
                problems.append(f"line {number}: ///ATTR {value!r}: of {sorted(JBI_ATTRIBUTES)}")
            elif key == "///GROUP1" and not re.fullmatch(r"RB\d", value.strip()):
                problems.append(f"line {number}: ///GROUP1 {value!r}: the robot, RB1")
        elif line.strip():
            instructions.append((number, line.strip()))
    for key in ("///DATE", "///ATTR", "///GROUP1"):
        if key not in seen:
            problems.append(f"//INST has no {key}")
    return instructions, problems


def jbi_instructions(text: str) -> list[str]:
    """Rules: //INST's header (``_jbi_instructions``); ``NOP`` the first instruction and ``END`` the last, nothing
    after it [NX100 job examples; motoman#142]; every MOVJ/MOVL/MOVC refers to a defined Cnnnnn (or Pnnnn) and every
    C defined is used (an unused C is load error 3190, third-party, unverified); PL 0..8 (positioning levels);
    comment instructions (') of at most 32 characters."""
    instructions, problems = _jbi_instructions(text)
    if not instructions or instructions[0][1] != "NOP":
        problems.append(f"the first instruction is {instructions[0][1] if instructions else None!r}, not NOP")
    if not instructions or instructions[-1][1] != "END":
        problems.append(f"the last instruction is {instructions[-1][1] if instructions else None!r}, not END")
    pos, _ = _jbi_parts(text)
    defined = {line.split("=", 1)[0] for _, line in pos if re.match(r"[CP]\d+=", line)}
    used = set()
    for number, line in instructions:
        move = JBI_MOVE.fullmatch(line)
        if line.startswith("'"):
            if len(line) - 1 > JBI_COMMENT_MAX:
                problems.append(f"line {number}: comment of {len(line) - 1} characters (at most {JBI_COMMENT_MAX})")
        elif line.startswith("MOV"):
            if move is None:
                problems.append(f"line {number}: {line!r} is not 'MOVx Cnnnnn ...'")
                continue
            used.add(move.group(2))
            if move.group(2) not in defined:
                problems.append(f"line {number}: {move.group(2)} is not defined in //POS")
            level = re.search(r"\bPL=(\S+)", move.group(3))
            if level and not (level.group(1).isdigit() and 0 <= int(level.group(1)) <= 8):
                problems.append(f"line {number}: PL={level.group(1)}: 0 to 8")
    for name in sorted({d for d in defined if d.startswith("C")} - used):
        problems.append(f"{name} is defined and never used by a move")
    return problems


def _jbi_moves(text: str) -> list[tuple[int, str, str, str]]:
    """Every move instruction as (line number, MOVJ/MOVL/MOVC/MOVS, position name, the rest)."""
    instructions, _ = _jbi_instructions(text)
    return [(number, *JBI_MOVE.fullmatch(line).groups()) for number, line in instructions
            if JBI_MOVE.fullmatch(line)]


def jbi_circles(text: str) -> list[str]:
    """Rule: MOVC comes in groups of three consecutive points: the arc's start, a point on it and its end; two
    arcs in a row share a point and mark it with FPT on the MOVC where the first ends, so a run of consecutive MOVC
    is 3 points, or 3 + 2k with FPT on its 3rd, 5th, ... (Yaskawa NX100/DX100 operator's manuals, "Circular
    Interpolation": the arc through three points, continuous arcs separated by FPT; our reading, page not
    checked here)."""
    problems, run = [], []
    moves = _jbi_moves(text) + [(0, "END", "", "")]
    for number, kind, name, rest in moves:
        if kind == "MOVC":
            run.append((number, rest))
            continue
        if run:
            size = len(run)
            ends = [k for k, (_, r) in enumerate(run, start=1) if re.search(r"\bFPT\b", r)]
            if size < 3 or size % 2 == 0 or ends != list(range(3, size, 2)):
                problems.append(f"line {run[0][0]}: {size} consecutive MOVC (FPT on {ends}): an arc is 3 points; "
                                f"continuous arcs 3 + 2k with FPT on the 3rd, 5th, ...")
            run = []
    return problems


def jbi_zones_into_zero_length(text: str) -> list[str]:
    """Rule: no move with a positioning level PL > 0 is followed by a move to the same position as written (a
    zero-length move, e.g. a MOVC arc start equal to the point before it): the level asks the controller to
    round the corner towards the next move, and a zero-length next move has no path to round into; the corner
    is then undefined (issue 35's defect "zone into zero-length MOVC"; our reading of PL [NX100 INFORM, "PL
    position level"], unverified)."""
    pos, _ = _jbi_parts(text)
    values = {line.split("=", 1)[0]: tuple(float(v) for v in line.split("=", 1)[1].split(","))
              for _, line in pos if re.match(r"[CP]\d+=", line)}
    problems = []
    moves = _jbi_moves(text)
    for (number, kind, name, rest), (_, next_kind, next_name, _) in itertools.pairwise(moves):
        level = re.search(r"\bPL=(\d+)", rest)
        if level and int(level.group(1)) > 0 and name in values and values.get(next_name) == values[name]:
            problems.append(f"line {number}: {kind} {name} PL={level.group(1)} into {next_kind} {next_name} at the "
                            "same position (a zero-length move)")
    return problems


JBI_RULES = (jbi_header, jbi_positions, jbi_instructions, jbi_circles, jbi_zones_into_zero_length)


def jbi_problems(text: str) -> list[str]:
    """Every JBI rule's problems, each prefixed with its rule."""
    return [f"{rule.__name__}: {problem}" for rule in JBI_RULES for problem in rule(text)]


# ----------------------------------------------------------------------------------------------------------------
# URScript
# ----------------------------------------------------------------------------------------------------------------

_UR_OPENS = re.compile(r"(def|thread|if|while|for)\b.*:\s*(#.*)?")
_UR_CONTINUES = re.compile(r"(elif\b.*|else\s*):\s*(#.*)?")


def _ur_top_level(text: str) -> tuple[list[tuple[int, str]], list[str]]:
    """(the top-level statements, each block as its opening line, problems of the block structure: every
    ``def``/``thread``/``if``/``while``/``for ...:`` closed by its ``end``) [UR]."""
    depth, top, problems = 0, [], []
    for number, line in enumerate(text.splitlines(), start=1):
        code = line.strip()
        if not code or code.startswith("#"):
            continue
        if _UR_CONTINUES.fullmatch(code):
            if depth == 0:
                problems.append(f"line {number}: {code!r} outside an if")
            continue
        if depth == 0:
            top.append((number, code))
        if _UR_OPENS.fullmatch(code):
            depth += 1
        elif code == "end":
            depth -= 1
            if depth < 0:
                problems.append(f"line {number}: 'end' closes no block")
                depth = 0
    if depth:
        problems.append(f"{depth} block(s) not closed by 'end' at the end of the file")
    return [(n, c) for n, c in top if c != "end"], problems


def urscript_runs(text: str) -> list[str]:
    """Rule: the program runs its motion: either the file is one top-level function (``def name(): ... end``,
    which the controller runs when the file is sent as a program [UR]), or it calls a function it defines at the
    top level after defining it (so it also runs where the file is only inserted, e.g. a Script node) [UR]."""
    top, problems = _ur_top_level(text)
    defs = {re.match(r"def\s+(\w+)", c).group(1): n for n, c in top if c.startswith("def ")}
    others = [(n, c) for n, c in top if not c.startswith("def ")]
    if not defs:
        return problems + ["no top-level function"]
    if len(defs) == 1 and not others:
        return problems
    called = [(n, c) for n, c in others if re.fullmatch(r"(\w+)\(\s*\)", c) and c.split("(")[0] in defs
              and n > defs[c.split("(")[0]]]
    if not called:
        problems.append(f"top-level functions {sorted(defs)} beside other top-level lines "
                        f"{[c for _, c in others][:3]}, and none is called after its definition")
    return problems


def urscript_replay_guard(text: str, max_replay_lines: int) -> list[str]:
    """Rule: at most ``max_replay_lines`` servoj lines (the writer's guard, ``urscript.MAX_REPLAY_LINES``: the
    size a controller and read-program are known to take)."""
    count = sum(1 for line in text.splitlines() if line.strip().startswith("servoj("))
    return [f"{count} servoj lines, more than {max_replay_lines}"] if count > max_replay_lines else []


def urscript_problems(text: str, max_replay_lines: int) -> list[str]:
    """Every URScript rule's problems, each prefixed with its rule."""
    return ([f"urscript_runs: {p}" for p in urscript_runs(text)]
            + [f"urscript_replay_guard: {p}" for p in urscript_replay_guard(text, max_replay_lines)])
