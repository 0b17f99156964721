"""What a debugger command returns to the front end (commands.py, breakcommands.py, source.py)."""

from __future__ import annotations

from dataclasses import dataclass, field

from rich.console import RenderableType


@dataclass
class Outcome:
    output: list[RenderableType] = field(default_factory=list)
    redraw: bool = False
    refresh: bool = False  # the screen's markers changed: redraw it on a full-screen terminal
    moved: bool = False  # the machine moved (or restarted)
    quit: bool = False
    failed: bool = False
