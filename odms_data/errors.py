"""The project's exceptions: each one's message is a single line a user can act on."""


class OdmsError(Exception):
    """Base class: a problem with the user's input or data, reported without a traceback.

    The message says what is wrong; `fix`, when there is one, names the remedy (e.g. "overwrite")
    for a front end to spell with its own options (the command line's: cli/fixes.py). `option`,
    when there is one, is the library's name of the input the message starts with (e.g. "classes"),
    which a front end may write as it names that input (the command line: its flag)."""

    def __init__(self, *args: object, fix: str = "", option: str = "") -> None:
        super().__init__(*args)
        self.fix = fix
        self.option = option


class InputError(OdmsError):
    """A file, argument or value given by the user is malformed; the message names it."""


class StoreError(OdmsError):
    """A store is missing, incomplete, locked, unreadable or inconsistent."""


class StoreExistsError(StoreError):
    """The output store exists and `overwrite` was not asked for."""


class OutputLockedError(OdmsError):
    """Another process holds the write lock of an output."""


class StoreLockedError(StoreError, OutputLockedError):
    """Another process holds the write lock of the store."""


class DigestMismatchError(OdmsError):
    """A store's content digest differs from the one its split manifest records."""


class OutputExistsError(OdmsError):
    """An output file exists and `overwrite` was not asked for, or is something odms-data does not replace."""


class WriteError(OdmsError):
    """An output could not be written (a full disk, no permission); the message names its path."""


class MissingExtraError(OdmsError, ImportError):
    """An optional dependency is not installed; the message names the extra that installs it
    (extras.py). An ImportError too, for code that imports a loader and catches that."""

    def __init__(self, message: str, name: str) -> None:
        super().__init__(message)
        self.name = name  # the missing module, as ImportError names it


class Interrupted(KeyboardInterrupt):
    """A stop asked for by a signal (SIGINT, SIGTERM or SIGHUP), handled as Ctrl-C is."""

    def __init__(self, signum: int) -> None:
        super().__init__(f"signal {signum}")
        self.signum = signum
