"""Step through the machine in the terminal, cycle by cycle (docs/debugger.md).

    netsushisen debug --program os.s --program ic.o [--image img.json] [--config cfg.toml]
                      [--set KEY=VALUE ...] [--pes N] [--pe K] [--proc os|ic|sc]
    netsushisen debug --ic ic.s --batch commands.txt        (or --batch - : commands on stdin)
    netsushisen debug SCENE [--res N] [--corners] [--generic] [--kernels DIR] [--pes N] ...
                                                            (scene mode: as `netsushisen render`)

`--program` takes object files or `.s` sources that name their processor (`.proc`); `--os`,
`--ic`, `--sc` and the image/config options are those of `netsushisen run`. Scene mode prepares
the scene as `netsushisen render` does (grid, pre-pass, databases, kernels, eye rays); there
`--os/--ic/--sc FILE` are your own kernel sources.

Interactive: a screen of panels after every stop, a `(nss)` prompt with history and tab
completion; Enter repeats the last command; `help` lists the commands. `--batch` runs commands
without a terminal and prints the same panels as plain text; exit 1 if a command failed.
"""

from __future__ import annotations

import argparse
import os
import signal
import sys

from rich.console import Console
from rich.text import Text

from netsushisen.errors import NetsushisenError
from netsushisen.isa.processors import STAGES

PROMPT = "(nss) "


def configure(parser: argparse.ArgumentParser) -> None:
    from netsushisen.emulator.cli import add_machine_arguments

    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.add_argument("scene", nargs="?", metavar="SCENE",
                        help="debug a scene's render (needs the render pipeline)")
    parser.add_argument("--program", action="append", default=[], metavar="FILE",
                        help="a program (object file or .s with .proc); repeat for each processor")
    add_machine_arguments(parser)
    parser.add_argument("--res", type=int, metavar="N", help="scene mode: N x N image "
                        "(default: render's)")
    parser.add_argument("--corners", action="store_true", help="scene mode: SPD corner rays")
    parser.add_argument("--generic", action="store_true",
                        help="scene mode: assemble every kernel feature, not only the scene's")
    parser.add_argument("--slots", type=int, metavar="N", help="scene mode: rays OS keeps in flight")
    parser.add_argument("--kernels", metavar="DIR",
                        help="scene mode: your own os.s, ic.s, sc.s (--os/--ic/--sc FILE: one)")
    parser.add_argument("--pe", type=int, default=0, metavar="K", help="PE to view first (0)")
    parser.add_argument("--proc", choices=STAGES, help="processor to view first "
                        "(default: the first with a program)")
    parser.add_argument("--batch", metavar="FILE", help="run the commands in FILE ('-': stdin) "
                        "without a terminal, printing the panels as text")
    parser.add_argument("-x", "--commands", metavar="FILE",
                        help="run the commands in FILE first, then go on interactively")
    parser.add_argument("--checkpoint-interval", type=int, default=2048, metavar="K",
                        help="cycles between checkpoints for reverse execution (2048)")
    parser.add_argument("--max-checkpoints", type=int, default=256, metavar="N",
                        help="checkpoints kept before the interval doubles (256)")
    parser.add_argument("--width", type=int, metavar="COLUMNS",
                        help="screen width (default: the terminal's; 120 when not a terminal)")
    parser.add_argument("--no-screen", action="store_true",
                        help="do not draw the panels after every stop (the `screen` command does)")


# ---------------------------------------------------------------------------------------------
# Machine factories


def programs_factory(args: argparse.Namespace):
    from netsushisen.emulator.cli import machine_inputs
    from netsushisen.emulator.debugger import ProgramsFactory

    if not (args.program or args.os or args.ic or args.sc):
        raise NetsushisenError("nothing to debug: give programs (--program FILE, --os/--ic/--sc) "
                               "or a SCENE")
    config, programs, image = machine_inputs(args, args.program)
    names = ", ".join(f"{s} {p.source_map[0].file if p.source_map else '?'}"
                      for s, p in programs.items() if p is not None)
    return ProgramsFactory(config, programs, image, description=names)


