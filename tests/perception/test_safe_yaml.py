"""The limits of ``perception.safe_yaml``: refused before anything is built, one line naming the source."""

import math
import resource
import time

import pytest

from lookahead.perception.safe_yaml import (
    MAX_YAML_BYTES,
    YamlError,
    first_non_finite,
    load_yaml,
    read_yaml_text,
)


def billion_laughs(levels: int = 9) -> str:
    """10**levels strings from a few hundred bytes of anchors and aliases."""
    lines = ["l0: &l0 [lol, lol, lol, lol, lol, lol, lol, lol, lol, lol]"]
    for i in range(1, levels):
        lines.append(f"l{i}: &l{i} [{', '.join([f'*l{i - 1}'] * 10)}]")
    return "\n".join(lines) + "\n"


def test_billion_laughs_is_refused_from_the_node_graph_fast_and_small():
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    t0 = time.perf_counter()
    with pytest.raises(YamlError, match=r"^bomb.yaml:\d+: aliases expand to more than"):
        load_yaml(billion_laughs(), "bomb.yaml")
    assert time.perf_counter() - t0 < 0.5
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - rss0 < 50 * 1024  # KiB


def test_ordinary_aliases_still_work_and_the_root_node_gives_lines():
    data, root = load_yaml("base: &b {speed: 5}\nother: *b\nlist:\n  - 1\n", "ok.yaml")
    assert data == {"base": {"speed": 5}, "other": {"speed": 5}, "list": [1]}
    assert root.value[2][1].start_mark.line == 3


@pytest.mark.parametrize("text, problem", [
    ("a: 1\nb: 2\na: 3\n", r"^f.yaml:3: duplicate key 'a'$"),
    ("a: &x [*x]\n", r"^f.yaml:1: an alias refers to a node that contains it"),
    ("a: [1, 2\n", r"^f.yaml:2: malformed YAML: "),
    ("x: " + "[" * 100 + "]" * 100 + "\n", r"^f.yaml:1: nested more than 64 levels deep$"),
    ("x: " + "[" * 5000 + "]" * 5000 + "\n", r"^f.yaml:1: malformed YAML: "),  # libyaml's own cap
])
def test_malformed_or_hostile_yaml_is_one_line_naming_file_and_line(text, problem):
    with pytest.raises(YamlError, match=problem) as e:
        load_yaml(text, "f.yaml")
    assert "\n" not in str(e.value)


def test_merge_keys_are_not_duplicate_keys():
    data, _ = load_yaml("b: &b {x: 1}\nc:\n  <<: *b\n  y: 2\n", "m.yaml")
    assert data["c"] == {"x": 1, "y": 2}


def test_an_oversized_file_is_refused_before_it_is_read(tmp_path):
    big = tmp_path / "big.yaml"
    with big.open("wb") as f:
        f.truncate(MAX_YAML_BYTES + 1)  # sparse: costs no disk
    with pytest.raises(YamlError, match=rf"^{big}: {MAX_YAML_BYTES + 1} bytes, more than"):
        read_yaml_text(big, "scenario")


def test_binary_and_missing_files_name_the_file(tmp_path):
    binary = tmp_path / "bin.yaml"
    binary.write_bytes(b"\xff\xfe\x00garbage")
    with pytest.raises(YamlError, match=rf"^{binary}: not UTF-8 text"):
        read_yaml_text(binary)
    with pytest.raises(YamlError, match=r"no such suite file"):
        read_yaml_text(tmp_path / "none.yaml", "suite")


def test_first_non_finite_names_the_location():
    assert first_non_finite({"a": [1.0, {"b": math.nan}]})[0] == ("a", 1, "b")
    assert first_non_finite({"a": [1.0, 2, "x", None]}) is None
    assert first_non_finite([0.0, -math.inf]) == ((1,), -math.inf)
