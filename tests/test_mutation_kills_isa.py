"""Tests written to kill mutants that survived tools/mutate.py in isa/ (docs/mutation.md): the
configuration's loading rules, each against a value worked out from its documented rule."""

from __future__ import annotations

import pytest

from netsushisen.isa.errors import ConfigError
from netsushisen.isa.config import load_config


def _error(path=None, sets=()) -> str:
    with pytest.raises(ConfigError) as err:
        load_config(path, list(sets))
    return err.value.format()


def test_a_nested_table_in_a_config_file_names_its_full_path(tmp_path):
    toml = tmp_path / "machine.toml"
    toml.write_text("[ic_memory]\nt_r = 3\n")
    assert load_config(toml).ic_memory.t_r == 3
    toml.write_text("[ic_memory]\nbogus = 1\n")
    assert "unknown configuration field 'ic_memory.bogus'" in _error(toml)


def test_set_names_the_unknown_field_up_to_where_it_went_wrong():
    assert ("--set 'ic_memory.bogus.x=1': unknown configuration field 'ic_memory.bogus'"
            in _error(sets=["ic_memory.bogus.x=1"]))


def test_word_bytes_follow_a_precision_read_at_run_time():
    # the precision string comes from the command line (not the literal in the source)
    assert load_config(None, ["precision=" + "fp" + "32"]).word_bytes == 4
    assert load_config(None, ["precision=fp64"]).word_bytes == 8


def test_a_cache_block_of_exactly_one_word_is_allowed():
    # "a power of two of at least one word": 4 bytes in fp32 is the smallest block, 2 is too small
    assert load_config(None, ["ic_memory.block_bytes=4"]).ic_memory.block_bytes == 4
    assert "block_bytes must be a power of two of at least one word, got 2" in \
        _error(sets=["ic_memory.block_bytes=2"])
    assert load_config(None, ["precision=fp64", "ic_memory.block_bytes=8"]).ic_memory.block_bytes == 8


def test_an_optional_share_takes_none_and_a_number():
    assert load_config(None, ["ic_memory.cache_share=none"]).ic_memory.cache_share is None
    assert load_config(None, ["ic_memory.cache_share=0.25"]).ic_memory.cache_share == 0.25


# --- isa/images.py ---------------------------------------------------------------------------

def test_a_global_memory_without_a_size_ends_at_its_highest_word():
    from netsushisen.isa.images import image_from_json
    from netsushisen.isa.words import WordFormat

    wf = WordFormat("fp32")
    img = image_from_json({"icgm": [{"at": 5, "words": [1, 2, 3]}]})   # words 5, 6, 7
    assert img.global_memory("icgm", wf).tolist() == [0, 0, 0, 0, 0, 1, 2, 3]
    img = image_from_json({"icgm": [1], "sizes": {"icgm": 16}})
    assert len(img.global_memory("icgm", wf)) == 16


def test_raw_words_up_to_64_bits_load_and_wider_ones_are_refused():
    from netsushisen.isa.errors import NetsushisenError
    from netsushisen.isa.images import image_from_json
    from netsushisen.isa.words import WordFormat

    img = image_from_json({"scgm": ["0x3ff0000000000000", "0xffffffffffffffff"]})
    assert img.global_memory("scgm", WordFormat("fp64")).tolist() == [0x3FF0000000000000, 2**64 - 1]
    with pytest.raises(NetsushisenError) as err:
        image_from_json({"scgm": ["0x10000000000000000"]})
    assert "wider than 64 bits" in err.value.format()


def test_an_npz_image_keeps_its_frame(tmp_path):
    import numpy as np

    from netsushisen.isa.images import load_image

    path = tmp_path / "image.npz"
    np.savez(path, frame=np.array([64, 48]), icgm=np.array([1.5], np.float32))
    assert load_image(path).frame == (64, 48)
