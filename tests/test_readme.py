"""The README stays true to the code it documents."""

from pathlib import Path

from pendtrack.artifacts import schemas_markdown
from pendtrack.cli import COMMANDS

README = (Path(__file__).resolve().parents[1] / "README.md").read_text()


def test_readme_embeds_the_artifact_tables_verbatim():
    assert schemas_markdown() in README


def test_readme_starts_with_demo_and_test_and_lists_every_command():
    head = README[:1200]
    assert "make demo" in head and "make test" in head
    for name in COMMANDS:
        assert f"`{name}`" in README, name
