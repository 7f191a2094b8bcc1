"""The user-facing error of the ``physmind`` command line (its own module so commands and ``python -m physmind.cli`` share one class)."""


class CliError(Exception):
    """A user-facing error: printed as one line, exit code 2, no traceback."""
