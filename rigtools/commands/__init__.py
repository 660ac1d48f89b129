"""Sub-commands of ``rig``: one module per command, each with ``register(subparsers)``."""

import argparse

SKIP_DAMAGED_HELP = (
    "read a recording rig check rejects, leaving each damaged point or channel out with a note "
    "(without it such a file is refused in one line naming its first problem)"
)


def add_skip_damaged(parser: argparse.ArgumentParser) -> None:
    """The readers' ``--skip-damaged`` (``rig``'s entry point applies it to every recording the
    command opens: ``rigtools.recording.reader.reading_damaged``)."""
    parser.add_argument("--skip-damaged", action="store_true", help=SKIP_DAMAGED_HELP)
