"""``python -m pendtrack`` runs the CLI."""

from pendtrack.cli import main

main()
