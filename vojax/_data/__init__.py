"""Host-side I/O of recorded tests: never jitted."""

from ._records import DataError as DataError
from ._records import Record as Record
from ._records import load_records as load_records
