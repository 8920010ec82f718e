"""The project's exceptions: each one's message is a single line a user can act on."""


class OdmsError(Exception):
    """Base class: a problem with the user's input or data, reported without a traceback."""


class InputError(OdmsError):
    """A file, argument or value given by the user is malformed; the message names it."""


class StoreError(OdmsError):
    """A store is missing, incomplete, locked, unreadable or inconsistent."""


class StoreExistsError(StoreError):
    """The output store exists and `overwrite` was not asked for."""


class StoreLockedError(StoreError):
    """Another process holds the write lock of the store."""


class DigestMismatchError(OdmsError):
    """A store's content digest differs from the one its split manifest records."""
