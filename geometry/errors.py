"""The one exception type for user mistakes.

Every bad input (a missing file, a negative thickness, a NaN column) is raised
as :class:`InputError` naming the offending field or file; the command line
turns it into exit status 2 and a one-line message, never a traceback.
"""


class InputError(ValueError):
    """A user mistake: ``field`` names the field or file, ``message`` what was expected."""

    def __init__(self, field: str, message: str):
        self.field = str(field)
        self.message = str(message)
        super().__init__(f"{self.field}: {self.message}")
