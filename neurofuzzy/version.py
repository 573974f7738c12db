"""The toolkit's version (its own module, so that the parts that record it in their files need
not import the package's top level)."""

__version__ = "0.1.0"
