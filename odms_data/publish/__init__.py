"""Publishing stores: the Hugging Face Hub export (hub_export.py) with its dataset card and
Croissant metadata (hub_metadata.py), and the contact sheet of an example (contact_sheet.py)."""
