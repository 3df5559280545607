"""A history that stops a run as a kill would: shared by the resume tests (serial and MPI)."""

from ngsgel.output import History


class Killed(Exception):
    pass


class KilledHistory(History):
    """Stops the run, as a kill would, right after writing its row number ``at``: the point is
    recorded, its checkpoint not yet written."""

    def __init__(self, path, at: int):
        super().__init__(path)
        self.at = at

    def append(self, row) -> None:
        super().append(row)
        if len(self.rows) == self.at:
            raise Killed