class SceneFactory:
    """Scene mode: the render pipeline's host work (grid, pre-pass, images, kernels, eye rays)
    is done once; every `build()` (the start, `restart`) makes a fresh Machine from it."""

    def __init__(self, setup):
        self.setup = setup
        self.description = (f"scene {setup.scene.name}, {setup.res}x{setup.res}"
                            f"{' corners' if setup.corners else ''}, "
                            f"{'generic' if setup.generic else 'specialised'} kernels")

    def build(self):
        return self.setup.machine()


def scene_factory(args: argparse.Namespace):
    """Scene mode: `netsushisen.emulator.render` prepares the scene as `netsushisen render` does."""
    if args.program or args.image:
        raise NetsushisenError("scene mode builds its own programs and memory image: --program "
                               "and --image are for raw programs (use --os/--ic/--sc FILE or "
                               "--kernels DIR for your own kernels)")
    from netsushisen.emulator import render as pipeline

    if args.res is not None and args.res < 1:
        raise NetsushisenError(f"--res {args.res}: the image needs at least 1x1 pixels")
    from netsushisen.emulator.cli import config_from_args

    config = config_from_args(args)
    kernels = {s: getattr(args, s) for s in STAGES if getattr(args, s)}
    options = {"corners": args.corners, "generic": args.generic, "kernel_dir": args.kernels,
               "kernels": kernels}
    if args.res is not None:
        options["res"] = args.res
    if args.slots is not None:
        options["slots"] = args.slots
    return SceneFactory(pipeline.prepare(args.scene, config, **options))


# ---------------------------------------------------------------------------------------------
# Front end


def make_console(width: int | None = None, file=None) -> Console:
    file = file or sys.stdout
    tty = hasattr(file, "isatty") and file.isatty()
    return Console(file=file, width=width or (None if tty else 120), markup=False,
                   highlight=False, emoji=False)


class FrontEnd:
    def __init__(self, session, console: Console, *, interactive: bool, auto_screen: bool = True):
        from netsushisen.emulator.debug_commands import Commands

        self.session = session
        self.console = console
        self.interactive = interactive
        self.commands = Commands(session, auto_screen=auto_screen)
        self.commands.run_source = self.run_lines
        self.failed = False

    def draw(self) -> None:
        from netsushisen.emulator.debug_view import screen

        if self.interactive:
            self.console.clear()
        size = self.console.size
        self.console.print(screen(self.session, size.width,
                                  size.height if self.interactive else None))

    def show(self, outcome) -> None:
        from netsushisen.emulator.debug_view import where_line

        if outcome.redraw and self.commands.auto_screen:
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

    def interactive_loop(self) -> None:
        _setup_readline(self.session)
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
        _save_history()


def _setup_readline(session) -> None:
    try:
        import readline
    except ImportError:  # no readline on this platform: plain input()
        return
    from netsushisen.emulator.debug_help import ALIASES, HELP, INFO_TOPICS
    from netsushisen.emulator.debug_expr import REGIONS

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


def run(args: argparse.Namespace) -> int:
    from netsushisen.emulator.debug_expr import DebugError
    from netsushisen.emulator.debugger import Session

    if not args.scene and (args.res is not None or args.corners or args.generic or args.kernels
                           or args.slots is not None):
        raise NetsushisenError("--res, --corners, --generic, --slots and --kernels are for scene "
                               "mode (debug SCENE ...)")
    factory = scene_factory(args) if args.scene else programs_factory(args)
    try:
        session = Session(factory, pe=args.pe, stage=args.proc,
                          checkpoint_interval=args.checkpoint_interval,
                          max_checkpoints=args.max_checkpoints)
    except DebugError as err:
        raise NetsushisenError(str(err)) from None
    batch = args.batch
    if batch is None and not sys.stdin.isatty():
        batch = "-"  # commands piped in: run them as a batch
    console = make_console(args.width)
    front = FrontEnd(session, console, interactive=batch is None, auto_screen=not args.no_screen)
    if batch is not None:
        if batch == "-":
            lines = sys.stdin.read().splitlines()
        else:
            try:
                with open(batch, encoding="utf-8") as fh:
                    lines = fh.read().splitlines()
            except OSError as err:
                raise NetsushisenError(f"{batch}: {err.strerror}") from None
        front.banner()
        if args.commands:
            front.execute(f"source {args.commands}")
        front.run_lines(lines)
        return 1 if front.failed else 0
    if args.commands:
        front.execute(f"source {args.commands}")
    front.interactive_loop()
    return 0
