"""Git LFS pointers: the small text file a clone without ``git lfs`` holds in place of a video or a table.

A user's repository often keeps its videos and logs in Git LFS; cloned without it, each is a
three-line pointer ("version https://git-lfs.github.com/spec/v1", "oid sha256:...", "size N"),
which no reader can make sense of. The readers name it instead of failing on its contents.
"""

from __future__ import annotations

from pathlib import Path

LFS_POINTER = b"version https://git-lfs.github.com/spec/v1"  # first line of a file Git LFS left in its place


def is_lfs_pointer(path: str | Path) -> bool:
    """True if ``path`` is a Git LFS pointer (False if it cannot be read)."""
    try:
        with Path(path).open("rb") as fh:
            return fh.read(len(LFS_POINTER)) == LFS_POINTER
    except OSError:
        return False


def lfs_message(what: str) -> str:
    """The error text for a pointer in place of ``what`` ("the video", "the table")."""
    return f"a Git LFS pointer, not {what} itself (fetch it: git lfs pull)"
