"""The debugger's front ends: batch (commands from a file or a pipe, panels printed as plain
text) and interactive (a screen of panels after every stop, a `(nss)` prompt with history and
tab completion; Enter repeats the last command). Both run `Commands` on a `Session`; `netsushisen
debug` (netsushisen/commands/debug.py) picks one.
"""

from __future__ import annotations

import os
import signal
import sys

from rich.console import Console
from rich.text import Text

from netsushisen.debugger.commands import Commands
from netsushisen.debugger.expressions import REGIONS
from netsushisen.debugger.help import ALIASES, HELP, INFO_TOPICS
from netsushisen.debugger.layout import screen
from netsushisen.debugger.view import where_line
from netsushisen.isa.processors import STAGES

PROMPT = "(nss) "


def make_console(width: int | None = None, file=None) -> Console:
    file = file or sys.stdout
    tty = hasattr(file, "isatty") and file.isatty()
    return Console(file=file, width=width or (None if tty else 120), markup=False,
                   highlight=False, emoji=False)


class FrontEnd:
    def __init__(self, session, console: Console, *, interactive: bool, auto_screen: bool = True):
        self.session = session
        self.console = console
        self.interactive = interactive
        self.commands = Commands(session, auto_screen=auto_screen)
        self.commands.run_source = self.run_lines
        self.failed = False

    def draw(self) -> None:
        """The screen: on a terminal redrawn in place from the top, sized to fit (layout.py);
        in a batch or a pipe printed at natural height, as a log."""
        if self.interactive:
            self.console.clear()
        size = self.console.size
        self.console.print(screen(self.session, size.width,
                                  size.height if self.interactive else None,
                                  self.commands.layout))

    def show(self, outcome) -> None:
        if (outcome.redraw or (outcome.refresh and self.interactive)) \
                and self.commands.auto_screen:
            self.draw()
        elif outcome.moved:
            self.console.print(where_line(self.session))
        for item in outcome.output:
            self.console.print(item, soft_wrap=isinstance(item, Text))

    def execute(self, line: str, echo: bool = False, repeat_empty: bool = False) -> bool:
        """Run one command line; False to quit."""
        if echo and line.strip() and not line.strip().startswith("#"):
            self.console.print(Text(PROMPT + line.strip(), style="bold"))
        outcome = self.commands.execute(line, repeat_empty=repeat_empty)
        self.failed |= outcome.failed
        self.show(outcome)
        return not outcome.quit

    def run_lines(self, lines) -> bool:
        for line in lines:
            if not self.execute(line.rstrip("\n"), echo=True):
                return False
        return True

    def banner(self) -> None:
        s = self.session
        m = s.machine
        self.console.print(Text(f"netsushisen debug: {s.factory.description}; {len(m.pes)} PE"
                                f"{'s' if len(m.pes) != 1 else ''}; viewing pe{s.pe}.{s.stage}; "
                                f"checkpoint every {s.interval} cycles. `help` lists the commands."),
                           soft_wrap=True)
        for line in s.start_messages:  # --fast-forward: where the session starts
            self.console.print(Text(line), soft_wrap=True)

    def interactive_loop(self) -> None:
        """The full-screen session: the terminal's alternate screen (as gdb's TUI, less or vim:
        the shell's scrollback is back as it was on quit), the screen redrawn in place after
        every stop, the prompt below it."""
        _setup_readline(self.session)
        alt = self.console.is_terminal and self.console.set_alt_screen(True)
        try:
            self._loop()
        finally:
            if alt:
                self.console.set_alt_screen(False)
        _save_history()

    def _loop(self) -> None:
        self.draw()
        self.banner()
        old = signal.getsignal(signal.SIGINT)

        def on_interrupt(signum, frame):
            self.session.interrupt = True

        while True:
            try:
                line = input(PROMPT)
            except EOFError:
                self.console.print()
                break
            except KeyboardInterrupt:
                self.console.print("^C")
                continue
            signal.signal(signal.SIGINT, on_interrupt)
            try:
                going = self.execute(line, repeat_empty=True)
            finally:
                signal.signal(signal.SIGINT, old)
            if not going:
                break


def _setup_readline(session) -> None:
    try:
        import readline
    except ImportError:  # no readline on this platform: plain input()
        return
    path = _history_path()
    if path:
        try:
            readline.read_history_file(path)
        except OSError:
            pass
    readline.set_history_length(1000)

    def candidates(text: str) -> list[str]:
        line = readline.get_line_buffer()
        words = line[:readline.get_begidx()].split()
        if not words:
            return sorted(set(HELP) | set(ALIASES))
        first = words[0]
        if first in ("info", "i"):
            return list(INFO_TOPICS)
        if first == "proc":
            return list(STAGES)
        if first in ("help", "h"):
            return list(HELP)
        if first in ("trace", "screen"):
            return ["on", "off"]
        program = session.machine.programs.get(session.stage)
        names = [f"r{i}" for i in range(64)] + ["pc", "cycle", "lr", "zero", "if"]
        names += [f"{r}[" for r in REGIONS] + list(STAGES)
        if program is not None:
            names += list(program.labels)
        return names

    def complete(text: str, state: int):
        try:
            options = [c for c in candidates(text) if c.startswith(text)]
        except Exception:
            return None
        return options[state] if state < len(options) else None

    readline.set_completer(complete)
    readline.set_completer_delims(" \t\n=+-*/()[],&|<>!~^%")
    if "libedit" in (readline.__doc__ or ""):
        readline.parse_and_bind("bind ^I rl_complete")
    else:
        readline.parse_and_bind("tab: complete")


def _history_path() -> str | None:
    path = os.environ.get("NETSUSHISEN_DEBUG_HISTORY")
    if path is not None:
        return path or None
    home = os.path.expanduser("~")
    return os.path.join(home, ".netsushisen_debug_history") if os.path.isdir(home) else None


def _save_history() -> None:
    try:
        import readline
    except ImportError:
        return
    path = _history_path()
    if path:
        try:
            readline.write_history_file(path)
        except OSError:
            pass
