"""Paper reproductions: one module per paper (its data, published numbers and reproduction)."""

from . import mei2010

CASES = {mei2010.NAME: mei2010}

__all__ = ["CASES"]
