"""The failures the add-on shows the user: each one line, as the renderer's own `error:` lines."""

from __future__ import annotations


class CubistError(Exception):
    """A failure to show the user as it is: `str(error)` is one line."""


class BinaryNotFound(CubistError):
    pass


class SettingError(CubistError):
    """A panel value the renderer cannot take (caught before running it)."""


class RendererError(CubistError):
    """The renderer exited with an error; the message is its one-line `error:` text."""

    def __init__(self, message: str, returncode: int):
        super().__init__(message)
        self.returncode = returncode


class Cancelled(CubistError):
    def __init__(self):
        super().__init__("render cancelled")
