"""`DataError`: a file vojax cannot read, named with the reason in one sentence;
`CurvesFailed`: an AFM file some of whose curves could not be read, with the others."""


class DataError(ValueError):
    """A problem with a data file, said in one sentence naming file, record, row and column."""


class CurvesFailed(DataError):
    """Some curves of an AFM file (a force map, a QI series) could not be read or analysed;
    the others were. `records`: the records of the curves that were read (a list of
    `Record`); `failures`: ``(curve name, reason)`` for each that was not. The batch writes
    the first as records and the second to ``failures.csv``, and goes on."""

    def __init__(self, path, records, failures):
        self.records, self.failures = list(records), list(failures)
        total = len(self.records) + len(self.failures)
        super().__init__(
            f"{path}: {len(self.failures)} of its {total} curves could not be read (the "
            f"other {len(self.records)} are in this error's `records`, the reasons in its "
            f"`failures`); the first's reason: {self.failures[0][1]}"
        )
