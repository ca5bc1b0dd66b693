"""The disk cache's root and its value entries: exact round trip, atomic writes, bad entries refused, pruning."""

from __future__ import annotations

import os
import time

import pytest
from hypothesis import given
from hypothesis import strategies as st

from ftc_mj.disk_cache import CACHE_ENV, SWITCH_ENV, cache_root, machine_tag, prune_values, read_value, write_value


def test_the_root_follows_the_environment(tmp_path, monkeypatch) -> None:
    monkeypatch.setenv(CACHE_ENV, str(tmp_path))
    monkeypatch.delenv(SWITCH_ENV, raising=False)
    assert cache_root() == tmp_path
    monkeypatch.setenv(SWITCH_ENV, "off")
    assert cache_root() is None
    monkeypatch.delenv(SWITCH_ENV)
    monkeypatch.delenv(CACHE_ENV)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache_root() == tmp_path / "xdg" / "ftc-mj"


@given(st.floats(allow_nan=False))
def test_a_value_comes_back_to_the_bit(value: float) -> None:
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "sub" / "k.json"
        write_value(path, "k", value)
        back = read_value(path, "k")
        assert back is not None and back.hex() == value.hex()
        assert [p.name for p in path.parent.iterdir()] == ["k.json"]  # no temporary left


def test_an_entry_of_another_key_or_damaged_is_refused_with_one_line(tmp_path, capsys) -> None:
    path = tmp_path / "k.json"
    assert read_value(path, "k") is None and capsys.readouterr().err == ""  # none yet: silent
    write_value(path, "other", 1.5)
    assert read_value(path, "k") is None
    for text in ("{", '{"key": "k"}', '{"key": "k", "value": "x"}', "x" * 5000):
        path.write_text(text)
        assert read_value(path, "k") is None
    err = capsys.readouterr().err.splitlines()
    assert len(err) == 5 and all("cannot be used" in line for line in err)


def test_a_write_that_fails_leaves_nothing(tmp_path) -> None:
    path = tmp_path / "k.json"
    path.mkdir()  # a folder in the entry's place
    write_value(path, "k", 2.0)
    assert path.is_dir() and sorted(p.name for p in tmp_path.iterdir()) == ["k.json"]


def test_prune_deletes_what_was_not_used_for_the_age(tmp_path) -> None:
    """Entries (and temporaries) older than the age go; a read refreshes an entry's age."""
    old, used, new = (tmp_path / f"{n}.json" for n in ("old", "used", "new"))
    for p in (old, used, new):
        write_value(p, p.stem, 1.0)
    stale = time.time() - 3600.0
    for p in (old, used):
        os.utime(p, (stale, stale))
    tmp = tmp_path / ".x.json.abc"
    tmp.write_text("")
    os.utime(tmp, (stale, stale))
    assert read_value(used, "used") == 1.0
    assert prune_values(tmp_path, 60.0) == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["new.json", "used.json"]


def test_the_machine_tag_names_the_versions() -> None:
    from importlib.metadata import version

    tag = machine_tag()
    assert f"numpy {version('numpy')}" in tag and f"numba {version('numba')}" in tag


@pytest.mark.parametrize("value", [0.0, -0.0, float("inf"), 7.316246323914863])
def test_special_values_round_trip(tmp_path, value: float) -> None:
    write_value(tmp_path / "k.json", "k", value)
    assert read_value(tmp_path / "k.json", "k").hex() == value.hex()
