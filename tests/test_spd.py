"""SPD generators: Table 1 counts, size-factor formulas, record-by-record agreement with the shared
.nff files (the paper's four and shells, tree, lattice), the library pieces they rest on, and the
scene catalog."""

from __future__ import annotations

import numpy as np
import pytest

from netsushisen.isa.errors import SceneError
from netsushisen.host.catalog import BUILTIN_SCENES, load_scene
from netsushisen.host.nff import format_nff, read_nff
from netsushisen.host.scenes import Kind
from netsushisen.host.spd import GENERATORS, PAPER_SCENES, generate, hash_rand
from netsushisen.host.spd_lib import gauss_rand, phong_pow

# The paper's Table 1 (= the SPD README's statistics): primitives, polygons, spheres, cones,
# cylinders, lights, reflective, transparent.
TABLE1 = {
    "tetra": (4096, 4096, 0, 0, 0, 1, False, False),
    "balls": (7382, 1, 7381, 0, 0, 3, True, False),
    "mount": (8196, 8192, 4, 0, 0, 1, True, True),
    "rings": (8401, 1, 4200, 0, 4200, 3, True, False),
}


# The other generators, counts from shared/spd/README.md at their default sizes.
EXTRA = {
    "shells": (5761, 0, 5761, 0, 0, 1, True, False),
    "tree": (8191, 1, 4095, 4095, 0, 7, False, False),
    "lattice": (8281, 0, 2197, 0, 6084, 6, True, False),
}


@pytest.fixture(scope="module")
def generated():
    return {name: generate(name) for name in GENERATORS}


def table1(scene):
    return (scene.n_primitives, scene.count(Kind.POLYGON), scene.count(Kind.SPHERE),
            scene.count(Kind.CONE), scene.count(Kind.CYLINDER), len(scene.light_position),
            scene.reflective, scene.transparent)


@pytest.mark.parametrize("name", list(TABLE1) + list(EXTRA))
def test_table1_counts_from_generator(generated, name):
    assert table1(generated[name]) == {**TABLE1, **EXTRA}[name]


@pytest.mark.parametrize("name", list(TABLE1))
def test_table1_counts_from_shared_file(shared_spd, name):
    assert table1(read_nff(shared_spd / f"{name}.nff")) == TABLE1[name]


