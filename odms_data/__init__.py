"""odms-data: generate, store, import and score ODMS (object depth via motion and segmentation) data."""

__version__ = "0.1.0"
