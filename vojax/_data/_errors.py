"""`DataError`: a file vojax cannot read, named with the reason in one sentence."""


class DataError(ValueError):
    """A problem with a data file, said in one sentence naming file, record, row and column."""
