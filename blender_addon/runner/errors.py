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


def temp_folder_error(e: OSError) -> str:
    """A temporary folder that cannot be made (the disk full, no permission), in words."""
    import tempfile

    return (f"cannot create a temporary folder in {tempfile.gettempdir()}: {e.strerror or e} (free some space "
            f"there, or point TMPDIR to a writable folder)")
