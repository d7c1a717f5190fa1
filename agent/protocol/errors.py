"""The one exception type that the command line turns into a one-line error message."""


class UserError(Exception):
    """Bad input from the user (a file, an argument, a scenario): printed as one line, exit code 1."""
