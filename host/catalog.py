"""Where scenes come from: one string names either a built-in SPD generator or an NFF file.

`load_scene("balls")` runs the generator at its SPD default size, `load_scene("balls:2")` at size
factor 2, and `load_scene("scenes/teapot.nff")` reads a file. Every command that takes a scene
goes through here, so the same spelling works everywhere and a typo gets one clear message that
lists what exists.
"""

from __future__ import annotations

from pathlib import Path

from netsushisen.isa.errors import Diagnostic, SceneError
from netsushisen.host.nff import read_nff
from netsushisen.host.scenes import Scene
from netsushisen.host.spd import GENERATORS, generate

BUILTIN_SCENES: tuple[str, ...] = tuple(GENERATORS)


def builtin_help() -> str:
    """One line per built-in scene: name, default size factor, what it is."""
    return "\n".join(f"{g.name:<6} (default size {g.default_size}, 1..{g.max_size}): {g.summary}"
                     for g in GENERATORS.values())


def _names() -> str:
    return ", ".join(f"{n}[:SIZE]" for n in BUILTIN_SCENES)


def parse_spec(spec: str) -> tuple[str, int | None] | None:
    """(name, size) if `spec` names a built-in scene, else None (it is then a file path).

    A spec that contains a path separator or ends in `.nff` is always a path, so a file called
    `tetra` can still be read as `./tetra`.
    """
    if "/" in spec or "\\" in spec or spec.lower().endswith(".nff"):
        return None
    name, sep, size_text = spec.partition(":")
    if name not in GENERATORS:
        return None
    if not sep:
        return name, None
    try:
        size = int(size_text)
    except ValueError:
        raise SceneError(f"bad size factor '{size_text}' in scene '{spec}': write "
                         f"{name}:N with an integer N (built-in scenes: {_names()})") from None
    return name, size


def load_scene(spec: str) -> Scene:
    """A `Scene` from a built-in name (`tetra`, `balls:2`, ...) or the path of an `.nff` file."""
    parsed = parse_spec(spec)
    if parsed is not None:
        return generate(*parsed)
    path = Path(spec)
    if not path.exists():
        hint = f"no such file, and not a built-in scene (built-in scenes: {_names()})"
        raise SceneError(Diagnostic(f"cannot load scene: {hint}", file=spec))
    if path.is_dir():
        raise SceneError(Diagnostic("cannot load scene: this is a directory, not an NFF file",
                                    file=spec))
    return read_nff(path)
