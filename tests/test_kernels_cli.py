"""The kernels outside `render` (issue 16, item 1): `asm --scene` assembles them with the symbols
render uses, `kernels export` copies them to edit, `render --kernels DIR` runs the edit."""

from __future__ import annotations

import json

import pytest

from netsushisen import pipeline
from netsushisen.isa.config import MachineConfig
from netsushisen.commands.kernels import including_defines
from netsushisen.kernels import KERNELS

SCENE = "tetra:1"


def _defines(text: str) -> dict:
    out = {}
    for line in text.splitlines():
        name, _, value = line.partition("=")
        out[name] = json.loads(value) if value not in ("inf", "-inf", "nan") else float(value)
    return out


def _render(cli, tmp_path, engine_name, name, *extra):
    stats = tmp_path / f"{name}.json"
    code, _, err = cli("render", SCENE, "--res", "4", "--engine", engine_name, "--quiet",
                       "-o", tmp_path / f"{name}.png", "--json", stats, *extra)
    assert code == 0, err
    return json.loads(stats.read_text())


def test_asm_scene_matches_render(cli, tmp_path, engine_name):
    """The static ILP and the symbols `asm --scene` gives are the ones render's statistics
    report, processor by processor."""
    stats = _render(cli, tmp_path, engine_name, "bundled")
    for stage in ("os", "ic", "sc"):
        code, out, err = cli("asm", "--scene", SCENE, "--res", "4", "--proc", stage, "--stats",
                             "--json")
        assert code == 0, err
        assert json.loads(out)[stage] == stats["programs"][stage]["static_ilp"]
        code, out, err = cli("asm", "--scene", SCENE, "--res", "4", "--proc", stage,
                             "--show-defines")
        assert code == 0, err
        assert _defines(out) == stats["programs"][stage]["defines"]


def test_asm_scene_text_and_choices(cli, tmp_path):
    code, out, err = cli("asm", "--scene", SCENE, "--stats")
    assert code == 0, err
    assert [line.split(":")[0].rsplit("/", 1)[-1] for line in out.splitlines()
            if ".s:" in line] == ["os.s", "ic.s", "sc.s"]
    want = pipeline.kernel_inputs(SCENE, MachineConfig(), 32).defines
    ic = pipeline.assemble_kernels(want)["ic"]
    assert f"IC  {len(ic.bundles)} bundles" in out
    # the options that change the symbols change them; -D overrides one
    _, specialised, _ = cli("asm", "--scene", SCENE, "--show-defines")
    _, generic, _ = cli("asm", "--scene", SCENE, "--show-defines", "--generic", "--depth", "3",
                        "-D", "SLOTS=4")
    spec, gen = _defines(specialised), _defines(generic)
    assert spec == want
    assert spec["HAS_SPHERES"] == 0 and gen["HAS_SPHERES"] == 1
    assert spec["MAX_DEPTH"] == 5 and gen["MAX_DEPTH"] == 3 and gen["SLOTS"] == 4
    # the listing shows the kernels' macro expansions
    code, out, _ = cli("asm", "--scene", SCENE, "--proc", "os", "--listing", "-")
    assert code == 0 and "; expands " in out and "ENQUEUE slot, t0, t1, main" in out
    # objects: one per stage, named by stage, written where we are
    code, _, err = cli("asm", "--scene", SCENE, "-o", tmp_path / "x.o")
    assert code == 1 and "-o names one object file" in err


@pytest.mark.parametrize("argv,fragment", [
    (["asm", "--generic", "kernels/ic.s"], "--generic needs --scene"),
    (["asm", "--pes", "2", "x.s"], "--pes needs --scene"),  # --set: the machine .sched is for
    (["asm"], "give a SOURCE.s, or --scene"),
    (["asm", "--scene", "no_such_scene", "--stats"], "no_such_scene"),
    (["asm", "--scene", SCENE, "--res", "0", "--stats"], "--res 0"),
    (["asm", "--scene", SCENE, "--kernels", "/no/such/dir", "--stats"], "no such folder"),
])
def test_asm_scene_bad_input(cli, argv, fragment):
    code, _, err = cli(*argv)
    assert code == 1 and fragment in err and "Traceback" not in err


def test_export_refuses_a_full_folder(cli, tmp_path):
    out = tmp_path / "k"
    code, stdout, err = cli("kernels", "export", out, "--res", "4")
    assert code == 0, err
    names = sorted(p.name for p in out.iterdir())
    assert names == sorted([p.name for p in KERNELS.iterdir()
                            if p.suffix in (".s", ".inc")] + ["defines.inc"])
    assert "render SCENE --kernels" in stdout
    # the default build: every feature, so every test of ic.s assembles
    assert ".equ HAS_CONES, 1" in (out / "defines.inc").read_text()
    (out / "ic.s").write_text("# my edit\n")
    code, _, err = cli("kernels", "export", out, "--scene", SCENE)
    assert code == 1 and "not empty" in err and (out / "ic.s").read_text() == "# my edit\n"
    code, _, err = cli("kernels", "export", out, "--scene", SCENE, "--force")
    assert code == 0, err
    assert (out / "ic.s").read_text() == including_defines((KERNELS / "ic.s").read_text())
    assert (out / "ic_sphere.inc").read_text() == (KERNELS / "ic_sphere.inc").read_text()
    inc = (out / "defines.inc").read_text()
    want = pipeline.kernel_inputs(SCENE, MachineConfig(), 32).defines
    assert f".equ HAS_POLYGONS, {want['HAS_POLYGONS']}" in inc and ".equ HAS_CONES, 0" in inc
    assert inc.count(".equ ") == len(want)
    code, _, err = cli("kernels", "export", tmp_path / "x", "--generic")
    assert code == 1 and "need --scene" in err


