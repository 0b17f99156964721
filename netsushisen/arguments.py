"""The Python API's argument checks: a wrong type or value is the API's own error, at once.

A notebook user who writes `nss.render("tetra", res="64")` should read what `res` takes, not a
`TypeError` from deep inside numpy three seconds later (issue 46, item 7). Each check names the
argument and what it takes, and raises `ArgumentError`, a `NetsushisenError` (the message is
the one line the command line would print), before any work.
"""

from __future__ import annotations

from typing import Any

from netsushisen.isa.errors import NetsushisenError


class ArgumentError(NetsushisenError):
    """A Python API argument of the wrong type or value (what TypeError or ValueError would
    say, as the API's own error)."""


def shown(value: Any) -> str:
    """A value as the message shows it: its repr, cut at 40 characters."""
    text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def integer(name: str, value: Any, low: int | None = None, high: int | None = None,
            optional: bool = False) -> int | None:
    """`value` as an int (numpy integers too; not bool, not float), within low..high."""
    import numpy as np

    if value is None and optional:
        return None
    bounds = (f" from {low:,}" if low is not None else "") + (f" to {high:,}" if high is not None
                                                              else "")
    takes = f"an integer{bounds}" + (" or None" if optional else "")
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise ArgumentError(f"{name}={shown(value)}: {name} takes {takes}, not "
                            f"{type(value).__name__}")
    value = int(value)
    if (low is not None and value < low) or (high is not None and value > high):
        raise ArgumentError(f"{name}={shown(value)}: {name} takes {takes}")
    return value


def flag(name: str, value: Any) -> bool:
    """`value` as a bool (True or False only)."""
    import numpy as np

    if not isinstance(value, (bool, np.bool_)):
        raise ArgumentError(f"{name}={shown(value)}: {name} takes True or False, not "
                            f"{type(value).__name__}")
    return bool(value)


def choice(name: str, value: Any, choices: tuple[str, ...], optional: bool = True) -> str | None:
    """`value` one of `choices` (or None when optional)."""
    if value is None and optional:
        return None
    takes = " or ".join(repr(c) for c in choices) + (" or None" if optional else "")
    if not isinstance(value, str):
        raise ArgumentError(f"{name}={shown(value)}: {name} takes {takes}, not "
                            f"{type(value).__name__}")
    if value not in choices:
        raise ArgumentError(f"{name}={shown(value)}: {name} takes {takes}")
    return value


def text(name: str, value: Any, optional: bool = False) -> str | None:
    if value is None and optional:
        return None
    if not isinstance(value, str):
        raise ArgumentError(f"{name}={shown(value)}: {name} takes a string"
                            f"{' or None' if optional else ''}, not {type(value).__name__}")
    return value


def path(name: str, value: Any, optional: bool = False) -> str | None:
    """A file or folder name (str or os.PathLike) as a str."""
    import os

    if value is None and optional:
        return None
    if isinstance(value, str):
        return value
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    raise ArgumentError(f"{name}={shown(value)}: {name} takes a path (str or pathlib.Path)"
                        f"{' or None' if optional else ''}, not {type(value).__name__}")


def overrides(name: str, value: Any) -> list[str]:
    """Configuration overrides as `--set` items: a dict {path: value} (values int, float, bool
    or str) or a list of "path=value" strings."""
    from netsushisen.isa.config import override_items

    takes = 'a dict {"path": value} or a list of "path=value" strings or None'
    if value is None:
        return []
    if isinstance(value, dict):
        for k, v in value.items():
            if not isinstance(k, str):
                raise ArgumentError(f"{name}={shown(value)}: {name} takes {takes} (a key "
                                    f"{shown(k)} is {type(k).__name__})")
            if isinstance(v, (dict, list, tuple, set)) or v is None:
                raise ArgumentError(f"{name}={shown(value)}: {name}[{k!r}] takes a number, a "
                                    f"bool or a string, not {type(v).__name__}")
    elif isinstance(value, (list, tuple)):
        for item in value:
            if not isinstance(item, str) or "=" not in item:
                raise ArgumentError(f"{name}={shown(value)}: {name} takes {takes} (an item "
                                    f"{shown(item)} is not \"path=value\")")
    else:
        raise ArgumentError(f"{name}={shown(value)}: {name} takes {takes}, not "
                            f"{type(value).__name__}")
    return override_items(value)


def defines(name: str, value: Any) -> dict[str, int | float]:
    """Assembler symbols: a dict {name: int or float}."""
    if value is None:
        return {}
    if not isinstance(value, dict):
        raise ArgumentError(f"{name}={shown(value)}: {name} takes a dict {{\"NAME\": number}} "
                            f"or None, not {type(value).__name__}")
    for k, v in value.items():
        if not isinstance(k, str) or isinstance(v, bool) or not isinstance(v, (int, float)):
            raise ArgumentError(f"{name}={shown(value)}: {name} takes a dict {{\"NAME\": "
                                f"number}} (the entry {shown(k)}: {shown(v)} is not one)")
    return dict(value)


def config(value: Any):
    """A MachineConfig, a TOML file's path, or None (the defaults)."""
    from netsushisen.isa.config import MachineConfig

    if value is None or isinstance(value, MachineConfig):
        return value
    if isinstance(value, str) or hasattr(value, "__fspath__"):
        return path("config", value)
    raise ArgumentError(f"config={shown(value)}: config takes a nss.Config, a TOML file's path "
                        f"or None, not {type(value).__name__}")


def options(report: str, given: dict, accepted: dict[str, Any]) -> dict:
    """A report's keyword options checked against the ones it takes (name -> check)."""
    out = {}
    for key, value in given.items():
        if key not in accepted:
            takes = ", ".join(accepted) or "no options"
            raise ArgumentError(f"{key}={shown(value)}: report {report!r} takes {takes}")
        out[key] = accepted[key](key, value)
    return out
