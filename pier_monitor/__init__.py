"""Physics-informed damage identification of reinforced-concrete bridge piers."""

__version__ = "0.1.0"
