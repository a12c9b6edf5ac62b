"""The shipped detector and its model card, as package data (``importlib.resources``)."""
