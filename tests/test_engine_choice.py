"""The engine is never a secret (issue 25, item 2): the render and run summaries and the
statistics (`run.engine`) name the engine that ran; where numba cannot be imported the default
falls back to the reference engine with one warning line saying why and what it costs; and a
command that runs no machine (asm, isa, scene, config, report) does not import numba at all.

A missing numba is simulated in a subprocess by a meta-path finder that refuses to import it,
as an interpreter without numba would.
"""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

BLOCK_NUMBA = textwrap.dedent("""\
    import sys

    class NoNumba:
        def find_spec(self, name, path=None, target=None):
            if name == "numba" or name.startswith("numba."):
                raise ModuleNotFoundError(f"No module named {name!r}", name=name)
            return None

    sys.meta_path.insert(0, NoNumba())
    """)


def _python(code: str, cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=300, cwd=cwd)


def test_without_numba_render_falls_back_with_one_warning_and_still_renders(tmp_path):
    out = _python(BLOCK_NUMBA + textwrap.dedent("""\
        from netsushisen.cli import main
        sys.exit(main(["render", "tetra", "--res", "2", "-o", "t.png", "--json", "s.json"]))
        """), tmp_path)
    assert out.returncode == 0, out.stderr
    warnings = out.stderr.splitlines()
    assert len(warnings) == 1, out.stderr
    assert warnings[0].startswith("netsushisen: warning: the compiled engine is unavailable "
                                  "(ModuleNotFoundError: No module named 'numba')")
    assert "reference engine, about 200 times slower" in warnings[0]
    stats = json.loads((tmp_path / "s.json").read_text())
    assert stats["run"]["engine"] == "reference" and stats["run"]["status"] == "finished"
    assert "reference engine: finished" in " ".join(out.stdout.split())
    assert (tmp_path / "t.png").stat().st_size > 0


def test_without_numba_asking_for_the_compiled_engine_is_one_line(tmp_path):
    out = _python(BLOCK_NUMBA + textwrap.dedent("""\
        from netsushisen.cli import main
        sys.exit(main(["render", "tetra", "--res", "2", "--engine", "compiled"]))
        """), tmp_path)
    assert out.returncode == 1
    assert out.stderr.splitlines() == [
        "netsushisen render: error: engine 'compiled' is unavailable here (ModuleNotFoundError: "
        "No module named 'numba'); engines: reference"]


@pytest.mark.parametrize("numba", ["installed", "missing"])
def test_commands_that_run_no_machine_do_not_import_numba(tmp_path, cli, numba):
    """Installed, they do not import it; missing, they work all the same."""
    stats = tmp_path / "s.json"
    code, _, err = cli("render", "tetra:1", "--res", "2", "-q", "-o", tmp_path / "t.png",
                       "--json", stats)
    assert code == 0, err
    source = ROOT / "kernels" / "examples" / "ray_sphere_ic.s"
    commands = [["asm", str(source), "--proc", "ic", "-o", "x.o", "--stats"],
                ["asm", "--scene", "tetra:1", "--proc", "sc", "--stats"], ["isa", "-o", "isa.md"],
                ["scene", "info", "tetra"], ["scene", "list"], ["config", "--dump"],
                ["report", "ilp", str(stats)], ["report", "flat", str(stats)],
                ["report", "stalls", "--explain"], ["disasm", "x.o"], ["kernels", "list"],
                ["report", "stalls", str(stats), "--plot", "s.png"],
                ["report", "memory", str(stats)],
                ["report", "annotate", str(stats)], ["report", "diff", str(stats), str(stats)],
                ["golden", "tetra:1", "--res", "2", "-o", "g.png"], ["scene", "nff", "tetra:1"],
                ["--help"], ["asm", "--help"]]
    out = _python((BLOCK_NUMBA if numba == "missing" else "") + textwrap.dedent(f"""\
        import sys
        from netsushisen.cli import main
        for argv in {commands!r}:
            try:
                code = main(argv)
            except SystemExit as stop:
                code = stop.code
            assert code == 0, argv
            assert "numba" not in sys.modules, ("imported numba", argv)
        print("ok")
        """), tmp_path)
    assert out.returncode == 0 and out.stdout.endswith("ok\n"), out.stderr[-2000:]


def test_asm_help_does_not_import_numba(tmp_path):
    """The acceptance line of issue 31: `python -X importtime -m netsushisen.cli asm --help`
    lists no numba module (nor `isa` and `scene info`, which run no machine either)."""
    for argv in (["asm", "--help"], ["isa", "-o", "isa.md"], ["scene", "info", "tetra"]):
        out = subprocess.run([sys.executable, "-X", "importtime", "-m", "netsushisen.cli", *argv],
                             capture_output=True, text=True, timeout=120, cwd=tmp_path)
        assert out.returncode == 0, out.stderr[-2000:]
        imported = [line.rsplit("|", 1)[-1].strip() for line in out.stderr.splitlines()
                    if line.startswith("import time:")]
        assert "numpy" in imported  # the listing is read: it names what was imported
        assert not [m for m in imported if m.split(".")[0] in ("numba", "llvmlite")], argv


def test_render_and_run_name_the_engine(cli, tmp_path):
    code, out, _ = cli("render", "tetra:1", "--res", "2", "--engine", "reference",
                       "-o", tmp_path / "t.png", "--json", tmp_path / "s.json")
    assert code == 0 and "reference engine: finished" in " ".join(out.split())
    assert json.loads((tmp_path / "s.json").read_text())["run"]["engine"] == "reference"
    (tmp_path / "ic.s").write_text(".proc ic\n.text\n li r1, 3\n halt\n")
    for engine in ("reference", "compiled"):
        code, out, _ = cli("run", "--ic", tmp_path / "ic.s", "--engine", engine,
                           "--json", tmp_path / "r.json")
        assert code == 0 and out.splitlines()[0].endswith(f", {engine} engine")
        assert json.loads((tmp_path / "r.json").read_text())["run"]["engine"] == engine
