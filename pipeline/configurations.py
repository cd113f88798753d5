"""IK branch (configuration) names as a user writes them: a light module (readers validate a name
here without importing the IK algorithms that label solutions, ``pipeline.ik.branches``).

A configuration is a mapping ``{shoulder: front|back, elbow: up|down, wrist: flip|noflip}`` (any
non-empty subset) or the FANUC-style string "W E S": W = F (flip) or N (noflip), E = U (up) or D
(down), S = T (front, "toward") or B (back), e.g. "N U T". A branch label reads "shoulder front,
elbow up, wrist noflip".
"""

from __future__ import annotations

from .errors import ConfigurationError

#: Configuration keys and their values, and the vendor string's letters for each.
CONFIGURATION = {"shoulder": ("front", "back"), "elbow": ("up", "down"), "wrist": ("flip", "noflip")}
VENDOR_LETTERS = (("wrist", {"F": "flip", "N": "noflip"}), ("elbow", {"U": "up", "D": "down"}),
                  ("shoulder", {"T": "front", "B": "back"}))


def parse_configuration(value) -> dict[str, str]:
    """A configuration from a mapping ``{shoulder: front|back, elbow: up|down, wrist: flip|noflip}``
    (any non-empty subset) or a FANUC-style string "W E S" ("N U T"); ConfigurationError says what is
    wrong."""
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
        raise ConfigurationError(f"a configuration is a mapping of {', '.join(CONFIGURATION)} or a string like "
                                 f"'N U T', got {value!r}")
    for key, name in value.items():
        if key not in CONFIGURATION:
            raise ConfigurationError(f"unknown configuration key {key!r}; the keys: {', '.join(CONFIGURATION)}")
        if name not in CONFIGURATION[key]:
            raise ConfigurationError(f"configuration {key} must be {' or '.join(CONFIGURATION[key])}, got {name!r}")
    return dict(value)


def label_parts(label: str) -> dict[str, str]:
    """"shoulder front, elbow up, wrist noflip" -> {"shoulder": "front", ...} ({} for no label)."""
    return dict(part.split() for part in label.split(", ")) if label else {}


def matches(label: str, config: dict[str, str]) -> bool:
    """Whether a branch label has every part the configuration names."""
    parts = label_parts(label)
    return all(parts.get(key) == name for key, name in config.items())
