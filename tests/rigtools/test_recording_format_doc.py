"""docs/recording-format.md describes the files as the schema defines them: each table of the
document lists exactly the names of its schema table, and the examples use today's names."""

import re
from pathlib import Path

import pytest

from rigtools.recording import schema
from rigtools.vocabulary import MODEL_BACKENDS, V1_PARAMETER_RENAMES

DOC = Path(__file__).resolve().parents[2] / "docs" / "recording-format.md"


def _sections() -> dict[str, list[list[str]]]:
    """``{heading: [table, ...]}`` with each table the list of its first-column names."""
    out: dict[str, list[list[str]]] = {}
    heading, table = "", None
    for line in DOC.read_text().splitlines():
        if line.startswith("#"):
            heading, table = line.lstrip("# ").strip(), None
            continue
        cell = re.match(r"^\| `([^`]+)` \|", line)
        if cell:
            if table is None:
                table = []
                out.setdefault(heading, []).append(table)
            table.append(cell.group(1))
        elif not line.startswith("|"):
            table = None
    return out


SECTIONS = _sections()


@pytest.mark.parametrize(
    "heading, index, names",
    [
        ("Root attributes (all required)", 0, schema.ROOT_ATTRS),
        ("Root attributes (all required)", 1, schema.OPTIONAL_ROOT_ATTRS),
        ("Point groups `/points/NNNN`", 0, schema.POINT_ATTRS),
        ("Point groups `/points/NNNN`", 1, schema.STANDARD_PARAMETERS),
        (
            "Channel datasets `/points/NNNN/<channel>`",
            0,
            {**schema.CHANNEL_ATTRS, **schema.MEASURED_CHANNEL_ATTRS},
        ),
    ],
)
def test_document_table_lists_the_schema_names(heading, index, names):
    assert SECTIONS[heading][index] == list(names)


def test_every_known_backend_is_documented():
    row = next(line for line in DOC.read_text().splitlines() if line.startswith("| `backend` |"))
    for backend in schema.KNOWN_BACKENDS:
        assert f"`{backend}`" in row
    assert set(MODEL_BACKENDS) <= set(schema.KNOWN_BACKENDS)


def test_no_old_parameter_name_outside_the_note_on_renames():
    for old, new in V1_PARAMETER_RENAMES.items():
        lines = [line for line in DOC.read_text().splitlines() if old in line]
        assert all(new in line for line in lines), lines  # only where the rename is explained
