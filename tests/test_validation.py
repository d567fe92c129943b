"""The shared entry-point checks of truthbench._validation."""

from __future__ import annotations

import math

import pytest

from truthbench._validation import (
    MAX_NAME_LENGTH,
    available_memory_bytes,
    check_name,
    check_number,
    check_output_file,
    format_bytes,
    is_safe_name,
    read_text,
)


@pytest.mark.parametrize("name", ["quickstart", "hub_beam", "t3_hub_0.3Nm", "A-1", "x" * 64])
def test_portable_names(name):
    assert check_name("campaign.name", name) == name


@pytest.mark.parametrize("name", ["", ".", "..", "../x", "../../x", "/tmp/x", "a/b", "a\\b",
                                  "a b", "name.", "-lead", "x" * 65, "caf\u00e9", 12, None])
def test_names_that_are_paths_or_unsafe_are_refused(name):
    with pytest.raises(ValueError, match=r"'campaign.name' must be a name of 1 to 64 "):
        check_name("campaign.name", name)


def test_test_names_may_hold_spaces_and_bars_but_not_separators():
    assert is_safe_name("fourth | bar", portable=False)
    assert is_safe_name("t3 hub 0.3 Nm", portable=False)
    for bad in ("", ".", "..", "a/b", "a\\b", " lead", "trail ", "a\nb", "x" * 65):
        assert not is_safe_name(bad, portable=False), bad
    assert MAX_NAME_LENGTH == 64


def test_check_number_refuses_non_finite_and_huge_integers():
    assert check_number("x", 2) == 2.0
    for bad in (math.inf, math.nan, 10**400, True, "1"):
        with pytest.raises(ValueError, match="'x' must be a finite number"):
            check_number("x", bad)


def test_read_text(tmp_path):
    ok = tmp_path / "ok.toml"
    ok.write_bytes(b"\xef\xbb\xbfname = 1\n")  # a byte-order mark is dropped
    assert read_text(ok, what="campaign file") == "name = 1\n"
    cases = {
        "latin1.toml": (b"a = 1\nname = 'caf\xe9'\n", r"not UTF-8 text: byte 0xe9 at offset "
                                                      r"17 \(line 2\)"),
        "r.h5": (b"\x89HDF\r\n\x1a\n" + bytes(8), r"is an HDF5 file"),
    }
    for name, (data, match) in cases.items():
        (tmp_path / name).write_bytes(data)
        with pytest.raises(ValueError, match=match):
            read_text(tmp_path / name, what="campaign file")
    with pytest.raises(ValueError, match="is a directory; expected a campaign file"):
        read_text(tmp_path, what="campaign file")
    with pytest.raises(ValueError, match="campaign file not found"):
        read_text(tmp_path / "none", what="campaign file")


def test_check_output_file(tmp_path):
    assert check_output_file("--out", tmp_path / "new" / "x.h5", (".h5",), what="file") \
        == tmp_path / "new" / "x.h5"
    with pytest.raises(ValueError, match=r"'--out' must be a file ending in \.h5 or \.hdf5; "
                                         r"got .*x\.uff'; use export"):
        check_output_file("--out", tmp_path / "x.uff", (".h5", ".hdf5"), what="file",
                          hint="use export")
    (tmp_path / "d.h5").mkdir()
    with pytest.raises(ValueError, match="is a directory"):
        check_output_file("--out", tmp_path / "d.h5", (".h5",), what="file")
    (tmp_path / "f").write_text("")
    with pytest.raises(ValueError, match="is a file, so"):
        check_output_file("--out", tmp_path / "f" / "x.h5", (".h5",), what="file")


def test_memory_and_bytes():
    avail = available_memory_bytes()
    assert avail is None or avail > 0
    assert format_bytes(512) == "512 B"
    assert format_bytes(1536) == "1.5 KiB"
    assert format_bytes(3 * 1024**3) == "3 GiB"