def _close(a, b):
    """Agreement up to the 6 significant digits of %g (absolute slack for values near 0)."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    assert a.shape == b.shape
    np.testing.assert_allclose(a, b, rtol=1e-4, atol=1e-6)


def _keywords(text):
    """The record sequence of NFF text: first token of every line that starts a record."""
    return [line.split()[0] for line in text.splitlines() if line[:1].isalpha()]


@pytest.mark.parametrize("name", list(GENERATORS))
def test_generator_matches_shared_file(shared_spd, generated, name):
    path = shared_spd / f"{name}.nff"
    text = path.read_text()
    gen, ref = generated[name], read_nff(path)
    # same records (including every 'f' and the view block) in the same order
    assert _keywords(format_nff(gen)) == _keywords(text)
    assert np.array_equal(gen.kind, ref.kind)
    assert np.array_equal(gen.material, ref.material)
    assert np.array_equal(gen.polygons.count, ref.polygons.count)
    assert np.array_equal(gen.polygons.is_patch, ref.polygons.is_patch)
    _close(gen.polygons.vertices, ref.polygons.vertices)
    _close(gen.spheres.center, ref.spheres.center)
    _close(gen.spheres.radius, ref.spheres.radius)
    for field in ("base", "base_radius", "apex", "apex_radius"):
        _close(getattr(gen.cones, field), getattr(ref.cones, field))
    for field in ("color", "kd", "ks", "shine", "t", "ior"):
        _close(getattr(gen.materials, field), getattr(ref.materials, field))
    _close(gen.background, ref.background)
    _close(gen.light_position, ref.light_position)
    for field in ("eye", "at", "up"):
        _close(getattr(gen.camera, field), getattr(ref.camera, field))
    assert (gen.camera.angle, gen.camera.hither, gen.camera.resolution) == \
        (ref.camera.angle, ref.camera.hither, ref.camera.resolution)


def test_balls_near_z_records(shared_spd, generated):
    """balls.nff lines 4577-4666 are the 90 spheres the 2021 near-+-Z tolerance changes."""
    lines = (shared_spd / "balls.nff").read_text().splitlines()[4576:4666]
    assert len(lines) == 90 and all(line.startswith("s ") for line in lines)
    ref = np.array([[float(t) for t in line.split()[1:]] for line in lines])
    first = sum(1 for line in (shared_spd / "balls.nff").read_text().splitlines()[:4576]
                if line.startswith("s "))
    spheres = generated["balls"].spheres
    got = np.column_stack([spheres.center, spheres.radius])[first:first + 90]
    _close(got, ref)


@pytest.mark.parametrize("size", [1, 2, 3])
def test_size_factor_formulas(size):
    assert generate("tetra", size).count(Kind.POLYGON) == 4 ** size
    balls = generate("balls", size)
    assert balls.count(Kind.SPHERE) == sum(9 ** k for k in range(size + 1))
    assert balls.count(Kind.POLYGON) == 1
    mount = generate("mount", size)
    assert (mount.count(Kind.POLYGON), mount.count(Kind.SPHERE)) == (2 * 4 ** size, 4)
    rings = generate("rings", size)
    n = 5 * size * (size + 1) * (2 * size + 1)
    assert (rings.count(Kind.SPHERE), rings.count(Kind.CYLINDER)) == (n, n)
    objects = sum(k * k for k in range(1, size + 1))
    assert _keywords(format_nff(rings)).count("f") == 1 + 6 * objects
    assert generate("shells", size).count(Kind.SPHERE) == 180 * 2 ** size + 1
    tree = generate("tree", size)
    assert (tree.count(Kind.CONE), tree.count(Kind.SPHERE)) == (2 ** (size + 1) - 1,) * 2
    lattice = generate("lattice", size)
    assert (lattice.count(Kind.SPHERE), lattice.count(Kind.CYLINDER)) == \
        ((size + 1) ** 3, 3 * size * (size + 1) ** 2)


def test_generators_are_deterministic_and_sized_scenes_differ():
    a, b = generate("mount", 3), generate("mount", 3)
    assert np.array_equal(a.polygons.vertices, b.polygons.vertices)
    assert generate("mount", 4).polygons.vertices[:, 2].std() > 0  # a mountain, not a plane


def test_library_pieces():
    # mount.c's original hash at SF 6: (A<<17) + (B<<9) + (A<<1), low 16 bits
    assert hash_rand(1, 1, 6) == 514
    assert hash_rand(32, 0, 6) == 64  # 32<<17 falls out of the 16-bit mask entirely
    values = np.array([gauss_rand(seed) for seed in range(21, 3021)])
    assert abs(values.mean()) < 0.1 and abs(values.std() - 1.0) < 0.1
    assert gauss_rand(1234) == gauss_rand(1234)
    assert phong_pow(0.0) == 100000.0 and phong_pow(90.0) == 1.0
    assert f"{phong_pow(37.0):g}" == "3.0827" and f"{phong_pow(6.7):g}" == "101.148"


@pytest.mark.parametrize("name, size", [("tetra", 0), ("balls", 7), ("mount", 8), ("rings", -1),
                                        ("tree", 17), ("lattice", 0)])
def test_bad_sizes(name, size):
    with pytest.raises(SceneError, match="size factor"):
        generate(name, size)


# -- catalog ---------------------------------------------------------------------------------------

def test_catalog_builtins_and_sizes():
    assert PAPER_SCENES == ("tetra", "balls", "mount", "rings")
    assert BUILTIN_SCENES == PAPER_SCENES + ("shells", "tree", "lattice") == tuple(GENERATORS)
    assert load_scene("balls:2").count(Kind.SPHERE) == 91
    assert load_scene("tetra:1").source == "spd:tetra(size=1)"
    assert GENERATORS["rings"].default_size == 7 and GENERATORS["balls"].default_size == 4
    assert GENERATORS["tetra"].default_size == 6 and GENERATORS["mount"].default_size == 6


def test_catalog_files(shared_spd, tmp_path):
    assert load_scene(str(shared_spd / "teapot.nff")).n_primitives == 9264
    local = tmp_path / "tetra"  # a file named like a built-in is reachable through a path
    local.write_text(format_nff(generate("tetra", 1)))
    assert load_scene(str(local)).n_primitives == 4


@pytest.mark.parametrize("spec, fragment", [
    ("teapot", "not a built-in scene"),
    ("no/such/file.nff", "no such file"),
    ("balls:two", "bad size factor 'two'"),
])
def test_catalog_errors_list_the_builtins(spec, fragment):
    with pytest.raises(SceneError) as info:
        load_scene(spec)
    text = info.value.format()
    assert fragment in text
    for name in BUILTIN_SCENES:
        assert name in text


def test_catalog_directory(tmp_path):
    with pytest.raises(SceneError, match="directory"):
        load_scene(str(tmp_path))
