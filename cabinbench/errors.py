"""The mistakes a user can make, on the ground floor: every command catches :class:`UserError`
and prints it as one line with exit status :data:`EXIT_USAGE`.

Library code raises the subclass that names what was wrong (a layout file, a baseline, an
argument); its message names the file or argument and the fix.
"""

EXIT_USAGE = 2
EXIT_INTERRUPTED = 130  # the shell's status for a process ended by Ctrl-C


class UserError(Exception):
    """A mistake in what the user gave; the message names the file or argument and the fix."""


class UsageError(UserError):
    """A user mistake a command finds after parsing: an argument, an output path, a submission."""


class LayoutError(UserError, ValueError):
    """A layout file is invalid. The message names the file, the field, the problem and the fix."""

    def __init__(self, source: str, field_name: str, problem: str, fix: str):
        self.source, self.field_name, self.problem, self.fix = source, field_name, problem, fix
        super().__init__(f"{source}: field '{field_name}': {problem}. Fix: {fix}")


class BaselineError(UserError, ValueError):
    """A baseline name or class that cannot be loaded; the message says what to give instead."""
