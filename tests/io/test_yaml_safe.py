"""camcmm.yamlfile: the one YAML loader refuses bombs, duplicate keys, bad bytes, size.

Limits are checked by counts (nodes, bytes, traced memory), never by time.
"""

from __future__ import annotations

import tracemalloc

import pytest

from camcmm.api import InputError, YamlError, load_yaml, read_yaml


def _laughs(levels: int = 9, fan: int = 9) -> str:
    """The classic 'billion laughs': ``fan ** levels`` strings from a few hundred bytes."""
    names = "abcdefghijklmnop"[: levels + 1]
    lines = [f"{names[0]}: &{names[0]} [{', '.join(['lol'] * fan)}]"]
    for prev, cur in zip(names, names[1:]):
        lines.append(f"{cur}: &{cur} [{', '.join(['*' + prev] * fan)}]")
    return "\n".join(lines) + "\n"


def test_billion_laughs_refused_with_little_memory():
    text = _laughs()
    assert len(text) < 500  # 9**10 (3.5e9) strings when expanded
    tracemalloc.start()
    try:
        with pytest.raises(YamlError) as err:
            load_yaml(text, name="lol.yaml")
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith("lol.yaml:") and "alias" in msg
    assert peak < 2_000_000, peak  # bytes: a few node graphs, nothing expanded


def test_alias_limit_is_a_count_of_expanded_nodes():
    # Expanded, 'b' holds 4 copies of 'a' (3 nodes each) = 12 nodes of which 3 distinct.
    text = "a: &a [1, 2]\nb: [*a, *a, *a, *a]\n"
    assert load_yaml(text) == {"a": [1, 2], "b": [[1, 2]] * 4}
    # 4 aliases of a 3-node list add 4*3 = 12 nodes beyond the distinct ones
    assert load_yaml(text, max_alias_nodes=12)["b"][3] == [1, 2]
    with pytest.raises(YamlError, match="expand to more than 11 extra nodes"):
        load_yaml(text, max_alias_nodes=11)


def test_merge_key_bomb_refused():
    text = "a: &a {x: 1, y: 2}\n" + "".join(
        f"{c}: &{c} {{<<: [{', '.join(['*' + p] * 8)}]}}\n" for p, c in zip("abcdefgh", "bcdefghi")
    )
    with pytest.raises(YamlError, match="alias"):
        load_yaml(text, name="merge.yaml")


def test_recursive_alias_refused():
    for text in ("a: &x [1, *x]\n", "a: &x {b: *x}\n"):
        with pytest.raises(YamlError, match="refers to"):
            load_yaml(text)


def test_ordinary_anchors_and_merge_keys_still_work():
    text = "base: &b {speed: 2, axis: x}\nfast:\n  <<: *b\n  speed: 5\nsame: *b\n"
    assert load_yaml(text) == {
        "base": {"speed": 2, "axis": "x"},
        "fast": {"speed": 5, "axis": "x"},
        "same": {"speed": 2, "axis": "x"},
    }


def test_duplicate_mpe_in_a_vdi_plan_refused_naming_key_and_line(tmp_path):
    plan = tmp_path / "plan.yaml"
    plan.write_text(
        "standard: vdi2634-2\nmpe:\n  PF: 0.05\n  SD: 0.1\nsystem: s\nmpe:\n  PF: 5\n  SD: 5\n", encoding="utf-8"
    )
    with pytest.raises(InputError) as err:
        read_yaml(plan)
    msg = str(err.value)
    assert "'mpe'" in msg and "line 6" in msg and "line 2" in msg and str(plan) in msg and "\n" not in msg


def test_duplicate_keys_compare_as_values():
    for text in ("1: a\n1.0: b\n", "yes: 1\ntrue: 2\n", "a: 1\nb: {c: 1, c: 2}\n"):
        with pytest.raises(YamlError, match="duplicate key"):
            load_yaml(text)


def test_duplicate_key_in_the_vdi_plan_reader(tmp_path):
    from camcmm_plugins.vdi2634.plan import read_source

    plan = tmp_path / "plan.yaml"
    plan.write_text("standard: vdi2634-2\nmpe: {PF: 0.05}\nmpe: {PF: 5}\n", encoding="utf-8")
    with pytest.raises(InputError, match="duplicate key 'mpe'"):
        read_source(plan)


