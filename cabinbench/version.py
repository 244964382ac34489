"""The benchmark's version: every record carries it, and the package metadata reads it here."""

__version__ = "0.1.0"
