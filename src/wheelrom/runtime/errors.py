"""Errors for bad user input (mesh files, node sets, result files).

Configuration keys raise :class:`wheelrom.config.ConfigError`; both make the CLI exit with
status 2 and a message naming the offending file, key or node set.
"""


class InputError(ValueError):
    """Bad input other than configuration keys."""


class OutputExists(InputError):
    """An output file exists and neither resuming nor overwriting it was asked for."""

    def __init__(self, path: str):
        self.path = path
        super().__init__(f"{path} exists: resume to complete it, or overwrite it")


class Interrupted(Exception):
    """A computation stopped on Ctrl-C / SIGTERM after saving what was finished; the message
    says what is kept and how to go on. The CLI exits with status 130."""


class DiskFull(Exception):
    """The disk filled while a file was written: the message names the file and the errno,
    and what was already flushed is kept (a sweep or study resumes with ``--resume``). The
    CLI exits with status 1, one line, no traceback."""