def test_bad_utf8_is_one_line_naming_file_and_line(tmp_path):
    f = tmp_path / "budget.yaml"
    f.write_bytes(b"quantity: length\nunit: \xff\xfeum\n")
    with pytest.raises(YamlError) as err:
        read_yaml(f, name="budget.yaml")
    assert str(err.value) == "budget.yaml: not UTF-8 text (byte 0xff at line 2)"


def test_byte_order_marks_accepted():
    assert load_yaml(b"\xef\xbb\xbfa: 1\n") == {"a": 1}
    assert load_yaml("a: 1\n".encode("utf-16")) == {"a": 1}


def test_oversize_refused_before_reading(tmp_path):
    f = tmp_path / "big.yaml"
    f.write_bytes(b"a: " + b"x" * 2000 + b"\n")
    with pytest.raises(YamlError, match="larger than the 1000 bytes"):
        read_yaml(f, max_bytes=1000)
    with pytest.raises(YamlError, match="larger than"):
        load_yaml("a: " + "é" * 600, max_bytes=1000)  # 1203 bytes in UTF-8
    assert read_yaml(f, max_bytes=4000)["a"] == "x" * 2000


def test_syntax_errors_and_unsafe_tags_are_one_line():
    cases = {
        "a: [1, 2\n": "line 2",
        "a: 1\n---\nb: 2\n": "single document",
        "a: !!python/object/apply:os.system [echo]\n": "constructor",
        "a: \x00\n": "line 1",
        "n: 1" + "0" * 5000 + "\n": "cannot be read",
    }
    for text, part in cases.items():
        with pytest.raises(YamlError) as err:
            load_yaml(text, name="x.yaml")
        msg = str(err.value)
        assert msg.startswith("x.yaml:") and part in msg and "\n" not in msg, msg


def test_deep_nesting_refused():
    with pytest.raises(YamlError, match="nested deeper than 100"):
        load_yaml("[" * 150 + "]" * 150)
    assert load_yaml("[" * 50 + "]" * 50) is not None


def test_missing_file_and_empty_document(tmp_path):
    with pytest.raises(YamlError, match="cannot read"):
        read_yaml(tmp_path / "nope.yaml")
    assert load_yaml("") is None and load_yaml("# only a comment\n") is None


def test_no_raw_yaml_loading_left_in_the_code():
    """Every YAML document is read through camcmm.yamlfile (a test, so a new one is not added)."""
    import re
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    pattern = re.compile(r"\byaml\.(safe_load|load|full_load|unsafe_load|load_all|safe_load_all|compose)\(")
    hits = [
        f"{p.relative_to(root)}:{i}"
        for base in ("app", "plugins")
        for p in (root / base).rglob("*.py")
        if p.name != "yamlfile.py"
        for i, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1)
        if pattern.search(line)
    ]
    assert not hits, hits


def test_uncertainty_page_refuses_a_small_bomb_upload_and_keeps_working(tmp_path):
    """The reported case: a few hundred bytes uploaded as a budget must not grow the server."""
    pytest.importorskip("trame")
    pytest.importorskip("pyvista")
    import os

    from camcmm.gui.app import build, close

    server, _ = build(f"test-yaml-{os.getpid()}", tmp_path / "proj")
    try:
        server.state.ready()
        page, s = server.pages["uncertainty"], server.state
        bomb = (_laughs(levels=7) + "contributions: *h\n").encode()
        assert len(bomb) < 400  # 9**8 = 4.3e7 strings as rows
        rows_before = list(s.unc_b_rows)
        assert page.load_budget(bomb, "lol.yaml") is False
        assert s.unc_error.startswith("lol.yaml:") and "alias" in s.unc_error
        assert s.unc_b_rows == rows_before
        assert page.load_budget(b"quantity: L\ncontributions: []\nquantity: M\n", "dup.yaml") is False
        assert "duplicate key 'quantity'" in s.unc_error
        assert page.load_system("cameras: &c [1]\ncameras: *c\n", "system description") is False
        assert s.unc_error.startswith("system description: duplicate key 'cameras'")
    finally:
        close(server)