def test_exported_kernels_assemble_alone(cli, tmp_path):
    """Each exported stage program assembles as it is; with --scene, to the program `asm
    --scene` gives, bundle for bundle. The bundled ones alone name -D and --scene."""
    out = tmp_path / "k"
    assert cli("kernels", "export", out, "--scene", SCENE, "--res", "4")[0] == 0
    for stage in ("os", "ic", "sc"):
        code, _, err = cli("asm", out / f"{stage}.s", "--proc", stage, "-o", tmp_path / "a.o")
        assert code == 0, err
        code, _, err = cli("asm", "--scene", SCENE, "--res", "4", "--proc", stage,
                           "-o", tmp_path / "b.o")
        assert code == 0, err
        a, b = (json.loads((tmp_path / f"{n}.o").read_text()) for n in "ab")
        assert a["bundles"] == b["bundles"] and a["data"] == b["data"], stage
    code, _, err = cli("asm", KERNELS / "ic.s", "--proc", "ic", "--stats")
    first = err.splitlines()[0]
    assert code == 1 and "undefined symbol 'HAS_POLYGONS'" in first
    assert "-D HAS_POLYGONS=VALUE" in first and "--scene SCENE" in first


def test_exported_kernel_edited_runs(cli, tmp_path, engine_name):
    """An edit that costs cycles but not a pixel: a nop at the top of IC's primitive loop (and
    defines.inc included, which must change nothing)."""
    bundled = _render(cli, tmp_path, engine_name, "bundled")
    out = tmp_path / "mine"
    assert cli("kernels", "export", out, "--scene", SCENE, "--res", "4")[0] == 0
    ic = (out / "ic.s").read_text()
    assert ic.count("\ncell_loop:\n") == 1
    assert ic.count('.include "defines.inc"') == 1  # which must change nothing
    (out / "ic.s").write_text(ic.replace("\ncell_loop:\n", "\ncell_loop:\n    nop\n"))
    edited = _render(cli, tmp_path, engine_name, "edited", "--kernels", out)
    assert edited["programs"]["ic"]["source"].startswith(str(out))
    assert edited["programs"]["ic"]["bundles"] == bundled["programs"]["ic"]["bundles"] + 1
    assert edited["image_sha256"] == bundled["image_sha256"]
    assert edited["rays"] == bundled["rays"]
    assert edited["processors"]["pe0.ic"]["cycles"] > bundled["processors"]["pe0.ic"]["cycles"]
    # the same folder through asm: the edited program, as render assembled it
    code, stdout, err = cli("asm", "--scene", SCENE, "--res", "4", "--kernels", out, "--proc",
                            "ic", "--stats", "--json")
    assert code == 0, err
    assert json.loads(stdout)["ic"] == edited["programs"]["ic"]["static_ilp"]


def test_exported_include_with_an_error_is_located(cli, tmp_path):
    out = tmp_path / "mine"
    assert cli("kernels", "export", out)[0] == 0
    lines = (out / "ic_polygon.inc").read_text().split("\n")
    at = lines.index("poly_hit:")
    lines.insert(at + 1, "    fmadd t_nx, t_ny")
    (out / "ic_polygon.inc").write_text("\n".join(lines))
    code, _, err = cli("render", SCENE, "--res", "2", "--kernels", out, "-o", tmp_path / "x.png")
    assert code == 1 and "Traceback" not in err
    assert f"{out / 'ic_polygon.inc'}:{at + 2}:5: error: unknown mnemonic or macro 'fmadd'" in err
    assert not (tmp_path / "x.png").exists()


def test_kernels_list(cli):
    code, out, _ = cli("kernels", "list")
    assert code == 0
    assert [line.split()[0] for line in out.splitlines()] == sorted(
        p.name for p in KERNELS.iterdir() if p.suffix in (".s", ".inc"))


def test_asm_scene_takes_an_nff_file(cli):
    """SCENE is what render takes: a built-in name or an .nff file."""
    from pathlib import Path

    nff = Path(__file__).parent / "scenes" / "grazing_sphere.nff"
    code, out, err = cli("asm", "--scene", nff, "--show-defines")
    assert code == 0, err
    defines = _defines(out)
    assert defines == pipeline.kernel_inputs(str(nff), MachineConfig(), 32).defines
    assert defines["HAS_SPHERES"] == 1 and defines["HAS_POLYGONS"] == 0
