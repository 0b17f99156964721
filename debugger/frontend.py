"""The debugger's front ends: batch (commands from a file or a pipe, panels printed as plain
text at their natural height, a scrolling log) and interactive (full screen: the terminal's
alternate screen, a fixed layout sized to the terminal redrawn in place after every stop —
layout.py —, a `(nss)` prompt below it with history and tab completion by context; Enter
repeats the last command). Both run `Commands` on a `Session`; `netsushisen debug`
(netsushisen/commands/debug.py) picks one.
"""

from __future__ import annotations

import os
import re
import signal
import sys

from rich.console import Console
from rich.text import Text

from netsushisen.debugger.commands import Commands, resolve_command
from netsushisen.debugger.expressions import REGIONS, VIEWS, DebugError
from netsushisen.debugger.help import ALIASES, HELP, INFO_TOPICS, LAYOUTS
from netsushisen.debugger.layout import MIN_HEIGHT, MIN_WIDTH, PANELS, line_mode, screen
from netsushisen.debugger.view import where_line
from netsushisen.isa.processors import N_REGISTERS, STAGES

PROMPT = "(nss) "
PAGER_PROMPT = "--Type <RET> for more, q to quit, c to continue without paging--"


def _ask(prompt: str) -> str:
    """The pager's question (input(), its answer kept out of the command history)."""
    answer = input(prompt)
    try:
        import readline
        if answer.strip() and readline.get_current_history_length():
            readline.remove_history_item(readline.get_current_history_length() - 1)
    except (ImportError, ValueError):
        pass
    return answer


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
        self.ask = _ask  # the pager's question (tests answer it themselves)

    def draw(self) -> None:
        """The screen: on a terminal redrawn in place from the top, sized to fit (layout.py);
        in a batch or a pipe printed at natural height, as a log."""
        if self.interactive:
            self.console.clear()
        size = self.console.size
        if self.interactive and (size.width < MIN_WIDTH or size.height < MIN_HEIGHT):
            self.console.print(line_mode(self.session, size.width), soft_wrap=True)
            return
        self.console.print(screen(self.session, size.width,
                                  size.height if self.interactive else None,
                                  self.commands.layout))

    def show(self, outcome) -> None:
        if (outcome.redraw or (outcome.refresh and self.interactive)) \
                and self.commands.auto_screen:
            self.draw()
        elif outcome.moved:
            self.console.print(where_line(self.session))
        if self.interactive and outcome.output:
            self.page(outcome.output)
            return
        for item in outcome.output:
            self.console.print(item, soft_wrap=isinstance(item, Text))

    def page(self, items) -> None:
        """Print a command's output a screenful at a time, as gdb's pagination does: after
        each page `--Type <RET> for more, q to quit, c to continue without paging--`."""
        console = self.console
        with console.capture() as cap:
            for item in items:
                console.print(item, soft_wrap=isinstance(item, Text))
        lines = cap.get().split("\n")
        if lines and lines[-1] == "":
            lines.pop()
        width, page = max(console.size.width, 1), max(console.size.height - 1, 1)
        rows = [max(1, -(-Text.from_ansi(line).cell_len // width)) for line in lines]
        if sum(rows) <= page:
            console.file.write("".join(line + "\n" for line in lines))
            console.file.flush()
            return
        i, used = 0, 0
        while i < len(lines):
            if used + rows[i] > page and used:
                answer = self.ask(PAGER_PROMPT).strip().lower()
                if answer.startswith("q"):
                    console.file.write("Quit\n")
                    break
                if answer.startswith("c"):
                    page = 1 << 30
                used = 0
            console.file.write(lines[i] + "\n")
            used += rows[i]
            i += 1
        console.file.flush()

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

    def complete(text: str, state: int):
        try:
            line = readline.get_line_buffer()
            options = completions(session, line[:readline.get_endidx()],
                                  readline.get_begidx(), text)
        except Exception:
            return None
        return options[state] if state < len(options) else None

    readline.set_completer(complete)
    readline.set_completer_delims(" \t\n=+-*/()[],&|<>!~^%")
    if "libedit" in (readline.__doc__ or ""):
        readline.parse_and_bind("bind ^I rl_complete")
    else:
        readline.parse_and_bind("tab: complete")


# what each command's arguments are, for completion
_CODE = ("break", "tbreak", "until", "list", "disassemble")
_MEMORY = ("x", "rwatch", "awatch")
_VALUES = ("print", "display", "set", "watch")
_NUMBERED = ("delete", "disable", "enable", "condition", "ignore")


def completions(session, line: str, begidx: int, text: str) -> list[str]:
    """Tab completion by context (the line up to the cursor; `text` is the word being
    completed, starting at `begidx`). The first word: commands and aliases — the whole word,
    so `reverse-` offers only the three reverse commands. Then by the argument's kind: code
    locations (labels, `ic.`, FILE:) for break/until/list, memory names and data labels for
    x/rwatch/awatch, registers, memory, labels and names for print/display/set/watch,
    breakpoint numbers for delete/enable/condition..., and the command's own words for info,
    help, proc, layout, trace, screen."""
    words = line[:begidx].split()
    if not line.lstrip() or " " not in line.lstrip():  # still in the first word
        head = line.lstrip()
        names = sorted(set(HELP) | set(ALIASES))
        cut = len(head) - len(text)  # readline replaces only `text` (after a '-' delimiter)
        return [n[cut:] for n in names if n.startswith(head)]
    m = re.match(r"[\w-]+", words[0]) if words else None
    try:
        name = resolve_command(m.group(0)) if m else ""
    except DebugError:
        return []
    args_before = len(words) - 1
    if name == "info":
        options = list(INFO_TOPICS) if args_before == 0 else []
    elif name == "help":
        options = sorted(HELP)
    elif name == "proc":
        options = list(STAGES)
    elif name == "layout":
        options = list(LAYOUTS) + list(PANELS)
    elif name in ("trace", "screen"):
        options = ["on", "off"]
    elif name in _NUMBERED and (args_before == 0 or name in ("delete", "disable", "enable")):
        options = [str(n) for n in sorted([*session.breakpoints, *session.watchpoints])]
    elif name == "undisplay":
        options = []
    elif name in _CODE:
        options = _code_names(session)
    elif name in _MEMORY:
        options = [f"{r}[" for r in REGIONS] + list(REGIONS) + _data_labels(session)
    elif name in _VALUES or name in ("condition",):
        options = _value_names(session)
    else:
        options = []
    return sorted({o for o in options if o.startswith(text)})


def _program(session):
    return session.machine.programs.get(session.stage)


def _code_names(session) -> list[str]:
    program = _program(session)
    names = [f"{s}." for s in STAGES if session.machine.programs.get(s) is not None]
    if program is not None:
        names += [n for n, (sec, _) in program.labels.items() if sec == "text"]
        names += sorted({loc.file.rsplit("/", 1)[-1] + ":" for loc in program.source_map
                         if not loc.file.startswith("<")})
    return names


def _data_labels(session) -> list[str]:
    program = _program(session)
    if program is None:
        return []
    return [n for n, (sec, _) in program.labels.items() if sec == "data"]


def _value_names(session) -> list[str]:
    names = [f"r{i}" for i in range(N_REGISTERS)] + ["pc", "cycle", "lr", "zero"]
    names += [f"{r}[" for r in REGIONS] + [f"{v}:" for v in VIEWS] + [f"{s}." for s in STAGES]
    program = _program(session)
    if program is not None:
        names += list(program.labels) + list(program.defines)
        names += sorted({r.name for r in program.reg_names})
    return names


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
