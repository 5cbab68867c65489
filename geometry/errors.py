"""The two exception types every layer raises for a failure a user should hear about.

Every bad input (a missing file, a negative thickness, a NaN column) is raised
as :class:`InputError` naming the offending field or file; the command line
turns it into exit status 2 and a one-line message, never a traceback. A model that
cannot produce a trustworthy result for good inputs (an integrator giving up, a result
breaking its own invariants) raises :class:`ModelFailure`: exit status 1, one line.
"""


class InputError(ValueError):
    """A user mistake: ``field`` names the field or file, ``message`` what was expected."""

    def __init__(self, field: str, message: str):
        self.field = str(field)
        self.message = str(message)
        super().__init__(f"{self.field}: {self.message}")


class ModelFailure(RuntimeError):
    """A model could not give a trustworthy result (integration failed, invariants broken)."""

    model_failure = True          # the command line reports it as a failed model, not a bug
