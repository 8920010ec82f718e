"""A store's rows for a loader: the store is opened lazily in each process (a worker that
unpickles the source opens its own), and its length is read once in the parent."""

from __future__ import annotations

import os

from ..store.reader import Store, open_store


class StoreRows:
    """The store at `path`, opened on first use in each process; `len` is its number of examples."""

    def __init__(self, path: str) -> None:
        self.path = str(path)
        self._store: Store | None = None
        self._pid: int | None = None
        self._len = len(self.store)

    @property
    def store(self) -> Store:
        if self._store is None or self._pid != os.getpid():
            self._store, self._pid = open_store(self.path), os.getpid()
        return self._store

    def __getstate__(self) -> dict:
        return {**self.__dict__, "_store": None, "_pid": None}

    def __len__(self) -> int:
        return self._len
