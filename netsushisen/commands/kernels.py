"""The bundled stage kernels as files to edit: `netsushisen kernels export DIR [--scene SCENE]
[--generic] [--res N] [--config FILE] [--set k=v]... [--force]`, and `netsushisen kernels list`.

`export` copies os.s, ic.s, sc.s and their includes (protocol.inc, ic_*.inc) into DIR, and writes
DIR/defines.inc: the build symbols the kernels need (`HAS_POLYGONS`, `RESIDENT_M`, base
addresses, ...), one `.equ` a line — with --scene the symbols `render` gives the kernels for that
scene (the same function computes them: pipeline.kernel_inputs), else the default build's (every
feature, as `render --generic`, over DEFAULT_BUILD_SCENE's databases at 32×32). The exported
os.s, ic.s and sc.s include it, so each assembles on its own (`asm DIR/ic.s --proc ic`; with
--scene S the very program `asm --scene S --proc ic` gives), and the folder is ready for
`netsushisen render SCENE --kernels DIR` (the folder is searched first for includes, so an
edited include wins over the bundled one; render defines the symbols itself and its -D values
win over the file's `.equ`s, so the include never changes a render). An existing DIR that is not
empty is refused unless --force (which overwrites the kernel files, and leaves other files).
"""

from __future__ import annotations

import argparse
import shutil
from pathlib import Path

from netsushisen.isa.outputs import write_all
from netsushisen.isa.errors import NetsushisenError
from netsushisen.options import add_config_options, add_resolution, check_resolution, config_from_args

KERNEL_PATTERNS = ("*.s", "*.inc")
"""What a kernels folder holds: the stage programs and their includes (not examples/)."""
DEFAULT_BUILD_SCENE = "tetra"
"""The scene whose databases give the default build's addresses (`export` without --scene)."""
INCLUDE_LINE = ('.include "defines.inc"   # the build symbols (kernels export); render\'s -D '
                'values win\n')


def configure(parser: argparse.ArgumentParser) -> None:
    sub = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    export = sub.add_parser("export", help="copy the kernels and includes into a folder to edit",
                            description=__doc__.strip())
    export.add_argument("dir", metavar="DIR", help="folder to create (or an empty one)")
    export.add_argument("--force", action="store_true",
                        help="write into a folder that is not empty, overwriting kernel files")
    export.add_argument("--scene", metavar="SCENE",
                        help="also write defines.inc: the symbols render uses for SCENE")
    export.add_argument("--generic", action="store_true", help="with --scene: every feature")
    export.add_argument("--slots", type=int, default=None, metavar="N",
                        help="with --scene: rays OS keeps in flight, as `render --slots`")
    add_resolution(export, 32, "with --scene: the render's N×N size (its pre-pass picks the "
                               "resident records; default 32, as `render`)")
    add_config_options(export, pes=True, precision=True, depth=True)
    sub.add_parser("list", help="the bundled kernel files and what each is")


def kernel_files() -> list[Path]:
    """The bundled kernels and includes, sorted by name."""
    from netsushisen.kernels import KERNELS

    return sorted({p for pattern in KERNEL_PATTERNS for p in KERNELS.glob(pattern)},
                  key=lambda p: p.name)


def defines_inc(defines: dict[str, int | float], what: str) -> str:
    """The symbols as an include file of `.equ` lines."""
    rows = [f"# The symbols `netsushisen render` gives the kernels for {what}",
            "# (written by `netsushisen kernels export`; render defines them itself, and its",
            "# values win over these, so including this file never changes a render).", ""]
    rows += [f".equ {name}, {value!r}" for name, value in sorted(defines.items())]
    return "\n".join(rows) + "\n"


def including_defines(text: str) -> str:
    """A stage program's text with `.include "defines.inc"` before its first line that is not
    a comment (after its header), so the exported file assembles on its own."""
    lines = text.splitlines(keepends=True)
    at = next((i for i, line in enumerate(lines) if line.strip() and
               not line.lstrip().startswith("#")), len(lines))
    return "".join(lines[:at] + [INCLUDE_LINE] + lines[at:])


def export(args: argparse.Namespace) -> int:
    from netsushisen import pipeline
    from netsushisen.isa.processors import STAGES

    out = Path(args.dir)
    if out.exists() and not out.is_dir():
        raise NetsushisenError(f"{out}: exists and is not a folder")
    if out.is_dir() and any(out.iterdir()) and not args.force:
        raise NetsushisenError(f"{out}: the folder is not empty (--force writes into it, "
                               "overwriting the kernel files)")
    if not args.scene and (args.generic or args.sets or args.config or args.slots is not None):
        raise NetsushisenError("--generic, --slots, --config and --set need --scene SCENE "
                               "(they change the symbols written to defines.inc)")
    check_resolution(args.res)
    slots = pipeline.DEFAULT_SLOTS if args.slots is None else args.slots
    generic = args.generic or not args.scene
    defines = pipeline.kernel_inputs(args.scene or DEFAULT_BUILD_SCENE, config_from_args(args),
                                     args.res, False, generic, slots).defines
    if args.scene:
        what = f"{args.scene} at {args.res}x{args.res}" + (" (generic)" if args.generic else "")
    else:
        what = (f"the default build: every feature (as `render --generic`) over "
                f"{DEFAULT_BUILD_SCENE}'s databases at {args.res}x{args.res}")
    stages = {f"{stage}.s" for stage in STAGES}
    text = defines_inc(defines, what)
    try:
        out.mkdir(parents=True, exist_ok=True)
        files = [(out / src.name, lambda p, src=src: p.write_text(
                     including_defines(src.read_text(encoding="utf-8")), encoding="utf-8"))
                 if src.name in stages else (out / src.name, lambda p, src=src: shutil.copyfile(src, p))
                 for src in kernel_files()]
        files.append((out / "defines.inc", lambda p: p.write_text(text, encoding="utf-8")))
        write_all(files)  # one set, never through a link (isa/outputs.py)
        written = [path.name for path, _ in files]
    except OSError as err:
        raise NetsushisenError(f"{out}: cannot write: {err.strerror}") from None
    print(f"wrote {len(written)} files to {out}: {', '.join(written)}")
    scene = args.scene or "SCENE"
    print(f"assemble one:   netsushisen asm {out / 'ic.s'} --proc ic --stats")
    print(f"run them:       netsushisen render {scene} --kernels {out}")
    return 0


def run(args: argparse.Namespace) -> int:
    if args.action == "export":
        return export(args)
    from netsushisen.reports.tables import report_width

    room = report_width() - 19  # one line a file, within the terminal (80 when not one)
    for path in kernel_files():
        first = next((line.lstrip("# ").strip() for line in path.read_text().splitlines()
                      if line.startswith("#") and line.strip("# ")), "")
        print(f"{path.name:18s} {first if len(first) <= room else first[:room - 1] + '…'}")
    return 0
