"""`pendkit.safe_write`: nothing is written through a symbolic link the kit did not make, at the file or at a
folder below the one the user named; each refusal is one line naming the path."""

import os

import pytest

from pendkit import safe_write
from pendkit.safe_write import LinkRefused, check_no_links, open_new, replacing, write_bytes, write_text

pytestmark = pytest.mark.skipif(not hasattr(os, "symlink") or os.name == "nt", reason="symbolic links (POSIX)")


@pytest.fixture(params=["held folders", "lstat checks"])
def mode(request, monkeypatch):
    """Both ways: folders held open (POSIX) and the lstat checks Windows falls back to."""
    if request.param == "lstat checks":
        monkeypatch.setattr(safe_write, "_HELD_FOLDERS", False)
    return request.param


@pytest.fixture
def outside(tmp_path):
    notes = tmp_path / "notes.txt"
    notes.write_text("the instructor's notes")
    (tmp_path / "out").mkdir()
    return notes


def test_a_file_is_written_whole_with_its_folders_and_no_temporary_left(tmp_path, mode):
    path = write_text(tmp_path / "out" / "a" / "b" / "table.csv", "x,y\n", base=tmp_path / "out")
    assert path.read_text() == "x,y\n"
    write_bytes(path, b"again")
    assert path.read_bytes() == b"again" and os.listdir(path.parent) == ["table.csv"]


def test_a_link_at_the_file_is_refused_and_what_it_points_at_is_left_alone(tmp_path, outside, mode):
    link = tmp_path / "out" / "table.csv"
    link.symlink_to(outside)
    for write in (lambda: write_text(link, "x"), lambda: write_bytes(link, b"x"), lambda: open_new(link),
                  lambda: check_no_links(link)):
        with pytest.raises(LinkRefused, match=f"refused to write {link}: it is a symbolic link") as error:
            write()
        assert "\n" not in str(error.value)
    assert outside.read_text() == "the instructor's notes" and link.is_symlink()
    assert os.listdir(link.parent) == ["table.csv"]  # no temporary file left either


def test_a_link_in_place_of_a_folder_below_the_named_one_is_refused(tmp_path, outside, mode):
    (tmp_path / "out" / "alice").symlink_to(tmp_path)
    path = tmp_path / "out" / "alice" / "notes.txt"
    with pytest.raises(LinkRefused, match=f"{tmp_path / 'out' / 'alice'} is a symbolic link"):
        write_text(path, "x", base=tmp_path / "out")
    with pytest.raises(LinkRefused):
        check_no_links(path, tmp_path / "out")
    assert outside.read_text() == "the instructor's notes"


def test_the_folder_the_user_named_may_itself_be_a_link(tmp_path, mode):
    (tmp_path / "real").mkdir()
    (tmp_path / "named").symlink_to(tmp_path / "real")
    write_text(tmp_path / "named" / "sub" / "f.txt", "ok", base=tmp_path / "named")
    assert (tmp_path / "real" / "sub" / "f.txt").read_text() == "ok"


def test_a_link_planted_while_the_file_is_written_is_refused_too(tmp_path, outside, mode):
    link = tmp_path / "out" / "table.csv"
    with pytest.raises(LinkRefused, match="it is a symbolic link"):
        with replacing(link) as handle:
            handle.write("new")
            link.symlink_to(outside)
    assert outside.read_text() == "the instructor's notes"
    assert os.listdir(link.parent) == ["table.csv"]
