"""Host-side I/O of recorded tests: never jitted."""

from ._records import DataError as DataError, Record as Record, load_records as load_records
