"""The CSV rows the writers format: the text numpy's ``savetxt`` writes for the same columns and formats (numpy is
the reference), whatever the values and however many rows."""

import io

import numpy as np
import pytest

from plant.data.writers import CSV_CHUNK_ROWS, csv_rows

FORMATS = ["%.10g", "%.9f", "%.9g", "%.12g"]


def savetxt(columns, formats):
    buf = io.StringIO()
    np.savetxt(buf, columns, fmt=formats, delimiter=",")
    return buf.getvalue()


@pytest.mark.parametrize("n_rows", [0, 1, 7, CSV_CHUNK_ROWS, CSV_CHUNK_ROWS + 1, 2 * CSV_CHUNK_ROWS + 5])
def test_rows_are_numpys_savetxt_text(n_rows):
    rng = np.random.default_rng(n_rows)
    columns = rng.standard_normal((n_rows, 4)) * 10.0 ** rng.integers(-12, 12, (n_rows, 4))
    assert csv_rows(columns, FORMATS) == savetxt(columns, FORMATS)


def test_values_at_the_edges_of_floating_point_are_written_as_numpy_writes_them():
    edge = np.array([np.nan, np.inf, -np.inf, -0.0, 0.0, 5e-324, -2.2250738585072014e-308, 1.7976931348623157e308,
                     0.1 + 0.2, 123456789.123456789, -1e-10, 2**53 + 1.0])
    columns = np.column_stack([edge, edge[::-1], np.roll(edge, 3), np.roll(edge, 7)])
    assert csv_rows(columns, FORMATS) == savetxt(columns, FORMATS)


def test_a_format_per_column_is_required():
    with pytest.raises(ValueError, match="formats"):
        csv_rows(np.zeros((3, 2)), ["%.9g"])
