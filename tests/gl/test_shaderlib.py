"""The shader preprocessor and variant registry, without a GL context."""

import math
import re

import pytest

from blockhash.errors import InputError
from blockhash.gl.shaderlib import (
    CHOICES,
    NAMED,
    Source,
    Variant,
    define_block,
    glsl_dir,
    preprocess,
    variants,
)


def write(tmp_path, files):
    for name, text in files.items():
        (tmp_path / name).write_text(text)
    return tmp_path


def test_library_is_found_and_every_stage_has_a_guarded_documented_file():
    root = glsl_dir()
    for name in ("bh_fetch", "bh_box", "bh_hash", "bh_buckets", "bh_blocks", "bh_select",
                 "bh_select_packed", "bh_select_merge", "bh_merge_net", "bh_taken", "bh_lookup",
                 "bh_variants"):
        text = (root / f"{name}.glsl").read_text()
        guard = name.upper() + "_GLSL"
        assert text.startswith(f"// {name}.glsl:"), name
        assert f"#ifndef {guard}\n#define {guard}" in text and text.rstrip().endswith("#endif")


def test_every_selector_is_dispatched_once_with_an_error_for_unknown_ids():
    texts = {p.name: p.read_text() for p in glsl_dir().glob("*.glsl")}
    for selector, _ in CHOICES.values():
        owners = [name for name, text in texts.items() if f"#error unknown {selector}" in text]
        assert len(owners) == 1, (selector, owners)
        text = texts[owners[0]]
        chain = text[text.index(f"#if {selector} =="):text.index(f"#error unknown {selector}")]
        assert "#else" in chain or f"#elif {selector} !=" in chain


def test_glsl_ids_match_the_python_registry():
    text = (glsl_dir() / "bh_variants.glsl").read_text()
    ids = dict((m.group(1), int(m.group(2))) for m in re.finditer(r"#define (BH_\w+) (\d+)", text))
    prefixes = {"search": "BH_SEARCH_", "dedup": "BH_DEDUP_", "priority": "BH_PRIORITY_",
                "select": "BH_SELECT_", "cull": "BH_CULL_"}
    for choice, (_, names) in CHOICES.items():
        for name, value in names.items():
            assert ids[prefixes[choice] + name.upper()] == value


def test_includes_are_spliced_with_line_directives(tmp_path):
    root = write(tmp_path, {"main.frag": 'a\n#include "b.glsl"\nc\n', "b.glsl": "b1\nb2\n"})
    src = preprocess("main.frag", "#define X 0", root=root)
    assert src.text.splitlines() == ["#version 450 core", "#define X 0", "#line 100001 1", "a",
                                     "#line 200001 2", "b1", "b2", "#line 100003 1", "c"]
    assert src.files == ("<defines>", "main.frag", "b.glsl")


def test_compiler_locations_map_back_to_files(tmp_path):
    src = Source(text="", files=("<defines>", "main.frag", "b.glsl"))
    # Mesa: source 0, file encoded in the line; other drivers: source number, plain line.
    assert src.locate("0:200007(12): error: syntax error") == "b.glsl:7: error: syntax error"
    assert src.locate("2:7(12): error: syntax error") == "b.glsl:7: error: syntax error"
    assert src.locate("ERROR: 1(3) : undeclared") == "ERROR: main.frag:3 : undeclared"


def test_include_cycles_are_reported_with_the_chain(tmp_path):
    root = write(tmp_path, {"a.glsl": '#include "b.glsl"\n', "b.glsl": '#include "a.glsl"\n'})
    with pytest.raises(InputError, match=r"include cycle .*a\.glsl -> b\.glsl -> a\.glsl"):
        preprocess("a.glsl", root=root)


def test_missing_include_names_the_including_line(tmp_path):
    root = write(tmp_path, {"a.glsl": 'x\n#include "gone.glsl"\n'})
    with pytest.raises(InputError, match=r"'gone\.glsl' not found .*included from a\.glsl:2"):
        preprocess("a.glsl", root=root)


def test_defines_write_out_falsy_values():
    assert define_block({"A": 0, "B": False, "C": 3}) == "#define A 0\n#define B 0\n#define C 3"


def test_variants_list_named_and_every_combination():
    names = variants()
    assert names[:2] == ["default", "paper"] and len(names) == 2 + 2 * 3 * 2 * 4 * 2
    for name in names:
        assert Variant.parse(name).name in names or name in NAMED
    assert Variant.parse("linear-zero-off-insertion").defines() == {
        "BH_THRESHOLD_SEARCH": 0, "BH_DEDUP": 1, "BH_PRIORITY": 0, "BH_SELECT": 0, "BH_CULL": 0}
    assert Variant.parse("linear-zero-off-insertion-box").defines()["BH_CULL"] == 1
    assert Variant.parse("default").name == "binary-set-on-packed-box"


@pytest.mark.parametrize("name", ["fast", "linear-zero-on", "linear-zero-on-heap"])
def test_unknown_variant_lists_the_valid_ones(name):
    with pytest.raises(InputError, match=r"is not known.*the variants are: default, paper, linear-"):
        Variant.parse(name)


def test_unknown_choice_value_names_the_choice():
    with pytest.raises(InputError, match=r"variant select='heap' is not known; choose one of insertion, network, packed"):
        Variant(select="heap")


def test_merge_networks_sort_and_the_generated_file_is_current():
    """select=merge's networks (0-1 principle over every input) and glsl/bh_merge_net.glsl
    as blockhash.gl.merge_network renders it (tools/gen_merge_network.py writes it)."""
    from blockhash.gl import merge_network as gen

    gen.check()
    assert (glsl_dir() / "bh_merge_net.glsl").read_text() == gen.render()
    net, order = gen.batch_network()
    assert len(net) <= 32 and sorted(order) == list(range(10))
    n = 64
    bitonic = [[0] * i + [1] * (n - i - j) + [0] * j for i in range(n + 1) for j in range(n - i + 1)]
    assert gen.sorts(gen.bitonic_merge(n), n, bitonic)
    assert not gen.sorts(gen.bitonic_merge(n)[:-1], n, bitonic)  # the check can fail


def test_variants_say_which_choices_the_default_index_ignores():
    from blockhash.gl.shaderlib import CHOICES, IGNORED_BY_DEFAULT_INDEX, NAMED, Variant, variants

    every = variants()
    meaningful = variants(for_default_index=True)
    assert set(meaningful) <= set(every)
    assert set(IGNORED_BY_DEFAULT_INDEX) <= set(CHOICES)
    kept = [name for name in CHOICES if name not in IGNORED_BY_DEFAULT_INDEX]
    assert len(meaningful) - len(NAMED) == math.prod(len(CHOICES[n][1]) for n in kept)
    default = NAMED["default"]
    for name in meaningful[len(NAMED):]:
        v = Variant.parse(name)
        assert all(getattr(v, n) == getattr(default, n) for n in IGNORED_BY_DEFAULT_INDEX)
