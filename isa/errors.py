"""Diagnostics: how every tool reports bad input.

The project's rule is that bad input (a kernel, a scene file, a config, a deadlocked ring) gets a
clear located message and a non-zero exit, never a traceback. Everything raises `NetsushisenError`
(or a subclass) carrying one or more `Diagnostic`s; the command line prints them and exits with the
error's `exit_code`.
"""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class Diagnostic:
    """One located message, printed compiler-style: `file:line:col: error: message`."""

    message: str
    file: str | None = None
    line: int | None = None  # 1-based
    col: int | None = None  # 1-based
    source_line: str | None = None  # the offending line, shown with a caret under `col`
    severity: str = "error"

    def format(self) -> str:
        where = ""
        if self.file is not None:
            where = self.file
            if self.line is not None:
                where += f":{self.line}"
                if self.col is not None:
                    where += f":{self.col}"
            where += ": "
        text = f"{where}{self.severity}: {self.message}"
        if self.source_line is not None:
            src = self.source_line.rstrip("\n").expandtabs(8)
            text += "\n    " + src
            if self.col is not None:
                text += "\n    " + " " * (self.col - 1) + "^"
        return text


class NetsushisenError(Exception):
    """Bad input. `exit_code` is what the command line exits with (1 unless a subclass says)."""

    exit_code = 1

    def __init__(self, diagnostics: list[Diagnostic] | Diagnostic | str):
        if isinstance(diagnostics, str):
            diagnostics = [Diagnostic(diagnostics)]
        elif isinstance(diagnostics, Diagnostic):
            diagnostics = [diagnostics]
        self.diagnostics: list[Diagnostic] = list(diagnostics)
        super().__init__(self.format())

    def format(self) -> str:
        return "\n".join(d.format() for d in self.diagnostics)

    @property
    def path(self) -> str | None:
        """The file the first message is about (None when it names none): for a notebook, the
        `file` of `file:line:col: error: ...`."""
        return self.diagnostics[0].file if self.diagnostics else None

    @property
    def line(self) -> int | None:
        """The 1-based line of the first message (None when it names none)."""
        return self.diagnostics[0].line if self.diagnostics else None

    def __reduce__(self):
        """Copy and pickle by state: subclasses take other constructor arguments (a run fault
        takes a processor, a cycle and a message), so rebuilding through __init__ is wrong."""
        return _rebuild_error, (type(self), self.args, self.__dict__.copy())


def _rebuild_error(cls: type, args: tuple, state: dict) -> NetsushisenError:
    err = cls.__new__(cls)
    Exception.__init__(err, *args)
    err.__dict__.update(state)
    return err


class ConfigError(NetsushisenError):
    """An impossible or malformed machine configuration."""


class SceneError(NetsushisenError):
    """A malformed scene file or an unknown scene name."""


@dataclass
class DiagnosticSink:
    """Collects diagnostics so a tool can report every error of an input, not just the first."""

    diagnostics: list[Diagnostic] = field(default_factory=list)

    def error(self, message: str, file: str | None = None, line: int | None = None,
              col: int | None = None, source_line: str | None = None) -> None:
        self.diagnostics.append(Diagnostic(message, file, line, col, source_line))

    def __bool__(self) -> bool:
        return bool(self.diagnostics)

    def raise_if_any(self, cls: type[NetsushisenError] = NetsushisenError) -> None:
        if self.diagnostics:
            raise cls(self.diagnostics)
