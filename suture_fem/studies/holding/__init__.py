"""Holding strength: the pull at which the tissue tears at a cone or the thread breaks (``suture-fem holding``)."""
