"""The version of odms-data, in a module that imports nothing."""

__version__ = "0.1.0"
