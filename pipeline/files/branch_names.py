"""IK branch (configuration) names as a user writes them: a light module (readers validate a name
here without importing the IK algorithms that label solutions, ``pipeline.model.ik.branches``).

Each family of arms the closed form solves has its own names (``pipeline.model.ik.analytic`` tells a
robot's family; ``closed_form`` and ``three_parallel`` define the branches):

* a spherical wrist: a mapping ``{shoulder: front|back, elbow: up|down, wrist: flip|noflip}`` (any
  non-empty subset) or the FANUC-style string "W E S": W = F (flip) or N (noflip), E = U (up) or D
  (down), S = T (front, "toward") or B (back), e.g. "N U T". A label reads "shoulder front, elbow up,
  wrist noflip";
* three parallel axes (the UR family): a mapping ``{shoulder: left|right, elbow: up|down, wrist:
  up|down}`` (any non-empty subset), as UR users name the 8 solutions; no vendor string. A label
  reads "shoulder left, elbow up, wrist down".
"""

from __future__ import annotations

from ..errors import ConfigurationError

#: The families with named configurations (``AnalyticSolver.family``).
SPHERICAL_WRIST, THREE_PARALLEL = "spherical wrist", "three parallel axes"
#: What a family is called in messages.
FAMILY_TITLES = {SPHERICAL_WRIST: "a spherical wrist", THREE_PARALLEL: "the UR family (axes 2, 3, 4 parallel)"}
#: Configuration keys and their values per family, and the spherical wrist's vendor string letters.
CONFIGURATIONS = {
    SPHERICAL_WRIST: {"shoulder": ("front", "back"), "elbow": ("up", "down"), "wrist": ("flip", "noflip")},
    THREE_PARALLEL: {"shoulder": ("left", "right"), "elbow": ("up", "down"), "wrist": ("up", "down")},
}
VENDOR_LETTERS = (("wrist", {"F": "flip", "N": "noflip"}), ("elbow", {"U": "up", "D": "down"}),
                  ("shoulder", {"T": "front", "B": "back"}))


def configuration_names(family: str) -> str:
    """A family's allowed names, for messages: "shoulder front|back, elbow up|down, wrist flip|noflip"."""
    return ", ".join(f"{key} {'|'.join(names)}" for key, names in CONFIGURATIONS[family].items())


def _for_robot(family: str, robot: str) -> str:
    """" for ROBOT (FAMILY: its names)" in a message ("" without a robot name)."""
    return f" for {robot} ({FAMILY_TITLES[family]}: {configuration_names(family)})" if robot else ""


def parse_configuration(value, family: str = SPHERICAL_WRIST, robot: str = "") -> dict[str, str]:
    """A configuration of an arm of ``family`` (``SPHERICAL_WRIST``, ``THREE_PARALLEL``) named ``robot``:
    a mapping of the family's keys and names (any non-empty subset) or, for a spherical wrist, a
    FANUC-style string "W E S" ("N U T"); ConfigurationError says what is wrong and, with a robot
    name, names the robot, its family and the names it allows."""
    allowed = CONFIGURATIONS[family]
    if isinstance(value, str) and family != SPHERICAL_WRIST:
        raise ConfigurationError(f"a configuration{_for_robot(family, robot)} is a mapping, e.g. "
                                 f"{{shoulder: left, elbow: up, wrist: down}}; the vendor string {value!r} names "
                                 f"the branches of {FAMILY_TITLES[SPHERICAL_WRIST]}")
    if isinstance(value, str):
        letters = value.replace(",", " ").upper().split()
        if len(letters) != 3:
            raise ConfigurationError(f"a configuration string has 3 letters, wrist (F|N) elbow (U|D) shoulder (T|B), "
                                     f"e.g. 'N U T'; got {value!r}")
        config = {}
        for letter, (key, names) in zip(letters, VENDOR_LETTERS):
            if letter not in names:
                raise ConfigurationError(f"configuration {value!r}: the {key} letter must be one of "
                                         f"{', '.join(names)} ({', '.join(f'{k}={v}' for k, v in names.items())}), "
                                         f"got {letter!r}")
            config[key] = names[letter]
        return config
    if not isinstance(value, dict) or not value:
        string = " or a string like 'N U T'" if family == SPHERICAL_WRIST else ""
        raise ConfigurationError(f"a configuration{_for_robot(family, robot)} is a mapping of {', '.join(allowed)}"
                                 f"{string}, got {value!r}")
    for key, name in value.items():
        if key not in allowed:
            raise ConfigurationError(f"unknown configuration key {key!r}{_for_robot(family, robot)}; the keys: "
                                     f"{', '.join(allowed)}")
        if name not in allowed[key]:
            raise ConfigurationError(f"configuration {key} must be {' or '.join(allowed[key])}"
                                     f"{_for_robot(family, robot)}, got {name!r}{_other_family(key, name, family)}")
    return dict(value)


def _other_family(key: str, name: str, family: str) -> str:
    """" ('KEY NAME' names a branch of FAMILY)" when another family uses the name ("" otherwise)."""
    for other, keys in CONFIGURATIONS.items():
        if other != family and name in keys.get(key, ()):
            return f" ('{key} {name}' names a branch of {FAMILY_TITLES[other]})"
    return ""


def label_parts(label: str) -> dict[str, str]:
    """"shoulder front, elbow up, wrist noflip" -> {"shoulder": "front", ...} ({} for no label)."""
    return dict(part.split() for part in label.split(", ")) if label else {}


def matches(label: str, config: dict[str, str]) -> bool:
    """Whether a branch label has every part the configuration names."""
    parts = label_parts(label)
    return all(parts.get(key) == name for key, name in config.items())
